"""Battery results as plain JSON-safe data."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class CheckResult:
    """One battery check.

    Attributes:
        id: ``"B0"`` .. ``"B8"``.
        name: short name, e.g. ``"model fidelity"``.
        passed: the verdict (a skipped check passes).
        measured: measured values by key (SI units, the key names the unit).
        limits: the pass criteria by the same keys.
        message: one line; a failure names the joint or link and the measured value.
        skipped: True when the check does not apply (e.g. B4 without wheels).
        frames: rendered frames of the failing phase (paths relative to the output dir).
        seconds: wall time of the check.
        unverified: what the check could not decide ("" when it decided everything): a
            verdict it could not reach is **not verified**, neither a pass nor a failure
            (``passed`` then speaks only for what was decided).
    """

    id: str
    name: str
    passed: bool
    measured: dict[str, Any] = field(default_factory=dict)
    limits: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    skipped: bool = False
    frames: list[str] = field(default_factory=list)
    seconds: float = 0.0
    unverified: str = ""

    @property
    def status(self) -> str:
        """``"skip"``, ``"fail"``, ``"not verified"`` or ``"pass"``."""
        if self.skipped:
            return "skip"
        if not self.passed:
            return "fail"
        return "not verified" if self.unverified else "pass"

    def as_dict(self) -> dict[str, Any]:
        return {**self.__dict__, "status": self.status}


@dataclass
class BatteryReport:
    """Every check run, in id order, and the overall verdict."""

    checks: list[CheckResult]
    timings: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def verified(self) -> bool:
        """Every check decided everything it checks (see :attr:`CheckResult.unverified`)."""
        return not any(c.unverified for c in self.checks)

    def check(self, cid: str) -> CheckResult:
        for c in self.checks:
            if c.id == cid:
                return c
        raise KeyError(f"no check {cid!r}; ran: {', '.join(c.id for c in self.checks)}")

    def as_dict(self) -> dict[str, Any]:
        return {"passed": self.passed, "verified": self.verified,
                "checks": [c.as_dict() for c in self.checks],
                "timings": self.timings, "notes": self.notes}
