"""``build``: compile a program in the sandbox and write the run directory.

Writes ``program.py``, ``model.step``, ``mates.json``, ``report.json`` and (by default) every
other export of the bundle. Each file is written atomically (temp file + rename), so a killed
build never leaves a half-written file. ``report.json`` is written even when the build fails.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import CompileError, ProceduraError
from .paths import program_name, write_atomic
from .program.model import CompiledModel, Finding

log = logging.getLogger(__name__)


def dump_json(obj: Any) -> str:
    return json.dumps(obj, indent=2, sort_keys=False, ensure_ascii=False, default=_json_default) + "\n"


def _json_default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, tuple):
        return list(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _frame_dict(m: np.ndarray) -> dict[str, Any]:
    return {"origin_mm": m[:3, 3].tolist(), "x_axis": m[:3, 0].tolist(), "z_axis": m[:3, 2].tolist(),
            "matrix": np.asarray(m).tolist()}


def mates_json(model: CompiledModel, evidence: dict[str, Any] | None = None) -> dict[str, Any]:
    """The mate graph: every mate with its world frame, nominal, fit, offset, DOF and limits."""
    mates = []
    for m in model.mates:
        mates.append({
            "name": m.name, "type": m.type, "kind": m.kind,
            "parent": {"part": m.parent, "frame": m.parent_frame},
            "child": {"part": m.child, "frame": m.child_frame},
            "world_frame": _frame_dict(m.world_frame),
            "nominal": {"name": m.nominal_name, "value_mm": m.nominal},
            "fit": m.fit, "resolved_offset_mm": m.fit.get("offset"),
            "dof": m.dof, "limits": m.limits,
            "options": {k: v for k, v in m.options.items() if k != "limits"},
            "primary": m.primary, "residual": {"mm": m.residual_mm, "rad": m.residual_rad},
        })
    out: dict[str, Any] = {"program": model.name, "units": {"length": "mm", "angle": "deg"},
                           "root": model.parts[0].name if model.parts else None, "mates": mates}
    if evidence is not None:
        out["evidence"] = evidence
    return out


def part_rows(model: CompiledModel) -> list[dict[str, Any]]:
    from . import kernel
    rows = []
    for p in model.parts:
        lo, hi = kernel.bbox(p.shape())
        rows.append({"name": p.name, "material": p.material, "detail": p.detail,
                     "volume_mm3": kernel.volume(p.local_shape()), "bbox_mm": [list(lo), list(hi)],
                     "lines": list(p.lines), "compile_s": model.timings.get(f"part:{p.name}")})
    return rows


@dataclass
class BuildResult:
    """What ``build`` produced: the model (if it compiled), files, findings, status."""

    status: str
    out_dir: Path
    model: CompiledModel | None = None
    files: dict[str, Path] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)
    report: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def reason(self) -> str:
        errs = [f for f in self.findings if f.severity == "error"]
        if not errs:
            return self.status
        more = f" (+{len(errs) - 1} more, see report.json)" if len(errs) > 1 else ""
        return errs[0].message + more


def compile_file(source: str, name: str) -> CompiledModel:
    """Compile in the warm worker; while it boots (~3 s), load the parent's OCP modules."""
    from . import kernel
    from .program.sandbox import compile_source, default_worker, refuse_oversized
    refuse_oversized(source)  # before paying for the worker and the warm-up
    default_worker()  # starts the worker process now, returns at once
    kernel.warm_up()
    _warm_exports()
    return compile_source(source, name=name)


def _warm_exports() -> None:
    """Import what gates and exports need while the worker boots (free wall time)."""
    import scipy.spatial  # noqa: F401
    import trimesh  # noqa: F401

    from . import gates  # noqa: F401
    from .export import bundle  # noqa: F401
    try:
        import mujoco  # noqa: F401
        from pxr import Usd, UsdPhysics  # noqa: F401
    except ImportError:  # pragma: no cover - reported by doctor
        pass


