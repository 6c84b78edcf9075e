"""The four steps of a run, each a plain function of values: compile -> gate -> export -> simulate.

* :func:`compile_model` (program text -> :class:`CompiledModel`, in the sandbox worker),
* :func:`gate` (model -> :class:`GateVerdict`: every gate's findings; writes nothing),
* :func:`export` (model -> :class:`Bundle`: the export files and ``mates.json`` in a folder),
* :func:`simulate` (model + its bundle -> :class:`BatteryVerdict`; never reads ``program.py``).

Each can be called alone (the staged agent compiles and gates one part at a time and writes
nothing); :func:`procedura_brep.run.build.build` composes them into a run directory. ``gate``,
``export`` and ``simulate`` tessellate: a caller that must survive a model whose meshes blow
up runs them in :func:`procedura_brep.limited.run_limited` (``build`` does).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from .. import interrupt
from ..findings import Finding, blocking, failed
from ..paths import json_default, write_atomic
from ..program.model import CompiledModel

log = logging.getLogger(__name__)


def compile_model(source: str, *, name: str = "model", warm: bool = False) -> CompiledModel:
    """Compile ``source`` in the sandbox worker (the one compile of the run layer).

    Args:
        source: the program text (untrusted: it runs only in the sandbox).
        name: the model name.
        warm: the CLI's cold path: refuse an oversized program first, start the worker, and
            load this process's OCP, gate and export modules in a thread while the worker
            boots and compiles (free wall time: the compile waits on a pipe, without the GIL).

    Returns:
        The model; its ``findings`` say whether it compiled cleanly (``model.ok``).

    Raises:
        CompileError: the worker refused or could not compile the program (its ``findings``
            say why).
    """
    from ..program.sandbox import (
        compile_source,
        default_worker,
        kill_default_worker,
        refuse_oversized,
    )
    if not warm:
        return compile_source(source, name=name)
    refuse_oversized(source)  # before paying for the worker and the warm-up
    with interrupt.children_ignore_sigint():  # the terminal's Ctrl-C is ours to handle
        default_worker()  # starts the worker process now, returns at once
    interrupt.add_cleanup(kill_default_worker)
    loader = threading.Thread(target=warm_imports, name="warm-imports", daemon=True)
    loader.start()
    try:
        return compile_source(source, name=name)
    finally:
        loader.join()  # what follows (gates, exports) and any fork need the imports done


def settle() -> None:
    """Mark what this process holds now as long-lived: collect the garbage of the step just
    done, then move every survivor out of the cyclic collector's generations (``gc.freeze``).

    The staged agent calls it when it commits a part: the committed baseline (model, meshes,
    gate caches) lives on, and without this the next step's full collection walks all of it
    (about 0.09 s at 40 parts here, paid by whichever step triggers it). After it, a collection
    scans only what later steps made. What is frozen is still freed by reference counting;
    only reference cycles among frozen objects wait for :func:`gc.unfreeze`.
    """
    import gc
    gc.collect()
    gc.freeze()


def warm_imports(*, render: bool = False) -> None:
    """Import OCP and what gates and exports need while the worker boots and compiles (in a
    thread of :func:`compile_model`; the warm server, ``procedura-brep serve``, calls it once,
    with ``render`` for the renderer's modules too). The cyclic collector is paused meanwhile
    (imports make objects, not garbage: about 0.2 s of 1.2 s here), then what they made is
    frozen out of its reach, as the worker does. A failure is left for the real import to
    report."""
    import gc
    was = gc.isenabled()
    gc.disable()
    try:
        from .. import kernel
        kernel.warm_up()
        import scipy.sparse.csgraph  # noqa: F401 - the gates' and the exports' mesh components
        import scipy.spatial  # noqa: F401 - imported early, beside the worker's boot
        import shapely  # noqa: F401 - the articulation evidence's contact polygons
        from PIL import Image, PngImagePlugin  # noqa: F401 - the sheet's PNG

        from .. import gates  # noqa: F401 - imported early, beside the worker's boot
        from ..export import bundle  # noqa: F401 - imported early, beside the worker's boot
        try:
            import mujoco  # noqa: F401 - imported early, beside the worker's boot
            from pxr import Usd, UsdPhysics  # noqa: F401 - imported early, beside the worker's boot

            from ..export.usd import serial_usd
            serial_usd()  # before this process or any it forks makes a stage
        except ImportError:  # pragma: no cover - reported by doctor
            pass
        if render:
            import moderngl  # noqa: F401 - no context: a forked child makes its own

            from ..render import api  # noqa: F401 - the server's forks draw without importing
    except Exception:  # noqa: BLE001 - the step that needs the module imports it again and says why
        log.debug("warm imports failed", exc_info=True)
    finally:
        if was:
            gc.freeze()
            gc.enable()


@dataclass
class Verdict:
    """What a step's checks say about one model: the JSON-safe report, its findings, the time.

    Attributes:
        report: the step's report (JSON-safe).
        findings: its findings; :attr:`passed` applies the one policy to them.
        seconds: wall time of the step.
    """

    report: dict[str, Any]
    findings: list[Finding]
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return not failed(self.findings)

    @property
    def errors(self) -> list[Finding]:
        """The findings that fail the model (:func:`procedura_brep.findings.blocking`)."""
        return blocking(self.findings)


@dataclass
class GateVerdict(Verdict):
    """What the gates say about one model: ``report`` is the gate report
    (:meth:`procedura_brep.gates.CheckReport.as_dict`); ``findings`` every gate finding (errors,
    warnings, infos), compile findings included."""


def gate(model: CompiledModel, source: str | None = None, *,
         baseline: int | None = None) -> GateVerdict:
    """Every gate on ``model`` (:func:`procedura_brep.gates.check_model`); writes nothing.

    Args:
        model: a compiled model.
        source: the program text (line context in the feedback).
        baseline: the running N_vis of a staged build (floaters fail only above it).
    """
    from ..gates import check_model
    t = time.perf_counter()
    check = check_model(model, source, baseline=baseline)
    return GateVerdict(check.as_dict(), check.findings, time.perf_counter() - t)


@dataclass
class Bundle:
    """The files :func:`export` wrote.

    Attributes:
        root: the folder they are in.
        files: relative path -> path, ``mates.json`` included.
        timings: seconds per stage (``export_<format>_s``, ``export_s``, ``evidence_s``,
            ``articulate_s``).
        art: the articulation the USD, URDF and MJCF were written from (the battery takes the
            same one); None when none of them was written.
    """

    root: Path
    files: dict[str, Path] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    art: Any = None


def export(model: CompiledModel, root: Path, *, formats: tuple[str, ...] | None = None,
           step_schema: Literal["AP214", "AP242"] = "AP214",
           evidence: bool | None = None) -> Bundle:
    """Write the export bundle and ``mates.json`` of ``model`` into ``root``.

    Args:
        model: a compiled model.
        root: the folder (created).
        formats: the export formats (None: all).
        step_schema: ``AP214`` or ``AP242``.
        evidence: add the articulation evidence to ``mates.json`` (default: when more than one
            format is written).

    Raises:
        ArticulationError: the mate graph is not a tree.
        OSError: ``root`` cannot be written.
    """
    from ..export.bundle import parse_formats
    fmts = parse_formats(formats)
    timings: dict[str, float] = {}
    written, art = export_formats(model, root, fmts, step_schema=step_schema, timings=timings)
    written["mates.json"] = export_mates(model, root, evidence=len(fmts) > 1 if evidence is None
                                         else evidence, timings=timings)
    return Bundle(root, written, timings, art)


def export_formats(model: CompiledModel, root: Path, fmts: tuple[str, ...], *,
                   step_schema: str = "AP214", art: Any = None,
                   timings: dict[str, float] | None = None) -> tuple[dict[str, Path], Any]:
    """Write the formats ``fmts`` (validated names) of ``model`` into ``root``; returns the files
    written and the articulation they were written from (``art``, built here when a format
    needs one and none is given). Adds ``articulate_s``, ``export_<format>_s`` and
    ``export_s`` (the writing, without the articulation) to ``timings``, summed over calls."""
    from ..export.bundle import write_bundle
    times = timings if timings is not None else {}
    if art is None and {"usd", "urdf", "mjcf"} & set(fmts):
        from ..articulation import articulate
        t = time.perf_counter()
        art = articulate(model)  # built once: the exporters and the battery take the same one
        times["articulate_s"] = times.get("articulate_s", 0.0) + time.perf_counter() - t
    per: dict[str, float] = {}
    t = time.perf_counter()
    written = write_bundle(model, root, formats=fmts, timings=per,
                           step_schema=step_schema, art=art)  # type: ignore[arg-type]  # the CLI's StepSchema enum checked it
    times["export_s"] = times.get("export_s", 0.0) + time.perf_counter() - t
    for k, v in per.items():
        times[f"export_{k}_s"] = times.get(f"export_{k}_s", 0.0) + v
    return written, art


def export_mates(model: CompiledModel, root: Path, *, evidence: bool,
                 timings: dict[str, float] | None = None) -> Path:
    """Write ``root/mates.json`` (with the articulation evidence when ``evidence``; its time is
    ``timings["evidence_s"]``); returns its path."""
    from ..export.records import mates_json
    ev = None
    if evidence:
        t = time.perf_counter()
        from ..articulation import mates_evidence
        ev = mates_evidence(model)
        if timings is not None:
            timings["evidence_s"] = time.perf_counter() - t
    return write_atomic(root / "mates.json", dump_json(mates_json(model, ev)))


#: The run directory's picture (``sheet.png``): PBR, the six orthographic views and an iso.
SHEET_VIEWS: tuple[str, ...] = ("iso_se", "front", "back", "left", "right", "top", "bottom")
#: Tile side of ``sheet.png`` in pixels.
SHEET_SIZE = 384


def sheet(model: CompiledModel, root: Path, *, timings: dict[str, float] | None = None) -> Path:
    """Draw ``root/sheet.png``: the model in PBR from :data:`SHEET_VIEWS`, each view labelled
    with where its camera stands, the legend naming every part and its material. Returns its
    path; ``timings["sheet_s"]`` is the time it took.

    Draws in this process: a caller that inherited a GL context from a forking parent (see
    :func:`gl_in_use`) must draw it in that parent instead."""
    from ..render import sheet_image
    t = time.perf_counter()
    dest = root / "sheet.png"
    sheet_image(model, list(SHEET_VIEWS), mode="pbr", size=SHEET_SIZE).save(dest)
    if timings is not None:
        timings["sheet_s"] = time.perf_counter() - t
    return dest


@dataclass
class BatteryVerdict(Verdict):
    """What the MuJoCo battery says about one model: ``report`` is the battery report
    (:meth:`procedura_brep.sim.BatteryReport.as_dict`); ``findings`` one error finding per failed
    check (:func:`procedura_brep.sim.battery.failures`)."""


def simulate(model: CompiledModel, bundle: Bundle | Path | None = None, *,
             frames: bool = True) -> BatteryVerdict:
    """The MuJoCo battery on ``model``, reading the bundle :func:`export` just wrote.

    ``program.py`` is never read: the model is the reference. A format the battery needs that
    the bundle lacks (``--formats step``) is written into the bundle's folder; with no bundle,
    everything goes to a temporary folder (no failure frames are kept).

    Args:
        model: a compiled model.
        bundle: its bundle (or the folder holding it); failure frames go under it.
        frames: save frames of a failing phase (off when this process holds a GL context,
            which a forked child cannot use: the report's notes say so).
    """
    from ..sim.battery import failures, run_battery
    root = bundle.root if isinstance(bundle, Bundle) else bundle
    t = time.perf_counter()
    draw = frames and not gl_in_use()
    art = bundle.art if isinstance(bundle, Bundle) else None
    report = run_battery(model, out_dir=root, frames=draw, exported=root is not None,
                         art=art).as_dict()
    if frames and not draw:
        report.setdefault("notes", []).append(
            "no failure frames: this process inherited a GL context, which a forked child "
            "cannot use")
    return BatteryVerdict(report, failures(report), time.perf_counter() - t)


def gl_in_use() -> bool:
    """Whether this process holds (or inherited) a GL context (its driver threads do not survive a fork,
    so the child must not draw battery frames with it)."""
    import sys
    gl = sys.modules.get("procedura_brep.render.gl")
    return getattr(gl, "_RENDERER", None) is not None


def dump_json(obj: Any) -> str:
    """The run directory's JSON layout (indented, UTF-8, numpy-safe)."""
    import json
    return json.dumps(obj, indent=2, sort_keys=False, ensure_ascii=False, default=json_default) + "\n"


__all__ = ["SHEET_VIEWS", "BatteryVerdict", "Bundle", "GateVerdict", "compile_model", "dump_json", "warm_imports",
           "export", "export_formats", "export_mates", "gate", "gl_in_use", "sheet", "simulate"]
