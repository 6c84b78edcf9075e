"""``build``: the run-layer steps composed into a run directory.

``compile`` runs in the warm sandbox worker; ``gate``, ``export`` and ``simulate``
(:mod:`procedura_brep.run.steps`) run in that order in a limited child
(:func:`procedura_brep.limited.run_limited`): the gates run before anything is exported, and a
model that fails them is not exported unless ``export_failed`` asks for it. Writes
``program.py``, ``report.json`` and, for a build that passed its gates (or any build with
``export_failed``), ``model.step``, ``mates.json`` and every other export asked for, first
into a staging folder that is then swapped in (see :mod:`procedura_brep.run.directory` for the policy
when a build fails or is interrupted). ``report.json`` is written on every exit path; it is
laid out once, by :func:`procedura_brep.run.report.run_report`.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .. import interrupt
from ..errors import CompileError, OutputError, ProceduraError
from ..findings import Finding, blocking, failed
from ..paths import program_name
from ..program.model import CompiledModel
from . import steps
from .directory import Staging
from .report import describe, reason, run_report, write_summary, write_viewer_findings
from .status import Status, exit_code
from .steps import dump_json

log = logging.getLogger(__name__)

Progress = Callable[[str], None]


@dataclass
class BuildResult:
    """What ``build`` produced: the model (if it compiled), files, findings, status, report."""

    status: Status
    out_dir: Path
    model: CompiledModel | None = None
    files: dict[str, Path] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)
    report: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == Status.OK

    @property
    def compiled(self) -> bool:
        """Whether the program compiled cleanly: at least one part, and no part failed (an
        exception, a cap). A program that did not is the user's input at fault (exit 2), as
        for ``check``, ``render``, ``export`` and ``simulate``."""
        return self.model is not None and bool(self.model.parts) and self.model.ok

    @property
    def exit_code(self) -> int:
        """The process exit code for this build (:func:`procedura_brep.run.status.exit_code`)."""
        return exit_code(self.status, compiled=self.compiled)

    @property
    def errors(self) -> list[Finding]:
        """The findings that failed the build, in order."""
        return blocking(self.findings)

    @property
    def reason(self) -> str:
        """The first error (with its program line), plus how many more there are."""
        return reason(self.status, self.findings)



def build(program: Path, out_dir: Path, *, formats: tuple[str, ...] | None = None,
          name: str | None = None, gates: bool = True, source: str | None = None,
          simulate: bool = False, step_schema: str = "AP214",
          progress: Progress | None = None, export_failed: bool = False) -> BuildResult:
    """Compile ``program`` and write the run directory ``out_dir``.

    The build goes to a staging folder inside ``out_dir`` and is swapped in when done, so the
    directory never mixes two builds (policy: :mod:`procedura_brep.run.directory`). report.json is
    written on every exit path: success, findings, an export error, our own bug (then the
    exception propagates) and Ctrl-C (status ``interrupted``).

    Args:
        program: path of the program file.
        out_dir: the run directory (created).
        formats: exports to write (None: all); ``step`` and the viewer are always written.
        name: the model name (default from the path).
        gates: run the verification gates (before any export) and record them in the report.
        source: the program text (default: read ``program``).
        simulate: also run the MuJoCo battery and record it in ``report.json``.
        step_schema: ``AP214`` or ``AP242``.
        progress: called with a short line as each stage starts (compile, gates, exports,
            battery, save).
        export_failed: export a model that fails its gates too (status ``gates_failed``, a
            complete build); by default such a build writes only program.py and report.json
            (and keeps a previous complete build in ``out_dir``, as a failed one does).

    Raises:
        OutputError: ``out_dir`` cannot be written (before anything is compiled).
    """
    t0 = time.perf_counter()
    name = name or program_name(program)
    source = program.read_text(encoding="utf-8") if source is None else source
    from ..export.bundle import parse_formats
    fmts = tuple(dict.fromkeys(("step", *parse_formats(formats), "viewer")))
    run = _Run(Staging(out_dir), BuildResult(Status.FAILED, out_dir), t0, progress)
    with interrupt.on_interrupt(run.interrupted):
        try:
            run.staging.write("program.py", source)
            _build_into(run, source, name, fmts, gates=gates, simulate=simulate,
                        step_schema=step_schema, export_failed=export_failed)
        except KeyboardInterrupt:
            run.interrupted()
            raise
        except OutputError:
            run.staging.discard()
            raise
        except ProceduraError as exc:  # e.g. the mate graph is not a tree: a finding
            run.fail(Status.FAILED, [Finding(run.stage, str(exc))])
        except BaseException as exc:
            run.fail(Status.FAILED, [Finding("internal", f"{run.stage} failed: {type(exc).__name__}: {exc}")])
            raise
    return run.result


class _Run:
    """One build in progress: its staging folder, result and stage; finishes exactly once
    (the main thread and the Ctrl-C watcher may both try)."""

    def __init__(self, staging: Staging, result: BuildResult, t0: float,
                 progress: Progress | None) -> None:
        self.staging, self.result, self.t0 = staging, result, t0
        self.timings: dict[str, float] = {}
        self.sections: dict[str, Any] = {}  # the steps' reports: gates, battery
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

    def report(self, status: Status, *, complete: bool) -> dict[str, Any]:
        """The report of this run as it ends now (:func:`procedura_brep.run.report.run_report`)."""
        self.timings["total_s"] = time.perf_counter() - self.t0
        return run_report(status, self.result.model, self.result.findings, self.timings,
                          sections=self.sections, complete=complete)

    def succeed(self, status: Status) -> None:
        """Finish a complete build: every file asked for is staged; swap them in."""
        if not self._claim():
            return
        self._finish_ok(status)
        self._finished = True

    def _finish_ok(self, status: Status) -> None:
        self.result.status = status
        report = self.result.report = self.report(status, complete=True)
        self.staging.write("report.json", dump_json(report))
        write_viewer_findings(self.staging.dir, report)  # final only now, swapped in with it
        self.staging.commit()
        out = self.result.out_dir
        write_summary(out, report)
        self.result.files = {rel: out / rel for rel in self.result.files}
        self.result.files.update(program=out / "program.py", mates=out / "mates.json",
                                 report=out / "report.json")

    def fail(self, status: Status, findings: list[Finding] | None = None, *,
             interrupt_wins: bool = False) -> None:
        """Finish a build that wrote no bundle: program.py and report.json only, or the
        previous complete build kept (:meth:`procedura_brep.run.directory.Staging.finish_failed`)."""
        if not self._claim(interrupt_wins=interrupt_wins):
            return
        self._finish_failed(status, findings)
        self._finished = True

    def _finish_failed(self, status: Status, findings: list[Finding] | None) -> None:
        self.result.status = status
        if findings is not None:
            self.result.findings = [*self.result.findings, *findings]
        report = self.staging.finish_failed(self.report(status, complete=False), dump_json)
        self.result.report = report
        out = self.result.out_dir
        write_summary(out, report)
        self.result.files = {"report": out / "report.json"}
        if not report.get("kept_previous"):
            self.result.files["program"] = out / "program.py"

    def interrupted(self) -> None:
        self.fail(Status.INTERRUPTED, [Finding("interrupted", f"the build was interrupted during "
                                                         f"{self.stage}")], interrupt_wins=True)


def _build_into(run: _Run, source: str, name: str, fmts: tuple[str, ...], *, gates: bool,
                simulate: bool, step_schema: str, export_failed: bool) -> None:
    """compile (warm worker), then gate -> export -> simulate in the limited child."""
    result, timings, staging = run.result, run.timings, run.staging
    run.enter("compile", f"compiling {name}")
    try:
        t = time.perf_counter()
        model = steps.compile_model(source, name=name, warm=True)
        timings["compile_s"] = time.perf_counter() - t
    except CompileError as exc:
        result.findings = exc.findings or [Finding("compile", str(exc))]
        run.fail(Status.FAILED)
        return
    result.model = model
    result.findings = list(model.findings)
    if not model.ok:
        run.fail(Status.FAILED)
        return
    from ..limited import ChildFailure, run_limited
    first = "gates" if gates else "export"
    run.enter(first, _GATES_LINE if gates else _export_line(model, fmts))

    def heavy(send: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
        return verify_and_export(model, source, staging.dir, fmts, gates=gates, simulate=simulate,
                                 export_failed=export_failed, step_schema=step_schema, send=send)

    try:
        out = run_limited(heavy, stage=first,
                          on_message=lambda m: run.enter(str(m["stage"]), str(m["line"])))
    except ChildFailure as exc:
        if exc.kind != "error":  # out of memory, over time, killed: a finding, not a dead CLI
            run.fail(Status.FAILED, [Finding(f"parent-{exc.kind}", str(exc))])
            return
        if exc.exc_type == "KeyboardInterrupt":
            raise KeyboardInterrupt from None
        if exc.oserror:
            raise OutputError(result.out_dir, str(exc)) from None
        if exc.procedura:  # e.g. the mate graph is not a tree
            run.fail(Status.FAILED, [Finding(exc.stage, str(exc))])
            return
        raise RuntimeError(f"{exc.exc_type} in the {exc.stage} stage: {exc}") from None
    timings.update(out["timings"])
    run.sections.update(out["sections"])
    gate_errors = [Finding.from_dict(f) for f in out["gate_errors"]]
    battery = [Finding.from_dict(f) for f in out["battery_findings"]]
    masses = [Finding.from_dict(f) for f in out.get("mass_findings", [])]
    result.findings += [*gate_errors, *masses, *battery]
    status = (Status.GATES_FAILED if failed(gate_errors) else
              Status.BATTERY_FAILED if failed(battery) else Status.OK)
    if out["exported"] and "sheet.png" not in out["files"]:  # this process holds the GL context
        run.enter("sheet", "drawing sheet.png")
        steps.sheet(model, staging.dir, timings=timings)
        out["files"].append("sheet.png")
    run.enter("save", f"saving {result.out_dir}")
    if out["exported"]:
        result.files.update({rel: staging.dir / rel for rel in out["files"]})
        run.succeed(status)
    else:  # gates failed, nothing exported: as a failed build (the previous one is kept)
        run.fail(status)


_GATES_LINE = "running the gates"
#: Export beside the gates (a second process, :mod:`procedura_brep.run.overlap`) where there
#: is a second core; off, the export starts when the gates have passed.
OVERLAP_EXPORT = (os.cpu_count() or 1) > 1


def _export_line(model: CompiledModel, fmts: tuple[str, ...]) -> str:
    return f"writing {len(model.parts)} parts as {', '.join(fmts)}"


def verify_and_export(model: CompiledModel, source: str, root: Path, fmts: tuple[str, ...], *,
                      gates: bool, simulate: bool, export_failed: bool, step_schema: str,
                      send: Callable[[dict[str, Any]], None]) -> dict[str, Any]:
    """gate -> export -> simulate into ``root`` (the staging folder): everything that
    tessellates. Runs in the limited child of :func:`procedura_brep.limited.run_limited`;
    returns what the parent needs (JSON-safe): the sections of the report, the findings that
    fail the build, the files written, the timings and whether anything was exported.

    A model that fails its gates is not exported (nor simulated) unless ``export_failed``.
    With the gates on and ``OVERLAP_EXPORT``, the export runs beside the gates in a child of
    its own and is kept only when it is wanted (:mod:`procedura_brep.run.overlap`)."""
    timings: dict[str, float] = {}
    sections: dict[str, Any] = {}
    gate_errors: list[Finding] = []
    battery: list[Finding] = []
    hollow = sum(p.hollow is not None for p in model.parts)
    if hollow:  # exact shells take a forked offset each (up to config'd seconds): say so
        send({"stage": "masses", "line": f"weighing {hollow} hollow part(s) as shells"})
    masses = _masses(model, sections, timings)  # before any fork: its children inherit the shells
    if hollow:  # back to the stage the parent announced
        send({"stage": "gates" if gates else "export",
              "line": _GATES_LINE if gates else _export_line(model, fmts)})
    ahead = None
    if gates and OVERLAP_EXPORT:
        from .overlap import start_export
        ahead = start_export(model, root, formats=fmts, step_schema=step_schema)
        timings["tessellate_s"] = ahead.tessellate_s
    try:
        if gates:
            verdict = steps.gate(model, source)
            timings["gates_s"] = verdict.seconds
            sections["gates"] = verdict.report
            gate_errors = verdict.errors
        exported = not failed(gate_errors) or export_failed
        files: list[str] = []
        if exported:
            if gates:
                send({"stage": "export", "line": _export_line(model, fmts)})
            if ahead is not None:
                bundle = ahead.finish()
            else:
                bundle = steps.export(model, root, formats=fmts, step_schema=step_schema)  # type: ignore[arg-type]  # the CLI's StepSchema enum checked it
    finally:
        if ahead is not None:
            ahead.discard()  # killed and removed unless finished
    if exported:
        timings.update(bundle.timings)
        files = list(bundle.files)
        if "sheet.png" not in files and not steps.gl_in_use():  # else the parent draws it
            # (a forked child cannot use an inherited GL context); the overlapped export drew it
            send({"stage": "sheet", "line": "drawing sheet.png"})
            files.append(steps.sheet(model, root, timings=timings).name)
        if simulate:
            send({"stage": "battery", "line": "running the MuJoCo battery"})
            bv = steps.simulate(model, bundle)
            timings["battery_s"] = bv.seconds
            sections["battery"] = bv.report
            battery = bv.findings
    return {"files": files, "timings": timings, "sections": sections, "exported": exported,
            "gate_errors": [f.as_dict() for f in gate_errors],
            "battery_findings": [f.as_dict() for f in battery],
            "mass_findings": [f.as_dict() for f in masses]}


def _masses(model: CompiledModel, sections: dict[str, Any], timings: dict[str, float]) -> list[Finding]:
    """The report's ``masses`` section (per part and total, world, SI); its findings."""
    from ..articulation.mass import mass_report
    t = time.perf_counter()
    try:
        sections["masses"], found = mass_report(model)
    except ProceduraError as exc:  # a part's BRep or material the kernel cannot read
        found = [Finding("masses", f"mass properties not computed: {exc}", severity="warning")]
    timings["masses_s"] = time.perf_counter() - t
    return found



__all__ = ["BuildResult", "Progress", "build", "describe", "dump_json", "verify_and_export"]
