"""The decoupled critic's reply: a one-line SUMMARY and ISSUES tagged [HIGH|MED|LOW].

The critic is a separate single-turn vision call (its own system prompt; never a turn of the
fixer). Its reply reads::

    SUMMARY: six-wheeled rover, right side complete; the left rear wheel floats.
    ISSUES:
    - [HIGH] wheel_lr: floats 20 mm below its bogie; lower the bogie's axle frame by 20 mm.
    - [LOW] mast: a little short against the reference; raise mast_h to about 300 mm.

A defect between two parts (a gap, an overlap, a mate that does not line up) names both,
``- [HIGH] wheel_lr+bogie_l: ...``, the part to change first; the fixer may edit either.
``ISSUES: none`` (or no issue lines) means nothing is left to fix. :func:`parse_critique`
accepts bullets or numbers, ``part:`` or ``part -`` and any case of the tag, and reports a reply
with no SUMMARY or with issue lines it cannot read as :class:`CritiqueError`, so the call can be
retried with the reason.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal, cast

from ..errors import ProceduraError

Severity = Literal["HIGH", "MED", "LOW"]
SEVERITIES: tuple[Severity, ...] = ("HIGH", "MED", "LOW")
_SUMMARY_RE = re.compile(r"^\s*\**\s*SUMMARY\s*\**\s*:\s*\**\s*(.+?)\s*$", re.I | re.M)
_ISSUES_RE = re.compile(r"^\s*\**\s*ISSUES\s*\**\s*:\s*\**\s*(.*)$", re.I | re.M)
_ISSUE_RE = re.compile(
    r"^\s*(?:[-*+]|\d+[.)])?\s*\[\s*(HIGH|MED|MEDIUM|LOW)\s*\]\s*(`?[A-Za-z0-9_.]+`?(?:\s*\+\s*`?[A-Za-z0-9_.]+`?)?)\s*(?::|-|–|—)\s*(.+?)\s*$",
    re.I)
_NONE_RE = re.compile(r"^\s*(none|no issues?|nothing( left)?( to fix)?)\.?\s*$", re.I)


class CritiqueError(ProceduraError):
    """A critic reply that does not follow the format (the retry is told why)."""


@dataclass(frozen=True)
class Issue:
    """One diagnosed defect: severity, the part responsible, a one-sentence fix direction, and
    for a defect between two parts the other part (``other``; the fixer may edit either)."""

    severity: Severity
    part: str
    fix: str
    other: str | None = None

    @property
    def parts(self) -> tuple[str, ...]:
        """The part to change first, then the other part of a pair defect."""
        return (self.part,) if self.other is None else (self.part, self.other)

    def line(self) -> str:
        return f"[{self.severity}] {'+'.join(self.parts)}: {self.fix}"


@dataclass(frozen=True)
class Critique:
    """A parsed critic reply."""

    summary: str
    issues: tuple[Issue, ...]

    @property
    def high(self) -> tuple[Issue, ...]:
        return tuple(i for i in self.issues if i.severity == "HIGH")

    def top(self) -> Issue | None:
        """The issue to fix first (the highest severity, then the critic's order)."""
        return min(self.issues, key=lambda i: SEVERITIES.index(i.severity), default=None)

    def text(self) -> str:
        body = "\n".join(f"- {i.line()}" for i in self.issues) or "none"
        return f"SUMMARY: {self.summary}\nISSUES:\n{body}"


def parse_critique(text: str, *, parts: set[str] | None = None) -> Critique:
    """Parse a critic reply.

    Args:
        text: the reply.
        parts: the program's part names: an issue naming another module is an error (the critic
            must localise every defect to a part the fixer can edit).

    Raises:
        CritiqueError: no SUMMARY line, an issue line without a tag or a part, an unknown part.
    """
    m = _SUMMARY_RE.search(text)
    if not m:
        raise CritiqueError("the critique has no 'SUMMARY: ...' line")
    summary = m.group(1).strip()
    head = _ISSUES_RE.search(text)
    if not head:
        raise CritiqueError("the critique has no 'ISSUES:' list (write 'ISSUES: none' if nothing is left)")
    rest = [head.group(1)] + text[head.end():].split("\n")
    issues: list[Issue] = []
    bad: list[str] = []
    for raw in rest:
        line = raw.strip()
        if not line or _NONE_RE.match(line) or line.startswith("```"):
            continue
        im = _ISSUE_RE.match(line)
        if not im:
            if line.startswith(("-", "*", "+", "[")) or re.match(r"\d+[.)]", line):
                bad.append(line[:80])
            continue
        tag = im.group(1).upper()
        severity = cast(Severity, "MED" if tag == "MEDIUM" else tag)  # the pattern allows only these
        named = [n.strip().strip("`").split(".")[0] for n in im.group(2).split("+")]
        unknown = [n for n in named if parts is not None and n not in parts]
        if unknown:
            bad.append(f"{line[:60]} (no part {unknown[0]!r}; parts: {', '.join(sorted(parts or ()))})")
            continue
        if len(named) == 2 and named[0] == named[1]:
            named = named[:1]
        issues.append(Issue(severity, named[0], im.group(3), named[1] if len(named) == 2 else None))
    if bad:
        raise CritiqueError("issue lines must read '- [HIGH|MED|LOW] part_name: one-sentence fix' "
                            "(a defect between two parts: 'part_a+part_b: ...'); could not read: "
                            + "; ".join(bad))
    return Critique(summary, tuple(issues))