def build(program: Path, out_dir: Path, *, formats: tuple[str, ...] | None = None,
          name: str | None = None, gates: bool = True, source: str | None = None,
          simulate: bool = False, step_schema: str = "AP214") -> BuildResult:
    """Compile ``program`` and write the run directory ``out_dir``.

    Args:
        program: path of the program file.
        out_dir: the run directory (created).
        formats: exports to write (None: all); ``step`` is always written.
        name: the model name (default from the path).
        gates: run the verification gates and record them in the report.
        source: the program text (default: read ``program``).
        simulate: also run the MuJoCo battery and record it in ``report.json``.
        step_schema: ``AP214`` or ``AP242``.
    """
    t0 = time.perf_counter()
    name = name or program_name(program)
    source = program.read_text(encoding="utf-8") if source is None else source
    out_dir.mkdir(parents=True, exist_ok=True)
    result = BuildResult("failed", out_dir)
    timings: dict[str, float] = {}
    write_atomic(out_dir / "program.py", source)
    result.files["program"] = out_dir / "program.py"
    try:
        t = time.perf_counter()
        model = compile_file(source, name)
        timings["compile_s"] = time.perf_counter() - t
    except CompileError as exc:
        result.findings = exc.findings or [Finding("compile", str(exc))]
        _write_report(result, timings, t0)
        return result
    result.model = model
    result.findings = list(model.findings)
    if not model.ok:
        _write_report(result, timings, t0)
        return result
    from .export.bundle import parse_formats, write_bundle
    fmts = tuple(dict.fromkeys(("step", *parse_formats(formats))))
    t = time.perf_counter()
    bundle_t: dict[str, float] = {}
    written = write_bundle(model, out_dir, formats=fmts, timings=bundle_t,
                           step_schema=step_schema)  # type: ignore[arg-type]
    result.files.update({rel: path for rel, path in written.items()})
    timings.update({f"export_{k}_s": v for k, v in bundle_t.items()})
    timings["export_s"] = time.perf_counter() - t
    evidence = None
    if len(fmts) > 1:
        t = time.perf_counter()
        from .articulation import mates_evidence
        evidence = mates_evidence(model)
        timings["evidence_s"] = time.perf_counter() - t
    write_atomic(out_dir / "mates.json", dump_json(mates_json(model, evidence)))
    result.files["mates"] = out_dir / "mates.json"
    if gates:
        t = time.perf_counter()
        result.report["gates"] = run_gates(model, source)
        timings["gates_s"] = time.perf_counter() - t
    if simulate:
        t = time.perf_counter()
        from .sim import run_battery
        result.report["battery"] = run_battery(out_dir, out_dir=out_dir).as_dict()
        timings["battery_s"] = time.perf_counter() - t
    passed = (result.report.get("gates", {}).get("passed", True)
              and result.report.get("battery", {}).get("passed", True))
    result.status = "ok" if model.ok and passed else "gates_failed"
    _write_report(result, timings, t0)
    return result


def run_gates(model: CompiledModel, source: str) -> dict[str, Any]:
    """The gate report (``procedura_brep.gates.check_model``) as a JSON-safe dict."""
    from .gates import check_model
    return check_model(model, source).as_dict()


def _write_report(result: BuildResult, timings: dict[str, float], t0: float) -> None:
    model = result.model
    timings["total_s"] = time.perf_counter() - t0
    report: dict[str, Any] = {
        "status": result.status,
        "program": model.name if model else None,
        "findings": [f.as_dict() for f in result.findings],
        "timings": {**(model.timings if model else {}), **timings},
        **result.report,
    }
    if model is not None and model.parts:
        try:
            report["parts"] = part_rows(model)
        except ProceduraError as exc:
            report["findings"].append(Finding("kernel", str(exc)).as_dict())
        report["mates"] = [{"name": m.name, "type": m.type, "child": m.child, "parent": m.parent,
                            "primary": m.primary, "residual_mm": m.residual_mm,
                            "residual_rad": m.residual_rad} for m in model.mates]
    result.report = report
    write_atomic(result.out_dir / "report.json", dump_json(report))
    result.files["report"] = result.out_dir / "report.json"
