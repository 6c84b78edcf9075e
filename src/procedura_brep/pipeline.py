"""``build``: compile a program in the sandbox and write the run directory.

Writes ``program.py``, ``model.step``, ``mates.json``, ``report.json`` and (by default) every
other export of the bundle, first into a staging folder that is then swapped in (see
:mod:`procedura_brep.rundir` for the policy when a build fails or is interrupted).
``report.json`` is written on every exit path.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import interrupt
from .errors import CompileError, OutputError, ProceduraError
from .paths import json_default, program_name, write_atomic
from .rundir import Staging
from .program.model import CompiledModel, Finding

log = logging.getLogger(__name__)


def dump_json(obj: Any) -> str:
    return json.dumps(obj, indent=2, sort_keys=False, ensure_ascii=False, default=json_default) + "\n"


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
    def errors(self) -> list[Finding]:
        """The findings that failed the build, in order."""
        return [f for f in self.findings if f.severity == "error"]

    @property
    def reason(self) -> str:
        """The first error (with its program line), plus how many more there are."""
        errs = self.errors
        if not errs:
            return self.status
        more = f" (+{len(errs) - 1} more, see report.json or -v)" if len(errs) > 1 else ""
        return describe(errs[0]) + more


def describe(f: Finding) -> str:
    """A finding as one line for people: its message plus the program line, when known and
    not already in the message."""
    if f.line and f"line {f.line}" not in f.message:
        return f"{f.message} (program line {f.line})"
    return f.message


def compile_file(source: str, name: str) -> CompiledModel:
    """Compile in the warm worker; while it boots (~3 s), load the parent's OCP modules."""
    from . import kernel
    from .program.sandbox import compile_source, default_worker, kill_default_worker, refuse_oversized
    refuse_oversized(source)  # before paying for the worker and the warm-up
    with interrupt.children_ignore_sigint():  # the terminal's Ctrl-C is ours to handle
        default_worker()  # starts the worker process now, returns at once
    interrupt.add_cleanup(kill_default_worker)
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
          simulate: bool = False, step_schema: str = "AP214",
          progress: Progress | None = None) -> BuildResult:
    """Compile ``program`` and write the run directory ``out_dir``.

    The build goes to a staging folder inside ``out_dir`` and is swapped in when done, so the
    directory never mixes two builds (policy: :mod:`procedura_brep.rundir`). report.json is
    written on every exit path: success, findings, an export error, our own bug (then the
    exception propagates) and Ctrl-C (status ``interrupted``).

    Args:
        program: path of the program file.
        out_dir: the run directory (created).
        formats: exports to write (None: all); ``step`` is always written.
        name: the model name (default from the path).
        gates: run the verification gates and record them in the report.
        source: the program text (default: read ``program``).
        simulate: also run the MuJoCo battery and record it in ``report.json``.
        step_schema: ``AP214`` or ``AP242``.
        progress: called with a short line as each stage starts (compile, exports, gates,
            battery, save).

    Raises:
        OutputError: ``out_dir`` cannot be written (before anything is compiled).
    """
    t0 = time.perf_counter()
    name = name or program_name(program)
    source = program.read_text(encoding="utf-8") if source is None else source
    from .export.bundle import parse_formats
    fmts = tuple(dict.fromkeys(("step", *parse_formats(formats))))
    run = _Run(Staging(out_dir), BuildResult("failed", out_dir), t0, progress)
    with interrupt.on_interrupt(run.interrupted):
        try:
            run.staging.write("program.py", source)
            _build_into(run, source, name, fmts, gates=gates, simulate=simulate,
                        step_schema=step_schema)
        except KeyboardInterrupt:
            run.interrupted()
            raise
        except OutputError:
            run.staging.discard()
            raise
        except ProceduraError as exc:  # e.g. the mate graph is not a tree: a finding
            run.fail("failed", [Finding(run.stage, str(exc))])
        except BaseException as exc:
            run.fail("failed", [Finding("internal", f"{run.stage} failed: {type(exc).__name__}: {exc}")])
            raise
    return run.result


Progress = Callable[[str], None]


