"""``report.json`` of a build, assembled in one place from the steps' values.

:func:`run_report` is the only function that lays the report out; the run directory policy
(:mod:`procedura_brep.run.directory`) may add ``kept_previous`` / ``previous`` when it keeps an
earlier build, and the agent adds its own sections (usage, plan) after the build.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..errors import ProceduraError
from ..findings import Finding, blocking
from ..program.model import CompiledModel
from .status import Status


def run_report(status: Status, model: CompiledModel | None, findings: list[Finding],
               timings: Mapping[str, float], *, sections: Mapping[str, Any] | None = None,
               complete: bool = False) -> dict[str, Any]:
    """The build's report.

    Args:
        status: how the build ended.
        model: the compiled model (None when the program did not compile).
        findings: the build's findings: the compile's, then the gates' errors, then the
            battery's failed checks, then what stopped the build.
        timings: seconds per stage (``total_s`` included); the model's own per-part timings
            come first.
        sections: the steps' reports by key (``gates``, ``battery``), JSON-safe.
        complete: the build wrote every file it was asked for (``complete: true``).

    Returns:
        ``status``, ``program``, ``findings``, ``timings``, the sections, ``isolation`` (the
        compile child's OS layers, when known), ``parts`` and ``mates`` (when the model has
        parts) and ``complete`` (when true), in that order.
    """
    from ..export.records import mate_rows, part_rows
    report: dict[str, Any] = {
        "status": str(Status(status)),
        "program": model.name if model else None,
        "findings": [f.as_dict() for f in findings],
        "timings": {**(model.timings if model else {}), **timings},
        **(sections or {}),
    }
    if model is not None and model.isolation:
        report["isolation"] = model.isolation
    if model is not None and model.parts:
        try:
            report["parts"] = part_rows(model)
        except ProceduraError as exc:
            report["findings"].append(Finding("kernel", str(exc)).as_dict())
        report["mates"] = mate_rows(model)
    if complete:
        report["complete"] = True
    return report


def describe(f: Finding) -> str:
    """A finding as one line for people: its message plus the program line, when known and
    not already in the message."""
    if f.line and f"line {f.line}" not in f.message:
        return f"{f.message} (program line {f.line})"
    return f.message


def reason(status: Status | str, findings: list[Finding]) -> str:
    """Why a build ended as it did: the first blocking finding (with its program line), plus
    how many more there are; the status itself when no finding blocks."""
    errs = blocking(findings)
    if not errs:
        return str(status)
    more = f" (+{len(errs) - 1} more, see report.json or -v)" if len(errs) > 1 else ""
    return describe(errs[0]) + more


__all__ = ["describe", "reason", "run_report"]
