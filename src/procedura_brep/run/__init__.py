"""The run layer: typed steps ``compile -> gate -> export -> simulate`` and how a run ends.

Sits between sim/render and agent: it imports program, gates, export and sim; the agent and the
CLI import it. Its modules: :mod:`.steps` (the typed steps), :mod:`.build` (a run directory's
build), :mod:`.directory` (the run directory's staging and failure policy), :mod:`.commands`
(check, render, export, simulate in a limited child), :mod:`.report` and :mod:`.status`.

Public API (names resolve lazily, PEP 562, so importing the package loads no CAD code)::

    compile_model(source, name=..., warm=False) -> CompiledModel     # raises CompileError
    gate(model, source=None, baseline=None) -> GateVerdict            # writes nothing
    export(model, root, formats=None, step_schema="AP214") -> Bundle  # exports + mates.json
    simulate(model, bundle, frames=True) -> BatteryVerdict            # never reads program.py
    settle()                                                          # a commit: freeze the heap
    Status, exit_code(status, compiled=True) -> int                   # the one exit-code map
    run_report(...) -> dict, describe(finding) -> str, reason(status, findings) -> str

See docs/run_layer.md.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "compile_model": ".steps", "gate": ".steps", "export": ".steps", "simulate": ".steps",
    "settle": ".steps", "GateVerdict": ".steps", "Bundle": ".steps", "BatteryVerdict": ".steps", "dump_json": ".steps",
    "Status": ".status", "exit_code": ".status", "EXIT_CODES": ".status",
    "run_report": ".report", "describe": ".report", "reason": ".report",
}

__all__ = list(_LAZY)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