class _Run:
    """One build in progress: its staging folder, result and stage; finishes exactly once
    (the main thread and the Ctrl-C watcher may both try)."""

    def __init__(self, staging: Staging, result: BuildResult, t0: float,
                 progress: Progress | None) -> None:
        self.staging, self.result, self.t0 = staging, result, t0
        self.timings: dict[str, float] = {}
        self.stage = "start"
        self._progress = progress
        self._lock = threading.Lock()
        self._done = self._finished = False

    def enter(self, stage: str, line: str) -> None:
        self.stage = stage
        if self._progress is not None:
            self._progress(line)

    def _claim(self, *, interrupt_wins: bool = False) -> bool:
        """Whether the caller finishes the run. The interrupt's watcher may take over a finish
        the main thread started but could not complete (it waits on the watcher's commit lock)."""
        if not interrupt_wins and interrupt.stopping():
            interrupt.hold()  # the watcher writes the interrupted report and ends the process
        with self._lock:
            if self._finished or (self._done and not interrupt_wins):
                return False
            self._done = True
            return True

    def succeed(self, status: str) -> None:
        if not self._claim():
            return
        self._finish_ok(status)
        self._finished = True

    def _finish_ok(self, status: str) -> None:
        self.result.status = status
        report = _report(self.result, self.timings, self.t0)
        report["complete"] = True
        self.staging.write("report.json", dump_json(report))
        self.staging.commit()
        out = self.result.out_dir
        self.result.files = {rel: out / rel for rel in self.result.files}
        self.result.files.update(program=out / "program.py", mates=out / "mates.json",
                                 report=out / "report.json")

    def fail(self, status: str, findings: list[Finding] | None = None, *,
             interrupt_wins: bool = False) -> None:
        if not self._claim(interrupt_wins=interrupt_wins):
            return
        self._finish_failed(status, findings)
        self._finished = True

    def _finish_failed(self, status: str, findings: list[Finding] | None) -> None:
        self.result.status = status
        if findings is not None:
            self.result.findings = [*self.result.findings, *findings]
        report = self.staging.finish_failed(_report(self.result, self.timings, self.t0), dump_json)
        self.result.report = report
        out = self.result.out_dir
        self.result.files = {"report": out / "report.json"}
        if not report.get("kept_previous"):
            self.result.files["program"] = out / "program.py"

    def interrupted(self) -> None:
        self.fail("interrupted", [Finding("interrupted", f"the build was interrupted during "
                                                         f"{self.stage}")], interrupt_wins=True)


