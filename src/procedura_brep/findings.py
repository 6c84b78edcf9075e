"""Findings: the one currency of every check (compile, gates, battery), and the one policy.

A :class:`Finding` is a problem found while compiling, gating or simulating: never an
exception. Whether a list of findings fails a build is decided here and nowhere else:
:func:`blocks` (one finding), :func:`blocking` (the ones that fail) and :func:`failed` (the
verdict). Every layer calls these instead of comparing severities itself (a test greps the
package for such comparisons).

Base layer: imports only :mod:`procedura_brep.config`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

from .config import SANDBOX

Severity = Literal["error", "warning", "info"]
#: Every severity, most severe first.
SEVERITIES: tuple[Severity, ...] = ("error", "warning", "info")
#: The severities that fail a build (the policy; warnings and infos are reported only).
BLOCKING: frozenset[str] = frozenset({"error"})
#: The severity of a finding (or a finding's dict) that does not say.
DEFAULT_SEVERITY: Severity = "error"


def cap_text(text: str, limit: int | None = None) -> str:
    """``text`` cut to ``config.SANDBOX.message_chars`` characters (marked when cut)."""
    n = SANDBOX.message_chars if limit is None else limit
    if len(text) <= n:
        return text
    return text[:n] + f"... [{len(text) - n} more characters cut]"


@dataclass
class Finding:
    """One problem found while compiling, gating or simulating (never an exception).

    Attributes:
        code: stable identifier, e.g. ``"part-exception"``, ``"mate-residual"``, ``"battery-B2"``.
        message: one line for people and for the model.
        part: the part concerned, if any.
        mate: the mate concerned, if any.
        line: 1-based program line, if known.
        value: the measured value, if any.
        limit: the limit it was compared with, if any.
        severity: ``"error"`` fails the build (:data:`BLOCKING`); ``"warning"`` and ``"info"``
            are reported only.
        other: the second part of a finding about a pair (an interference, a mate's
            penetration), so a close-up of the two can go with it.
    """

    code: str
    message: str
    part: str | None = None
    mate: str | None = None
    line: int | None = None
    value: float | None = None
    limit: float | None = None
    severity: Severity = DEFAULT_SEVERITY
    other: str | None = None

    def __post_init__(self) -> None:
        # capped at the source: a hostile program's exception text must not flood the
        # report, the terminal or the model's feedback
        if isinstance(self.message, str):
            self.message = cap_text(self.message)

    def as_dict(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if v is not None}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Finding:
        """A finding from :meth:`as_dict` output (unknown keys are ignored)."""
        return cls(**{k: v for k, v in data.items() if k in cls.__dataclass_fields__})


F = TypeVar("F", Finding, Mapping[str, Any])


def blocks(finding: Finding | Mapping[str, Any]) -> bool:
    """Whether one finding (or its :meth:`~Finding.as_dict`) fails a build."""
    sev = (finding.get("severity", DEFAULT_SEVERITY) if isinstance(finding, Mapping)
           else finding.severity)
    return sev in BLOCKING


def blocking(findings: Iterable[F]) -> list[F]:
    """The findings that fail a build, in order."""
    return [f for f in findings if blocks(f)]


def failed(findings: Iterable[Finding | Mapping[str, Any]]) -> bool:
    """The policy: a build (or gate, or check) fails when any finding blocks."""
    return any(blocks(f) for f in findings)


__all__ = ["BLOCKING", "DEFAULT_SEVERITY", "SEVERITIES", "Finding", "Severity", "blocking", "blocks",
           "cap_text", "failed"]
