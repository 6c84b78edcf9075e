"""Deterministic gates on compiled models: compile feedback, mate, pieces, interference,
connectivity, coupling, finish, metrics.

Import-light: names resolve lazily (PEP 562), and no submodule imports build123d; OCP loads only
when a gate actually measures geometry.

Public API::

    check_model(model, source=None) -> CheckReport          # every gate + metrics, .as_dict()
    mate_gate(model) -> (list[Finding], GateResult)
    pieces_gate(model) -> (list[Finding], GateResult)            # detached pieces per part
    interference_gate(model) -> (list[Finding], GateResult)      # every pair of parts
    connectivity_gate(model, baseline=None) -> (list[Finding], GateResult)
    coupling_gate(model) -> (list[Finding], GateResult)           # gears, racks, screws mesh
    finish_gate(model=None, source=None) -> (list[Finding], GateResult)
    mesh_metrics(model) -> dict
    format_feedback(source, findings) -> str
    decide(findings) -> bool
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "check_model": ".check", "CheckReport": ".check",
    "mate_gate": ".mate_gate", "MateMeasure": ".mate_gate", "measure": ".mate_gate",
    "pieces_gate": ".pieces", "part_pieces": ".pieces",
    "interference_gate": ".interference", "scan": ".interference", "PairOverlap": ".interference",
    "connectivity_gate": ".connectivity", "analyse": ".connectivity", "Connectivity": ".connectivity",
    "finish_gate": ".finish",
    "coupling_gate": ".coupling",
    "mesh_metrics": ".metrics",
    "format_feedback": ".feedback", "format_finding": ".feedback",
    "GateResult": ".policy", "decide": ".policy",
    "CONNECT_MM": ".geometry", "clear_caches": ".geometry",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
