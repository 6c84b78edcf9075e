"""Findings formatted as feedback for the model: part, line, exception, 1-3 lines of context.

Pure text, no kernel: the build loop sends :func:`format_feedback` back to the LLM after a failed
compile or gate, so every line names what to fix and where.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from ..findings import blocks as is_blocking
from ..program.model import Finding

#: Most findings listed in one feedback message (the rest are counted, not shown).
MAX_FINDINGS: int = 12


def locate(source: str, finding: Finding) -> int | None:
    """The 1-based line a finding refers to: its own ``line``, else the part's ``def`` or the mate.

    Args:
        source: the program text.
        finding: the finding to place.

    Returns:
        A line number inside ``source``, or None when nothing in the text matches.
    """
    lines = source.splitlines()
    if finding.line is not None and 1 <= finding.line <= len(lines):
        return finding.line
    patterns = []
    if finding.part:
        patterns.append(re.compile(rf"^\s*def\s+{re.escape(finding.part)}\s*\("))
    if finding.mate:
        patterns.append(re.compile(rf"""\bmate\(.*["']{re.escape(finding.mate)}"""))
        patterns.append(re.compile(rf"""["']{re.escape(finding.mate)}["']"""))
    for pat in patterns:
        for i, text in enumerate(lines, 1):
            if pat.search(text):
                return i
    return None


def context(source: str, line: int, *, around: int = 1) -> list[str]:
    """Up to ``2 * around + 1`` numbered lines of ``source`` centred on ``line`` (marked ``>``)."""
    lines = source.splitlines()
    lo, hi = max(1, line - around), min(len(lines), line + around)
    width = len(str(hi))
    return [f"{'>' if i == line else ' '} {i:>{width}} | {lines[i - 1]}" for i in range(lo, hi + 1)]


def _head(f: Finding, line: int | None) -> str:
    where = []
    if f.part:
        where.append(f"part {f.part}")
    if f.mate:
        where.append(f"mate {f.mate}")
    if line is not None:
        where.append(f"line {line}")
    measured = ""
    if f.value is not None:
        measured = f" (measured {f.value:.4g}" + (f", limit {f.limit:.4g})" if f.limit is not None else ")")
    prefix = f"[{f.severity}] {f.code}"
    return f"{prefix}: {', '.join(where)}: {f.message}{measured}" if where else f"{prefix}: {f.message}{measured}"


def format_finding(source: str | None, finding: Finding, *, around: int = 1) -> str:
    """One finding as a few lines: ``[severity] code: part P, line N: message (measured, limit)``
    followed by the numbered program context (``around`` lines either side, 0-1 recommended)."""
    line = locate(source, finding) if source else finding.line
    out = [_head(finding, line)]
    if source and line is not None:
        out.extend("    " + c for c in context(source, line, around=around))
    return "\n".join(out)


def format_feedback(source: str | None, findings: Sequence[Finding], *, around: int = 1,
                    limit: int = MAX_FINDINGS) -> str:
    """All findings (errors first, then warnings) as one message for the model.

    Args:
        source: the program text the findings refer to (None: no context lines).
        findings: compile or gate findings.
        around: context lines either side of the finding's line (1 gives 3 lines).
        limit: at most this many findings are written out; the rest are counted.

    Returns:
        The feedback text; ``""`` when there are no findings.
    """
    if not findings:
        return ""
    ordered = sorted(findings, key=lambda f: (not is_blocking(f),))
    blocks = [format_finding(source, f, around=around) for f in ordered[:limit]]
    if len(ordered) > limit:
        blocks.append(f"... and {len(ordered) - limit} more finding(s) not shown")
    return "\n\n".join(blocks)
