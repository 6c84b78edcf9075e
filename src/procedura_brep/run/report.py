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


#: What each file of a run directory is, for the summary's list (docs/run_layer.md has them all).
OUTPUT_NOTES: tuple[tuple[str, str], ...] = (
    ("program.py", "the editable program (open it, edit a param, build again)"),
    ("sheet.png", "the model in PBR: six views and an iso, every part named on the legend"),
    ("viewer.html", "open it in a browser (no network): part tree, joint sliders, exploded "
                    "view, findings; or procedura-brep view DIR"),
    ("report.json", "everything below, machine-readable"),
    ("mates.json", "the mates, their frames and the articulation evidence"),
    ("model.step", "STEP with named, coloured parts (FreeCAD, any CAD suite)"),
    ("model.obj", "OBJ + model.mtl"),
    ("model.glb", "glTF binary with PBR materials"),
    ("model.usda", "OpenUSD with a physics articulation"),
    ("model.xml", "MJCF for MuJoCo"),
    ("urdf", "URDF (two profiles) and its meshes"),
    ("renders/sim", "frames of a failed battery check"),
    ("state.json", "a staged run's state: what --resume continues from"),
    ("reference.png", "the reference picture of a staged run (reference.json says where from)"),
    ("transcript.jsonl", "every model call of a staged run or revise (replayable)"),
    ("history", "the program after each commit and edit"),
)


def summary_md(report: Mapping[str, Any], out_dir: Any) -> str:
    """``summary.md``: what a person reads first in a run directory, from its report: the
    status, what was asked (a staged run's prompt), the parts, the mates, the findings, the
    battery's verdicts, the timings and every output that is there."""
    from pathlib import Path
    out = Path(out_dir)
    name = report.get("program") or out.name
    rows = [f"# {name}: {report.get('status', '?')}", ""]
    if report.get("prompt"):
        rows += [f"Asked: {report['prompt']}", ""]
    if report.get("kept_previous"):
        rows += ["This build failed; the files are the previous complete build's.", ""]
    if (out / "sheet.png").exists():
        rows += ["![the model: six views and an iso](sheet.png)", ""]
    parts = report.get("parts") or []
    rows += [f"## Parts ({len(parts)})", ""]
    if parts:
        rows += ["| part | material | volume (mm^3) |", "|---|---|---|"]
        rows += [f"| {p.get('name')} | {p.get('material')} | {float(p.get('volume_mm3') or 0):.4g} |" for p in parts]
    mates = report.get("mates") or []
    rows += ["", f"## Mates ({len(mates)})", ""]
    if mates:
        rows += ["| mate | type | child | parent |", "|---|---|---|---|"]
        rows += [f"| {m.get('name')} | {m.get('type')} | {m.get('child')} | {m.get('parent')} |" for m in mates]
    rows += masses_md(report.get("masses"))
    findings = report.get("findings") or []
    rows += ["", "## Findings", ""]
    rows += [f"- [{f.get('severity', 'error')}] {f.get('code')}: {f.get('message')}" for f in findings] or ["none"]
    battery = report.get("battery") or {}
    if battery.get("checks"):
        rows += ["", "## Battery", "", "| check | name | verdict | message |", "|---|---|---|---|"]
        rows += [f"| {c.get('id')} | {c.get('name')} | {c.get('status')} | {c.get('message', '')} |"
                 for c in battery["checks"]]
    there = [(f, note) for f, note in OUTPUT_NOTES if (out / f).exists()]
    rows += ["", "## Files", ""] + [f"- `{f}`: {note}" for f, note in there]
    timings = report.get("timings") or {}
    keys = [k for k in ("compile_s", "gates_s", "export_s", "evidence_s", "sheet_s", "battery_s", "total_s")
            if k in timings]
    rows += ["", "## Timings", ""] + [f"- {k[:-2]}: {float(timings[k]):.2f} s" for k in keys]
    return "\n".join(rows) + "\n"


def masses_md(masses: Any) -> list[str]:
    """The summary's mass table (from the report's ``masses`` section): each part's method,
    mass and centre of mass, and the total; no rows when the report has no masses."""
    if not isinstance(masses, Mapping) or not masses.get("parts"):
        return []

    def com(c: Any) -> str:
        return "(" + ", ".join(f"{float(x):.3f}" for x in c or ()) + ")"

    rows = ["", "## Masses", "", "| part | method | mass (kg) | centre of mass (m, world) |",
            "|---|---|---|---|"]
    rows += [f"| {p.get('name')} | {p.get('method')} | {float(p.get('mass_kg') or 0):.4g} | "
             f"{com(p.get('com_m'))} |" for p in masses["parts"]]
    total = masses.get("total") or {}
    rows.append(f"| total | | {float(total.get('mass_kg') or 0):.4g} | {com(total.get('com_m'))} |")
    return rows


def write_summary(out_dir: Any, report: Mapping[str, Any]) -> None:
    """Write ``summary.md`` for ``report`` into the run directory (a best effort: a summary
    that cannot be written never fails the build whose report it repeats)."""
    from pathlib import Path

    from ..paths import write_atomic
    try:
        write_atomic(Path(out_dir) / "summary.md", summary_md(report, out_dir))
    except OSError:
        pass


def write_viewer_findings(run_dir: Any, report: Mapping[str, Any]) -> None:
    """Rewrite ``viewer/findings.js`` for ``report`` where ``run_dir`` (a complete build's
    staging folder, before it is swapped in) holds a viewer: the bundle wrote it before the
    findings were final. A failed build keeps a previous viewer as it was. A best effort, as
    the summary."""
    from pathlib import Path

    from ..export.viewer import FINDINGS_JS, findings_js
    from ..paths import write_atomic
    root = Path(run_dir)
    if not (root / "viewer.html").is_file():
        return
    try:
        write_atomic(root / FINDINGS_JS, findings_js(report))
    except OSError:
        pass
