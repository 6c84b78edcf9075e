"""The tessellating work of ``check``, ``render``, ``export`` and ``simulate``, run in the limited
child of :func:`procedura_brep.limited.run_limited` (as ``build`` and ``generate`` do).

The CLI compiles in the sandbox worker, then hands the compiled model to one of the functions
here. Each runs its meshing, gates, exports, renders or battery in a forked child under
:data:`procedura_brep.config.PARENT` (address space, wall clock) and returns a JSON-safe dict, so
a program whose geometry blows up memory or time there ends in one :class:`StageError` line
(exit 1), never a dead or hung CLI. Errors the child raised on purpose come back as the same
:class:`~procedura_brep.errors.ProceduraError` subclass (so the CLI keeps its exit codes); any
other exception is our bug and comes back as a ``RuntimeError`` naming its type.

Rendering cannot fork from a process that already holds a GL context (its driver threads do not
survive a fork; the CLI never holds one): a library caller that rendered in-process gets its
render in-process, and the result says ``"isolated": False``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from .. import errors
from ..errors import OutputError, ProceduraError
from ..limited import ChildFailure, Send, run_limited
from ..program.model import CompiledModel
from .steps import gl_in_use

Progress = Callable[[str], None]
#: ProceduraError classes whose message alone rebuilds them in the parent.
_BY_MESSAGE = ("EditError", "InputError", "CompileError", "KernelError")


class StageError(ProceduraError):
    """A limited stage ran out of memory or time, was killed or crashed (``kind``, ``stage``)."""

    def __init__(self, message: str, *, kind: str, stage: str) -> None:
        self.kind, self.stage = kind, stage
        super().__init__(message)


def _raise(exc: ChildFailure, out: Path | None, command: str) -> NoReturn:
    """Turn a child failure into the exception the CLI maps to the right exit code."""
    if exc.kind != "error":
        raise StageError(f"{command} failed: {exc}", kind=exc.kind, stage=exc.stage) from None
    if exc.exc_type == "KeyboardInterrupt":
        raise KeyboardInterrupt from None
    msg = str(exc)
    if exc.exc_type == "OutputError" or (exc.oserror and out is not None):
        prefix = f"cannot write output {out}: "
        raise OutputError(out, msg[len(prefix):] if msg.startswith(prefix) else msg) from None
    if exc.procedura:
        cls = getattr(errors, exc.exc_type or "", None) if exc.exc_type in _BY_MESSAGE else None
        raise (cls or ProceduraError)(msg) from None
    raise RuntimeError(f"{exc.exc_type} in the {exc.stage} stage: {msg}") from None


def _limited(fn: Callable[[Send], dict[str, Any]], *, command: str, stage: str,
             progress: Progress | None, out: Path | None = None) -> dict[str, Any]:
    def relay(msg: dict[str, Any]) -> None:
        if progress is not None and "line" in msg:
            progress(str(msg["line"]))

    try:
        return run_limited(fn, stage=stage, on_message=relay)
    except ChildFailure as exc:
        _raise(exc, out, command)


def check(model: CompiledModel, source: str, *, progress: Progress | None = None) -> dict[str, Any]:
    """Every gate and the mesh metrics (``gates.check_model(...).as_dict()``), in the child.

    Raises:
        StageError: the gates ran out of memory or time, or their process died.
    """
    def heavy(send: Send) -> dict[str, Any]:
        from ..gates import check_model
        return check_model(model, source).as_dict()

    if progress is not None:
        progress("running the gates")
    return _limited(heavy, command="check", stage="gates", progress=progress)


def export(model: CompiledModel, out: Path, *, formats: tuple[str, ...], step_schema: str,
           progress: Progress | None = None) -> list[str]:
    """Write the export bundle into ``out`` in the child; returns the files written (relative).

    Raises:
        OutputError: ``out`` cannot be written.
        StageError: as :func:`check`.
    """
    def heavy(send: Send) -> dict[str, Any]:
        from ..export.bundle import write_bundle
        from .directory import output_reason
        try:
            files = write_bundle(model, out, formats=formats, step_schema=step_schema)  # type: ignore[arg-type]  # the CLI's StepSchema enum checked it
        except OSError as exc:
            raise OutputError(out, output_reason(exc, out)) from None
        return {"files": sorted(str(k) for k in files)}

    if progress is not None:
        progress(f"writing {len(model.parts)} parts as {', '.join(formats)}")
    return list(_limited(heavy, command="export", stage="export", progress=progress, out=out)["files"])


def render(model: CompiledModel, out: Path, *, progress: Progress | None = None,
           **options: Any) -> dict[str, Any]:
    """``render.render_to_dir(model, out, **options).as_dict()`` in the child (plus
    ``"isolated"``: whether it ran there).

    Raises:
        EditError: an unknown view or close-up name, a size out of range (exit 2).
        StageError: as :func:`check`.
    """
    def heavy(send: Send) -> dict[str, Any]:
        from ..errors import EditError
        from ..render import render_to_dir
        try:
            res = render_to_dir(model, out, **options)
        except ValueError as exc:
            raise EditError(str(exc)) from None
        return res.as_dict()

    if progress is not None:
        progress("rendering")
    if gl_in_use():  # pragma: no cover - library callers only; the CLI never draws before
        return {**heavy(lambda msg: None), "isolated": False}
    return {**_limited(heavy, command="render", stage="render", progress=progress, out=out), "isolated": True}


def simulate(model: CompiledModel, target: Path, *, out: Path | None,
             progress: Progress | None = None) -> dict[str, Any]:
    """The MuJoCo battery (``BatteryReport.as_dict()``) in the child.

    ``target`` is a run directory (its bundle is used, written first when it has no
    ``model.xml``; failure frames go there) or a program file (the bundle goes to ``out``, or a
    temporary directory). ``model`` is ``target``'s compiled program.

    Raises:
        StageError: as :func:`check`.
    """
    def heavy(send: Send) -> dict[str, Any]:
        from ..sim import battery
        if target.is_dir():
            return battery.run_bundle(model, target, frames=not gl_in_use()).as_dict()
        return battery.run_battery(model, out_dir=out, frames=not gl_in_use()).as_dict()

    if progress is not None:
        progress("running the MuJoCo battery")
    return _limited(heavy, command="simulate", stage="battery", progress=progress, out=out)


__all__ = ["StageError", "check", "export", "render", "simulate"]