def _build_into(run: _Run, source: str, name: str, fmts: tuple[str, ...], *, gates: bool,
                simulate: bool, step_schema: str) -> None:
    result, timings, staging = run.result, run.timings, run.staging
    run.enter("compile", f"compiling {name}")
    try:
        t = time.perf_counter()
        model = compile_file(source, name)
        timings["compile_s"] = time.perf_counter() - t
    except CompileError as exc:
        result.findings = exc.findings or [Finding("compile", str(exc))]
        run.fail("failed")
        return
    result.model = model
    result.findings = list(model.findings)
    if not model.ok:
        run.fail("failed")
        return
    from .isolate import ChildFailure, run_limited
    run.enter("export", f"writing {len(model.parts)} parts as {', '.join(fmts)}")

    def heavy(send: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
        return after_compile(model, source, staging.dir, fmts, gates=gates, simulate=simulate,
                             step_schema=step_schema, send=send)

    try:
        out = run_limited(heavy, stage="export",
                          on_message=lambda m: run.enter(str(m["stage"]), str(m["line"])))
    except ChildFailure as exc:
        if exc.kind != "error":  # out of memory, over time, killed: a finding, not a dead CLI
            run.fail("failed", [Finding(f"parent-{exc.kind}", str(exc))])
            return
        if exc.exc_type == "KeyboardInterrupt":
            raise KeyboardInterrupt from None
        if exc.oserror:
            raise OutputError(result.out_dir, str(exc)) from None
        if exc.procedura:  # e.g. the mate graph is not a tree
            run.fail("failed", [Finding(exc.stage, str(exc))])
            return
        raise RuntimeError(f"{exc.exc_type} in the {exc.stage} stage: {exc}") from None
    result.files.update({rel: staging.dir / rel for rel in out["files"]})
    timings.update(out["timings"])
    result.report.update(out["report"])
    keys = Finding.__dataclass_fields__
    result.findings += [Finding(**{k: v for k, v in f.items() if k in keys}) for f in out["findings"]]
    run.enter("save", f"saving {result.out_dir}")
    if not result.report.get("gates", {}).get("passed", True):
        run.succeed("gates_failed")
    elif not result.report.get("battery", {}).get("passed", True):
        run.succeed("battery_failed")
    else:
        run.succeed("ok")


def after_compile(model: CompiledModel, source: str, root: Path, fmts: tuple[str, ...], *,
                  gates: bool, simulate: bool, step_schema: str,
                  send: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    """Exports, mates.json, gates and battery into ``root`` (the staging folder): everything
    that tessellates. Runs in the limited child of :func:`procedura_brep.isolate.run_limited`;
    returns what the parent needs (JSON-safe)."""
    from .export.bundle import write_bundle
    timings: dict[str, float] = {}
    report: dict[str, Any] = {}
    findings: list[Finding] = []
    art = None  # the one articulation the exports and the battery take
    if simulate or {"usd", "urdf", "mjcf"} & set(fmts):
        from .articulation import articulate
        t = time.perf_counter()
        art = articulate(model)
        timings["articulate_s"] = time.perf_counter() - t
    t = time.perf_counter()
    bundle_t: dict[str, float] = {}
    written = write_bundle(model, root, formats=fmts, timings=bundle_t,
                           step_schema=step_schema, art=art)  # type: ignore[arg-type]
    timings.update({f"export_{k}_s": v for k, v in bundle_t.items()})
    timings["export_s"] = time.perf_counter() - t
    evidence = None
    if len(fmts) > 1:
        t = time.perf_counter()
        from .articulation import mates_evidence
        evidence = mates_evidence(model)
        timings["evidence_s"] = time.perf_counter() - t
    write_atomic(root / "mates.json", dump_json(mates_json(model, evidence)))
    if gates:
        send({"stage": "gates", "line": "running the gates"})
        t = time.perf_counter()
        report["gates"] = run_gates(model, source)
        timings["gates_s"] = time.perf_counter() - t
        findings += gate_failures(report["gates"])
    if simulate:
        send({"stage": "battery", "line": "running the MuJoCo battery"})
        t = time.perf_counter()
        from .sim import run_battery
        frames = not _gl_in_use()
        report["battery"] = run_battery(root, out_dir=root, frames=frames, art=art).as_dict()
        if not frames:
            report["battery"].setdefault("notes", []).append(
                "no failure frames: this process inherited a GL context, which a forked child "
                "cannot use")
        timings["battery_s"] = time.perf_counter() - t
        findings += battery_failures(report["battery"])
    return {"files": [*written, "mates.json"], "timings": timings, "report": report,
            "findings": [f.as_dict() for f in findings]}


def _gl_in_use() -> bool:
    """Whether this process inherited a GL context (its driver threads do not survive a fork,
    so the child must not draw battery frames with it)."""
    import sys
    gl = sys.modules.get("procedura_brep.render.gl")
    return getattr(gl, "_RENDERER", None) is not None


def gate_failures(gates: dict[str, Any]) -> list[Finding]:
    """The gate report's error findings as :class:`Finding` objects."""
    keys = Finding.__dataclass_fields__
    return [Finding(**{k: v for k, v in f.items() if k in keys}) for f in gates.get("findings", [])
            if f.get("severity", "error") == "error" and "code" in f and "message" in f]


def battery_failures(battery: dict[str, Any]) -> list[Finding]:
    """One finding per failed battery check, naming the check (``battery-B2`` ...)."""
    out = []
    for c in battery.get("checks", []):
        if c.get("passed") or c.get("skipped"):
            continue
        label = f"{c.get('id')} ({c['name']})" if c.get("name") else str(c.get("id"))
        out.append(Finding(f"battery-{c.get('id')}", f"battery {label} failed: "
                                                     f"{c.get('message') or 'no message'}"))
    return out


def run_gates(model: CompiledModel, source: str) -> dict[str, Any]:
    """The gate report (``procedura_brep.gates.check_model``) as a JSON-safe dict."""
    from .gates import check_model
    return check_model(model, source).as_dict()


def _report(result: BuildResult, timings: dict[str, float], t0: float) -> dict[str, Any]:
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
    return report
