"""``check_model``: every gate and metric on one compiled model, as a JSON-safe report.

This is what ``procedura-brep check --json`` prints; the fields are documented in docs/gates.md.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

from ..config import TOL
from ..program.model import CompiledModel, Finding
from .connectivity import analyse, judge
from .coupling import coupling_gate
from .feedback import format_feedback
from .interference import interference_gate
from .mate_gate import mate_gate
from .metrics import mesh_metrics
from .origin import origin_gate
from .pieces import pieces_gate
from .policy import GateResult, decide, result

#: Version of the report layout below; bump when a field changes meaning.
REPORT_VERSION: int = 4


@dataclass
class CheckReport:
    """The result of :func:`check_model`.

    Attributes:
        model: model name.
        passed: no error finding in any gate (compile findings included).
        gates: one :class:`GateResult` per gate, in order compile, mate, pieces, interference,
            connectivity, origin, coupling.
        metrics: :func:`~procedura_brep.gates.metrics.mesh_metrics`.
        feedback: every finding formatted for the model (empty when clean).
        timings: seconds per stage.
    """

    model: str
    passed: bool
    gates: list[GateResult]
    metrics: dict[str, Any]
    feedback: str = ""
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def findings(self) -> list[Finding]:
        return [f for g in self.gates for f in g.findings]

    def gate(self, name: str) -> GateResult:
        for g in self.gates:
            if g.gate == name:
                return g
        raise KeyError(f"no gate named {name!r}; gates: {', '.join(g.gate for g in self.gates)}")

    def as_dict(self) -> dict[str, Any]:
        """The JSON-safe report (see docs/gates.md, "check --json")."""
        mates = self.gate("mate").measured
        conn = self.gate("connectivity").measured
        return {
            "version": REPORT_VERSION,
            "model": self.model,
            "passed": self.passed,
            "n_vis": conn.get("n_vis"),
            "verdicts": {g.gate: g.passed for g in self.gates},
            "mates": mates,
            "pieces": self.gate("pieces").measured,
            "interference": self.gate("interference").measured,
            "connectivity": conn,
            "origin": self.gate("origin").measured,
            "coupling": self.gate("coupling").measured,
            "metrics": self.metrics,
            "triangles_per_part": self.metrics.get("triangles_per_part", {}),
            "findings": [f.as_dict() for f in self.findings],
            "feedback": self.feedback,
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
        }


def check_model(model: CompiledModel, source: str | None = None, *,
                baseline: int | None = None) -> CheckReport:
    """Run the compile, mate, pieces, interference, connectivity, origin and coupling gates and
    the mesh metrics.

    Args:
        model: a compiled model (its own ``findings`` are the compile gate's).
        source: the program text, used only to add line context to ``feedback``.
        baseline: the running N_vis before this change (the staged build): floaters fail
            only if N_vis rises above it (:func:`~procedura_brep.gates.connectivity.judge`).

    Returns:
        A :class:`CheckReport`; ``report.as_dict()`` is JSON-serialisable.
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    compile_res = result("compile", list(model.findings), {"parts": len(model.parts),
                                                           "mates": len(model.mates)})
    _, mate_res = mate_gate(model)
    timings["mate"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    _, pieces_res = pieces_gate(model)
    timings["pieces"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    _, inter_res = interference_gate(model)
    timings["interference"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    # a mate registered within its band (<= the contact distance) proves its two parts touch
    touching = frozenset(frozenset((m.child, m.parent)) for m in model.mates
                         if (mate_res.measured.get(m.name) or {}).get("area_mm2", 0.0) > 0.0
                         and TOL.registration_band_mm <= TOL.connect_mm)
    conn = analyse(model, touching=touching)
    _, conn_res = judge(conn, baseline=baseline)
    timings["connectivity"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    metrics = mesh_metrics(model, conn=conn)
    timings["metrics"] = time.perf_counter() - t2
    t2 = time.perf_counter()
    _, origin_res = origin_gate(model)
    timings["origin"] = time.perf_counter() - t2
    t2 = time.perf_counter()
    _, coupling_res = coupling_gate(model)
    timings["coupling"] = time.perf_counter() - t2
    gates = [compile_res, mate_res, pieces_res, inter_res, conn_res, origin_res, coupling_res]
    findings = [f for g in gates for f in g.findings]
    timings["total"] = time.perf_counter() - t0
    return CheckReport(model.name, decide(findings), gates, metrics,
                       format_feedback(source, findings), timings)
