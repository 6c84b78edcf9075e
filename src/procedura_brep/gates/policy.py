"""Gate results and the one policy that turns findings into pass/fail.

Gates never raise on a bad model: they return :class:`~procedura_brep.findings.Finding`
objects and a :class:`GateResult`; :func:`decide` is the gates' name for the one policy,
:func:`procedura_brep.findings.failed`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from ..findings import Finding, Severity, failed  # noqa: F401 - Severity re-exported


@dataclass
class GateResult:
    """The summary of one gate run.

    Attributes:
        gate: gate name: ``"compile"``, ``"mate"``, ``"connectivity"``, ``"finish"``.
        passed: the policy's verdict on ``findings``.
        findings: every finding the gate produced (errors and warnings).
        measured: the gate's measured values (JSON-safe), e.g. ``{"n_vis": 0}``.
    """

    gate: str
    passed: bool
    findings: list[Finding] = field(default_factory=list)
    measured: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"gate": self.gate, "passed": self.passed, "measured": self.measured,
                "findings": [f.as_dict() for f in self.findings]}


def decide(findings: Iterable[Finding]) -> bool:
    """True (pass) when no finding blocks (:func:`procedura_brep.findings.failed`)."""
    return not failed(findings)


def result(gate: str, findings: list[Finding], measured: dict[str, Any] | None = None) -> GateResult:
    """A :class:`GateResult` whose ``passed`` is decided by :func:`decide`."""
    return GateResult(gate, decide(findings), list(findings), dict(measured or {}))
