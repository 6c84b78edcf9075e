"""The ``procedura-brep`` command line: argument parsing and exit codes only.

Exit codes: 0 success; 1 the program built but a gate or check failed (or the build failed on
its own findings); 2 usage errors, unreadable input, unwritable output, or a program that does
not compile; 3 an internal error (our bug: please report it, ``-v`` shows the traceback); 130
interrupted (Ctrl-C; 143 for SIGTERM). ``build``, ``generate`` and ``revise`` map their run's
status to a code in one place, :func:`procedura_brep.run.status.exit_code`. Errors are one line
on stderr, never a traceback.
Progress goes to stderr too (``-q`` silences it), so stdout stays clean for ``--json``.
"""

from __future__ import annotations

import functools
import logging
import os
import sys
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, Callable, Optional

import typer

from .console import err as _err
from .console import more as _more
from .export.registry import FORMAT_NAMES
from .run.status import EXIT_FAIL, EXIT_INTERNAL, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, exit_code

app = typer.Typer(
    name="procedura-brep", add_completion=False, no_args_is_help=True,
    pretty_exceptions_show_locals=False,
    help="Text prompt -> editable CAD assembly: build123d parts joined by typed, checked mates.")


class _State:
    """Global options of this invocation."""

    verbose = False


class StepSchema(str, Enum):
    """STEP application protocols the exporter writes."""

    AP214 = "AP214"
    AP242 = "AP242"


#: The ``--formats`` names (the rows of :mod:`.export.registry`), as the help text lists them.
FORMAT_LIST = ",".join(FORMAT_NAMES)
FormatsOption = Annotated[Optional[str], typer.Option(
    help=f"Comma list of {FORMAT_LIST} (default: all).")]
StepSchemaOption = Annotated[StepSchema, typer.Option("--step-schema", help="STEP application protocol.")]
QuietOption = Annotated[bool, typer.Option("--quiet", "-q", help="No progress lines on stderr.")]


def guarded(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn any library error into a one-line message and an exit code."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from . import interrupt
        try:
            return mapped(*args, **kwargs)
        except BaseException:
            interrupt.hold()  # Ctrl-C under way: its watcher prints, writes and exits
            raise

    def mapped(*args: Any, **kwargs: Any) -> Any:
        from .errors import CompileError, EditError, InputError, OutputError, ProceduraError, ProgramFormatError
        try:
            return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except (EditError, ProgramFormatError, CompileError, InputError, OutputError) as exc:
            _err(str(exc))
            from .findings import blocking
            errors = blocking(getattr(exc, "findings", []))
            if _State.verbose and len(errors) > 1:
                from .run.report import describe
                _more([describe(f) for f in errors[1:]])
            raise typer.Exit(EXIT_USAGE) from None
        except ProceduraError as exc:
            from .llm.errors import ConfigError
            _err(str(exc))
            raise typer.Exit(EXIT_USAGE if isinstance(exc, ConfigError) else EXIT_FAIL) from None
        except OSError as exc:  # a path we did not check first: name it, do not guess a side
            what = f" {exc.filename}" if exc.filename else ""
            _err(f"cannot access{what}: {(exc.strerror or str(exc)).lower()}")
            raise typer.Exit(EXIT_USAGE) from None
        except KeyboardInterrupt:
            _err("interrupted")
            raise typer.Exit(EXIT_INTERRUPTED) from None
        except Exception as exc:  # noqa: BLE001 - never a traceback for users
            logging.getLogger(__name__).debug("internal error", exc_info=True)
            _err(f"internal error: {type(exc).__name__}: {exc} (run with -v for details)")
            raise typer.Exit(EXIT_INTERNAL) from None

    return wrapper


class _SafeFormatter(logging.Formatter):
    """Log records may quote a program or a model: no escape sequences on the terminal."""

    def format(self, record: logging.LogRecord) -> str:
        from .text import terminal_safe
        return terminal_safe(super().format(record), one_line=False)


@app.callback()
def main_callback(verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log details.")] = False
                  ) -> None:
    _State.verbose = verbose
    handler = logging.StreamHandler()
    handler.setFormatter(_SafeFormatter("%(levelname)s %(name)s: %(message)s"))
    # -v is this tool's own detail: other libraries (OpenGL, MuJoCo, USD ...) stay at WARNING
    logging.basicConfig(level=logging.WARNING, handlers=[handler])
    logging.getLogger("procedura_brep").setLevel(logging.DEBUG if verbose else logging.WARNING)


def hoist_verbose(argv: list[str]) -> list[str]:
    """``argv`` with every ``-v``/``--verbose`` moved in front of the subcommand, where the
    option lives, so ``procedura-brep build P -o D -v`` works as the README says. Tokens after a
    ``--`` are left alone."""
    end = argv.index("--") if "--" in argv else len(argv)
    flags = [a for a in argv[:end] if a in ("-v", "--verbose")]
    rest = [a for a in argv[:end] if a not in ("-v", "--verbose")]
    return flags + rest + argv[end:]


def _json(data: Any) -> None:
    """``data`` on stdout as indented JSON (values JSON does not know, as their text)."""
    import json
    typer.echo(json.dumps(data, indent=2, default=str, ensure_ascii=False))


def _verdict(data: dict[str, Any], json_: bool, table: Callable[[dict[str, Any]], None]) -> None:
    """The end of ``check`` and ``simulate``: the report as JSON or as its table, then exit 0
    when it passed, 1 when not."""
    if json_:
        _json(data)
    else:
        table(data)
    raise typer.Exit(EXIT_OK if data["passed"] else EXIT_FAIL)


def _read(program: Path) -> str:
    """The program text, or an :class:`InputError` that names the file and what is wrong."""
    from .errors import InputError
    try:
        if not program.exists():
            raise InputError(f"program {program} does not exist")
        if not program.is_file():
            raise InputError(f"program {program} is not a file")
        raw = program.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read input {program}: {(exc.strerror or str(exc)).lower()}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(f"program {program} is not UTF-8 text (byte 0x{raw[exc.start]:02x} at "
                         f"offset {exc.start}); pass a .py file in the program format") from None


def _progress(quiet: bool):
    from .progress import Progress
    return Progress(quiet=quiet)


def _output_dir(path: Path) -> Path:
    """Fail early (before any compile) when ``path`` cannot be a writable directory."""
    from .run.directory import ensure_dir
    return ensure_dir(path)


def _report_errors(reason: str, errors: list[Any]) -> None:
    """The first error on one line; with ``-v`` every further one too."""
    _err(reason)
    if _State.verbose and len(errors) > 1:
        from .run.report import describe
        _more([describe(f) for f in errors[1:]])


def _formats(text: str | None) -> tuple[str, ...]:
    """``--formats`` -> validated format names (None: all), as a usage error when unknown."""
    from .errors import EditError
    from .export.bundle import parse_formats
    try:
        return parse_formats(text)
    except ValueError as exc:
        raise EditError(str(exc)) from None


def _do_build(program: Path, out: Path, formats: tuple[str, ...], source: str | None = None,
              gates: bool = True, simulate: bool = False, step_schema: str = "AP214",
              quiet: bool = False, keep_failed: bool = False) -> int:
    from .run.build import build
    with _progress(quiet) as progress:
        res = build(program, out, formats=formats, source=source, gates=gates, simulate=simulate,
                    step_schema=step_schema, progress=progress, export_failed=keep_failed)
    if res.ok:
        n = len(res.model.parts) if res.model else 0
        t = res.report.get("timings", {}).get("total_s", 0.0)
        typer.echo(f"built {n} parts, {len(res.model.mates) if res.model else 0} mates -> {out} "
                   f"({t:.1f} s, status {res.status}){_sheet(out)}")
        return EXIT_OK
    kept = " (the previous build in the directory is kept)" if res.report.get("kept_previous") else ""
    _report_errors(f"build failed: {res.reason}{kept}", res.errors)
    t = res.report.get("timings", {}).get("total_s", 0.0)
    typer.echo(f"status {res.status}, {t:.1f} s -> {out} (report.json, summary.md){_sheet(out)}", err=True)
    return res.exit_code


@app.command()
@guarded
def build(
    program: Annotated[Path, typer.Argument(help="The program file (a .py in the program format).")],
    out: Annotated[Path, typer.Option("-o", "--out", help="The run directory to write.")],
    formats: FormatsOption = None,
    no_gates: Annotated[bool, typer.Option("--no-gates", help="Skip the verification gates.")] = False,
    simulate: Annotated[bool, typer.Option("--simulate", help="Also run the MuJoCo battery and "
                                                              "record it in report.json.")] = False,
    step_schema: StepSchemaOption = StepSchema.AP214,
    keep_failed: Annotated[bool, typer.Option("--keep-failed", help="Export a model that fails "
                                                                    "its gates too.")] = False,
    quiet: QuietOption = False,
) -> None:
    """Compile PROGRAM in the sandbox, gate it, and write the run directory (its exports only
    when the gates pass, or with --keep-failed; report.json always)."""
    source = _read(program)
    fmts = _formats(formats)
    _output_dir(out)
    raise typer.Exit(_do_build(program, out, fmts, source=source, gates=not no_gates,
                               simulate=simulate, step_schema=step_schema.value, quiet=quiet,
                               keep_failed=keep_failed))


@app.command()
@guarded
def export(
    program: Annotated[Path, typer.Argument(help="The program to export.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Directory for the exports.")],
    formats: FormatsOption = None,
    step_schema: StepSchemaOption = StepSchema.AP214,
    quiet: QuietOption = False,
) -> None:
    """Write the export bundle of PROGRAM (no gates, no report)."""
    from .run import commands
    fmts = _formats(formats)
    _output_dir(out)
    with _progress(quiet) as progress:
        model = _compiled(program, progress=progress)
        files = commands.export(model, out, formats=fmts, step_schema=step_schema.value,
                                progress=progress)
    typer.echo(f"wrote {len(files)} files -> {out}")
    for rel in sorted(files):
        typer.echo(f"  {rel}")


@app.command()
@guarded
def simulate(
    target: Annotated[Path, typer.Argument(help="A run directory (with program.py and its exports) "
                                                "or a program file.")],
    json_: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
    out: Annotated[Optional[Path], typer.Option("-o", "--out", help="Where a program's bundle and "
                                                                    "failure frames go.")] = None,
    quiet: QuietOption = False,
) -> None:
    """Run the MuJoCo battery B0-B8; exit 1 when any check fails, 2 when TARGET is unusable."""

    from .errors import InputError
    from .run import commands
    if not target.exists():
        raise InputError(f"{target} does not exist; pass a run directory or a program file")
    if target.is_dir() and not (target / "program.py").is_file():
        raise InputError(f"{target} has no program.py; build it first "
                         f"(procedura-brep build PROGRAM -o {target}) or pass a program file")
    program = target if target.is_file() else target / "program.py"
    source = _read(program)
    if out is not None:
        _output_dir(out)
    with _progress(quiet) as progress:
        model = _compiled(program, source, progress=progress)
        data = commands.simulate(model, target, out=out, progress=progress)
    from .console import print_battery
    _verdict(data, json_, print_battery)


@app.command()
@guarded
def edit(
    program: Annotated[Path, typer.Argument(help="The program to edit.")],
    set_: Annotated[list[str], typer.Option("--set", help="NAME=VALUE; repeatable.")],
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="Write the edited program "
                                                                          "here (default: in place).")] = None,
    build_dir: Annotated[Optional[Path], typer.Option("--build", help="Also build the edited "
                                                                      "program into this directory.")] = None,
    force: Annotated[bool, typer.Option("--force", help="Write the edit even if it breaks a mate "
                                                        "or a gate.")] = False,
    no_check: Annotated[bool, typer.Option("--no-check", help="Do not compile the edited program.")] = False,
    quiet: QuietOption = False,
) -> None:
    """Change named params (only their lines; comments and formatting kept).

    The edited program is compiled and gated first; an edit that breaks a mate or a gate is
    reported and not written (unless --force).
    """
    from .errors import OutputError
    from .findings import blocking
    from .paths import program_name, write_atomic
    from .program.edit import parse_assignment, set_params
    from .run import compile_model, gate
    from .run.build import build as run_build
    from .run.directory import output_reason
    from .run.report import describe
    source = _read(program)
    values = dict(parse_assignment(s) for s in set_)
    new = set_params(source, values)
    target = output or program
    if target.is_dir():
        raise OutputError(target, "it is a directory; name the program file to write")
    if build_dir is not None:
        _output_dir(build_dir)
    problem = None
    with _progress(quiet) as progress:
        if build_dir is not None:
            res = run_build(target, build_dir, source=new, name=program_name(program),
                            progress=progress)
            problem = None if res.ok else res.reason
        elif not no_check:
            progress(f"compiling {program_name(program)}")
            model = compile_model(new, name=program_name(program), warm=True)
            errs = blocking(model.findings)
            if not errs:
                progress("running the gates")
                errs = gate(model, new).errors
            problem = describe(errs[0]) if errs else None
    edits = ", ".join(f"{k}={v}" for k, v in values.items())
    if problem and not force:
        _err(f"edit {edits} rejected, {target} unchanged: {problem} (--force writes it anyway)")
        raise typer.Exit(EXIT_FAIL)
    try:
        write_atomic(target, new)
    except OSError as exc:
        raise OutputError(target, output_reason(exc, target)) from None
    from .text import terminal_safe
    typer.echo(f"set {edits} -> {target}" + (f" (with a problem: {terminal_safe(problem)})"
                                              if problem else ""))
    if build_dir is not None and res.model is not None:  # what it rebuilt
        t = res.report.get("timings", {}).get("total_s", 0.0)
        typer.echo(f"built {len(res.model.parts)} parts, {len(res.model.mates)} mates -> {build_dir} "
                   f"({t:.1f} s, status {res.status}){_sheet(build_dir)}")
    raise typer.Exit(EXIT_FAIL if problem else EXIT_OK)


def _compiled(program: Path, source: str | None = None, progress: Any = None):
    """PROGRAM compiled in the sandbox; a program that fails is a usage error (exit 2)."""
    from .errors import CompileError
    from .findings import blocking
    from .paths import program_name
    from .run import compile_model
    from .run.report import describe
    text = _read(program) if source is None else source
    if progress is not None:
        progress(f"compiling {program_name(program)}")
    try:
        model = compile_model(text, name=program_name(program), warm=True)
    except CompileError as exc:
        errs = exc.findings or []
        raise CompileError(f"{program} does not compile: {exc}", errs) from None
    if not model.ok:
        errs = blocking(model.findings)
        raise CompileError(f"{program} does not compile: {describe(errs[0])}"
                           + (f" (+{len(errs) - 1} more, -v lists them)" if len(errs) > 1 else ""),
                           errs)
    return model


@app.command()
@guarded
def check(
    program: Annotated[Path, typer.Argument(help="The program to check.")],
    json_: Annotated[bool, typer.Option("--json", help="Print the report as JSON (also when the "
                                                       "program does not compile).")] = False,
    quiet: QuietOption = False,
) -> None:
    """Run every gate (compile, mate, connectivity) and the mesh metrics on PROGRAM.

    Exit 0 when every gate passes, 1 when a gate fails, 2 on usage or compile errors.
    """

    from .errors import CompileError
    from .paths import program_name
    from .run import commands
    source = _read(program)
    with _progress(quiet) as progress:
        try:
            model = _compiled(program, source, progress=progress)
        except CompileError as exc:
            if not json_:
                raise
            _json({"model": program_name(program), "passed": False, "compiled": False,
                   "error": str(exc), "findings": [f.as_dict() for f in exc.findings]})
            raise typer.Exit(EXIT_USAGE) from None
        try:
            data = commands.check(model, source, progress=progress)
        except commands.StageError as exc:  # out of memory or time: a failed check, exit 1
            if not json_:
                raise
            _json({"model": program_name(program), "passed": False, "compiled": True, "error": str(exc)})
            raise typer.Exit(EXIT_FAIL) from None
    from .console import print_check
    _verdict({**data, "compiled": True} if json_ else data, json_, print_check)


@app.command()
@guarded
def render(
    program: Annotated[Path, typer.Argument(help="The program to render.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Directory for the PNGs.")],
    views: Annotated[Optional[str], typer.Option(help="Comma list of view names, or 'all' "
                                                      "(default: 12 views).")] = None,
    mode: Annotated[str, typer.Option(help="parts | clay | pbr")] = "parts",
    size: Annotated[int, typer.Option(help="Image side in pixels.")] = 512,
    sheet: Annotated[bool, typer.Option("--sheet", help="Also write a contact sheet with legend.")] = False,
    close_up: Annotated[Optional[str], typer.Option("--close-up", help="A part or mate name.")] = None,
    frames: Annotated[bool, typer.Option("--frames", help="Draw every mate frame's axes.")] = False,
    frames_of: Annotated[Optional[list[str]], typer.Option(
        "--frames-of", help="Draw this part's origin and every frame it publishes as axes at their "
                            "world poses (X red, Y green, Z blue); repeatable, or a comma list.")] = None,
    quiet: QuietOption = False,
) -> None:
    """Render views of PROGRAM (parts-colour, grey clay or PBR), with cache and staleness."""
    from .errors import EditError, RangeError
    from .render.api import MODES, SIZE_RANGE
    from .render.views import parse_views
    from .run import commands
    if mode not in MODES:  # refused before the compile
        raise EditError(f"unknown render mode {mode!r}; use one of: {', '.join(MODES)}")
    if not SIZE_RANGE[0] <= size <= SIZE_RANGE[1]:
        raise EditError(str(RangeError("--size", size, *SIZE_RANGE, unit="px")))
    try:
        parse_views(views)
    except ValueError as exc:
        raise EditError(str(exc)) from None
    _read(program)
    _output_dir(out)
    with _progress(quiet) as progress:
        model = _compiled(program, progress=progress)
        axes = [n.strip() for v in frames_of or [] for n in v.split(",") if n.strip()]
        res = commands.render(model, out, views=views, mode=mode, size=size, sheet=sheet,
                              close_up=close_up, frames_overlay=frames, frames_of=axes,
                              progress=progress)
    typer.echo(f"{len(res['rendered'])} rendered, {len(res['cached'])} from cache "
               f"({res['seconds']:.2f} s) -> {out}")
    if res["stale_before"]:
        typer.echo(f"replaced stale views: {', '.join(res['stale_before'])}")
    for key, path in sorted(res["paths"].items()):
        typer.echo(f"  {key}: {path}")


@app.command()
@guarded
def generate(
    prompt: Annotated[Optional[str], typer.Argument(help="What to model, in words (optional with a "
                                                         "replay tape or --resume).")] = None,
    out: Annotated[Optional[Path], typer.Option("-o", "--out", help="The run directory.")] = None,
    model: Annotated[Optional[str], typer.Option("--model", "-m", help="provider:model, e.g. openai:gpt-4o, "
                                                 "anthropic:..., replay:TAPE, exchange:DIR (default: "
                                                 "$PROCEDURA_BREP_MODEL, then the user config file)")] = None,
    base_url: Annotated[Optional[str], typer.Option("--base-url", help="OpenAI-compatible server URL.")] = None,
    image: Annotated[Optional[Path], typer.Option("--image", help="A reference PNG.")] = None,
    image_model: Annotated[Optional[str], typer.Option("--image-model", help="provider:model that "
                                                       "synthesises a reference image when no --image "
                                                       "is given (default: $PROCEDURA_BREP_IMAGE_MODEL, "
                                                       "then image_model in the user config file)")] = None,
    max_cost: Annotated[Optional[float], typer.Option("--max-cost", help="Stop before spending more "
                                                                         "than this many USD.")] = None,
    attempts: Annotated[int, typer.Option(min=1, max=10, help="Attempts per part (one-shot: calls).")] = 3,
    timeout: Annotated[Optional[float], typer.Option(help="Seconds to wait for one reply.")] = None,
    formats: Annotated[Optional[str], typer.Option(help=f"Exports: {FORMAT_LIST} (default: all).")] = None,
    one_shot: Annotated[bool, typer.Option("--one-shot", help="The control: the whole program in one call.")] = False,
    no_plan: Annotated[bool, typer.Option("--no-plan", help="Ablation: no assembly plan.")] = False,
    no_review: Annotated[bool, typer.Option("--no-review", help="Ablation: no plan review.")] = False,
    no_feedback: Annotated[bool, typer.Option("--no-feedback", help="Ablation: no renders in build calls.")] = False,
    no_refine: Annotated[bool, typer.Option("--no-refine", help="Ablation: ship the draft.")] = False,
    no_materials: Annotated[bool, typer.Option("--no-materials", help="Skip the materials stage (library, "
                                               "critic, sub-parts).")] = False,
    no_simulate: Annotated[bool, typer.Option("--no-simulate", help="Skip the MuJoCo battery.")] = False,
    no_articulation: Annotated[bool, typer.Option("--no-articulation", help="No articulation planning call "
                                                  "and no battery fix (the mates as built).")] = False,
    resume: Annotated[Optional[Path], typer.Option("--resume", help="Continue the killed staged run in DIR.")] = None,
    json_out: Annotated[bool, typer.Option("--json", help="Print report.json on stdout.")] = False,
    quiet: QuietOption = False,
) -> None:
    """Generate an assembly with a model: plan, review, build one part per call, refine, then build
    the run directory (``--one-shot``: the whole program in one call)."""
    from .agent.runstate import ResumeError
    from .errors import InputError
    from .llm import ConfigError, LLMError
    from .llm.settings import resolve_image_model, resolve_model
    setting = resolve_model(model, base_url)
    image_setting = resolve_image_model(image_model)
    if setting.model is None:
        _err("no model: pass --model PROVIDER:MODEL, or set PROCEDURA_BREP_MODEL, or write "
             "model = \"...\" in the user config file (procedura-brep doctor shows where)")
        raise typer.Exit(EXIT_USAGE)
    if out is None and resume is None:
        _err("say where the run goes: -o DIR (or --resume DIR)")
        raise typer.Exit(EXIT_USAGE)
    if out is not None and resume is not None and out.resolve() != resume.resolve():
        _err(f"--resume {resume} and -o {out} name different directories; give one")
        raise typer.Exit(EXIT_USAGE)
    out = out or resume
    assert out is not None
    try:
        png = image.read_bytes() if image else None
    except OSError as exc:
        raise InputError(f"cannot read input {image}: {(exc.strerror or str(exc)).lower()}") from None
    fmts = _formats(formats)
    _output_dir(out)
    import time
    started = time.perf_counter()
    try:
        with _progress(quiet) as progress:
            if one_shot:
                if resume is not None or not prompt:
                    _err("--one-shot needs a PROMPT and cannot --resume")
                    raise typer.Exit(EXIT_USAGE)
                from .agent.oneshot import generate as run
                res = run(prompt, out, model=setting.model, base_url=setting.base_url, max_cost_usd=max_cost,
                          attempts=attempts, image=png, timeout_s=timeout, formats=fmts, progress=progress)
                status, message, calls = res.status, res.message, res.attempts
            else:
                from .agent.staged import StagedOptions, generate_staged
                opts = StagedOptions(plan=not no_plan, review=not no_review, feedback=not no_feedback,
                                     refine=not no_refine, materials=not no_materials, attempts=attempts,
                                     simulate=not no_simulate, articulation=not no_articulation,
                                     formats=fmts or None)
                sres = generate_staged(prompt, out, model=setting.model, base_url=setting.base_url,
                                       options=opts, image=png, image_model=image_setting.model,
                                       max_cost_usd=max_cost, timeout_s=timeout,
                                       resume=resume is not None,
                                       progress=(lambda stage, text: progress(f"{stage}: {text}")))
                status, message, calls = sres.status, sres.message, sres.state.step
    except (ConfigError, ResumeError) as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_USAGE) from None
    except LLMError as exc:
        _err(f"{exc} (work kept in {out})")
        raise typer.Exit(EXIT_FAIL) from None
    if json_out and (out / "report.json").is_file():
        typer.echo((out / "report.json").read_text(encoding="utf-8"), nl=False)
    usage = _usage(out)
    took = time.perf_counter() - started
    if status == "ok":
        if not json_out:
            typer.echo(f"generated and built in {calls} call(s), {took:.0f} s{usage}: status ok -> {out} "
                       f"({_outputs(out)}){_sheet(out)}")
        raise typer.Exit(exit_code(status))
    _err(f"generate {status} after {calls} call(s), {took:.0f} s: {message} (work kept in {out}: "
         f"{_outputs(out)}){_sheet(out)}")
    raise typer.Exit(exit_code(status))


def _outputs(out: Path) -> str:
    """The run directory's main files that exist: what a person opens first."""
    names = ("program.py", "report.json", "model.step", "model.glb", "model.usda", "model.xml")
    return ", ".join(n for n in names if (out / n).is_file()) or "no files yet"


def _sheet(out: Path) -> str:
    """``; sheet OUT/sheet.png`` when the run directory has its picture (empty otherwise)."""
    return f"; sheet {out / 'sheet.png'}" if (out / "sheet.png").is_file() else ""


def _usage(out: Path) -> str:
    """``, cost $x`` from the run's report (empty when unknown)."""
    import json
    try:
        report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return ""
    cost = ((report.get("usage") or {}).get("total") or {}).get("cost_usd")
    return f", cost ${cost:.4f}" if isinstance(cost, (int, float)) else ""


@app.command()
@guarded
def revise(
    run_dir: Annotated[Path, typer.Argument(help="A run directory (from build or generate).")],
    instruction: Annotated[str, typer.Argument(help="The change, in words: \"make the wheels bigger\".")],
    part: Annotated[Optional[list[str]], typer.Option("--part", help="Only this part may change "
                                                                      "(repeat for several).")] = None,
    model: Annotated[Optional[str], typer.Option("--model", "-m", help="provider:model (default: "
                                                 "$PROCEDURA_BREP_MODEL, then the user config file)")] = None,
    base_url: Annotated[Optional[str], typer.Option("--base-url")] = None,
    max_edits: Annotated[int, typer.Option(min=1, max=20, help="Edits allowed.")] = 4,
    max_calls: Annotated[int, typer.Option(min=2, max=200, help="Model calls allowed (fixer and "
                                           "critic); the edits made before the bound are kept.")] = 32,
    no_simulate: Annotated[bool, typer.Option("--no-simulate", help="Skip the MuJoCo battery.")] = False,
    json_out: Annotated[bool, typer.Option("--json", help="Print the revision report on stdout.")] = False,
    quiet: QuietOption = False,
) -> None:
    """Apply a person's change request to a run directory through diagnosed, gated edits."""
    import time
    started = time.perf_counter()

    from .agent.revise import ReviseError
    from .agent.revise import revise as run
    from .llm import ConfigError, LLMError
    from .llm.settings import resolve_model
    setting = resolve_model(model, base_url)
    if setting.model is None:
        _err("no model: pass --model PROVIDER:MODEL, or set PROCEDURA_BREP_MODEL")
        raise typer.Exit(EXIT_USAGE)
    try:
        with _progress(quiet) as progress:
            res = run(run_dir, instruction, model=setting.model, base_url=setting.base_url, parts=part or None,
                      max_edits=max_edits, max_calls=max_calls, simulate=not no_simulate,
                      progress=lambda stage, text: progress(f"{stage}: {text}"))
    except (ReviseError, ConfigError) as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_USAGE) from None
    except LLMError as exc:
        _err(f"{exc} (every edit applied before this is in {run_dir}/program.py; rebuild it with "
             f"`procedura-brep build {run_dir}/program.py -o {run_dir}`)")
        raise typer.Exit(EXIT_FAIL) from None
    if json_out:
        _json(res.report)
    if res.status == "ok":
        if not json_out:
            typer.echo(f"revised {run_dir}: {res.report.get('edits', 0)} edit(s), "
                       f"{time.perf_counter() - started:.0f} s, status ok{_sheet(run_dir)}")
        raise typer.Exit(exit_code(res.status))
    why = f": {res.report['reason']}" if res.report.get("reason") else ""
    _err(f"revise ended {res.status}{why} after {res.report.get('edits', 0)} edit(s) (see {run_dir}/history)")
    raise typer.Exit(exit_code(res.status))


@app.command()
@guarded
def serve(
    socket_path: Annotated[Optional[Path], typer.Option("--socket", help="The Unix socket (default: "
                                                        "$PROCEDURA_BREP_SOCKET, else "
                                                        "$XDG_RUNTIME_DIR/procedura-brep/worker.sock).")] = None,
) -> None:
    """Keep a warm process that later commands reuse (Ctrl-C stops it).

    A later build, check, render, export, simulate or edit of this same install runs in a fork
    of it, everything already imported (same output, exit code and Ctrl-C as a local run);
    generate and a command of another process compile through its worker. With no server, or
    one started from other code, commands run as always. PROCEDURA_BREP_SERVER=off keeps a
    command off it."""
    from .errors import CompileError
    from .program.sandbox import Worker
    from .program.server import serve as run
    from .run.steps import warm_imports
    from .served import run_served

    def ready(path: Path) -> None:
        typer.echo(f"warm server listening on {path} (pid {os.getpid()}); Ctrl-C stops it", err=True)
    try:
        from .program.cache import persistent_dir
        worker = Worker(cache_dir=persistent_dir())
        worker.start()  # its boot and this process's imports side by side
        warm_imports(render=True)  # what a served command would import: its forks start warm
        run(worker, socket_path, ready=ready,
            handlers={"run": functools.partial(run_served, command=main)})
    except (OSError, CompileError) as exc:
        _err(f"cannot serve: {exc}")
        raise typer.Exit(EXIT_FAIL) from None


@app.command()
@guarded
def view(
    run_dir: Annotated[Path, typer.Argument(help="A run directory with a viewer (any build writes one).")],
    port: Annotated[int, typer.Option("--port", min=0, max=65535,
                                      help="The port on 127.0.0.1 (default: a free one).")] = 0,
) -> None:
    """Serve RUN_DIR's viewer.html on 127.0.0.1 and print its address (Ctrl-C stops it).

    The page also opens straight from the file system, with no server and no network."""
    from .run.view import ViewServer, serve_until_interrupted

    def ready(server: ViewServer) -> None:
        typer.echo(f"viewer: {server.url}")
        typer.echo(f"(also without a server: {server.file_url}); Ctrl-C stops it", err=True)
    try:
        serve_until_interrupted(run_dir, port=port, ready=ready)
    except OSError as exc:
        _err(f"cannot serve {run_dir} on 127.0.0.1:{port}: {(exc.strerror or str(exc)).lower()}")
        raise typer.Exit(EXIT_USAGE) from None
    typer.echo("viewer stopped", err=True)


@app.command()
@guarded
def mcp(
    http: Annotated[Optional[int], typer.Option("--http", min=1, max=65535, help="Serve streamable "
                                                "HTTP on 127.0.0.1:PORT instead of stdio.")] = None,
) -> None:
    """Serve the tool over MCP (stdio): check, build, render, simulate ... for coding agents.

    One process for the session keeps the compile worker warm.

    A client runs it as the command `procedura-brep mcp` (README, "MCP server")."""
    try:
        from .mcp_server import serve
    except ImportError as exc:  # the mcp SDK is a dependency; a broken install says so
        _err(f"the MCP server needs the mcp package ({exc}); pip install -e .")
        raise typer.Exit(EXIT_FAIL) from None
    serve(http)


@app.command()
@guarded
def doctor(
    model: Annotated[Optional[str], typer.Option("--model", "-m", help="Also check this provider.")] = None,
    base_url: Annotated[Optional[str], typer.Option("--base-url")] = None,
    ping: Annotated[bool, typer.Option("--ping", help="Make a 1-token call to the provider.")] = False,
) -> None:
    """Check the CAD kernel, renderer, MuJoCo, USD, FreeCAD and the provider."""
    from .doctor import run_checks
    from .llm.settings import config_path, resolve_image_model, resolve_model
    setting = resolve_model(model, base_url)
    where = {"none": f"none (no --model, no PROCEDURA_BREP_MODEL, nothing in {config_path()})"}.get(
        setting.source, setting.source)
    typer.echo(f"model in force: {setting.model or '-'} (from {where})")
    image_setting = resolve_image_model()
    where = {"none": "none: runs without --image have no reference image"}.get(
        image_setting.source, f"from {image_setting.source}")
    typer.echo(f"image model: {image_setting.model or '-'} ({where})")
    checks = run_checks(model=setting.model, base_url=setting.base_url, ping=ping)
    from .text import terminal_safe
    for c in checks:
        typer.echo(terminal_safe(c.line()))  # a provider's error text is not ours
    missing = [c for c in checks if not c.ok and not c.optional]
    raise typer.Exit(EXIT_FAIL if missing else EXIT_OK)


def main() -> None:
    """Console-script entry point: Ctrl-C ends the process within a second or two (exit 130),
    with report.json written and the compile worker gone (see :mod:`procedura_brep.interrupt`).

    A command that ran to its exit code leaves without the interpreter's teardown (the
    destructors of OCCT, MuJoCo, USD and trimesh took 1.2 s of every cold ``build``): the
    atexit handlers run (compile worker, temporary folders, logging), the streams are flushed,
    then the process exits with the code. With a non-daemon thread still running, it exits
    normally (waiting for it).
    """
    from . import interrupt
    interrupt.install()
    sys.argv[1:] = hoist_verbose(sys.argv[1:])
    try:
        app()
    except SystemExit as exc:
        _leave(exc.code)
    _leave(0)


def _leave(code: object) -> None:
    """Exit with ``code`` (SystemExit's: None, an int or a message), skipping the teardown."""
    import atexit
    import threading
    if isinstance(code, str):
        sys.stderr.write(code + "\n")
        code = 1
    status = 0 if code is None else code if isinstance(code, int) else 1
    if any(t is not threading.main_thread() and not t.daemon for t in threading.enumerate()):
        raise SystemExit(status)  # a thread the normal exit would wait for
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said
            pass
    os._exit(status)



def _pairs(values: list[str] | None) -> tuple[tuple[str, str], ...] | None:
    """``--pair full,one-shot`` (repeatable) -> pairs; one-line error otherwise."""
    out = []
    for v in values or []:
        a, sep, b = v.partition(",")
        if not sep or not a.strip() or not b.strip() or "," in b:
            _err(f"--pair {v!r}: write two variant names, A,B (e.g. --pair full,one-shot)")
            raise typer.Exit(EXIT_USAGE)
        out.append((a.strip(), b.strip()))
    return tuple(out) or None


@app.command()
@guarded
def bench(
    out: Annotated[Optional[Path], typer.Option("-o", "--out", help="The bench directory.")] = None,
    prompts: Annotated[Optional[Path], typer.Option("--prompts", help="A prompts TOML file (default: "
                                                    "the bundled MechBench-36 (reconstructed)).")] = None,
    model: Annotated[Optional[str], typer.Option("--model", "-m", help="provider:model that generates; "
                                                 "replay:DIR plays DIR/<case>/<variant>.jsonl.")] = None,
    base_url: Annotated[Optional[str], typer.Option("--base-url", help="OpenAI-compatible server URL.")] = None,
    variants: Annotated[str, typer.Option(help="Comma list of full, one-shot, no-refine, no-plan, "
                                               "no-review, no-feedback.")] = "full,one-shot",
    cases: Annotated[Optional[str], typer.Option("--cases", help="Comma list of case ids (default: all).")] = None,
    judge_model: Annotated[Optional[str], typer.Option("--judge-model", help="Vision model that judges "
                                                       "(default: --model; with --from: replay DIR's judge "
                                                       "transcript).")] = None,
    judge_base_url: Annotated[Optional[str], typer.Option("--judge-base-url")] = None,
    jobs: Annotated[int, typer.Option("--jobs", "-j", min=1, max=64, help="Local processes.")] = 1,
    ray: Annotated[bool, typer.Option("--ray", help="Run cases as Ray tasks (ray.init() on this "
                                                    "machine, or --ray-address).")] = False,
    ray_address: Annotated[Optional[str], typer.Option("--ray-address", help="Connect to this Ray cluster "
                                                       "(auto, HOST:6379, ray://HOST:10001); implies --ray.")] = None,
    from_dir: Annotated[Optional[Path], typer.Option("--from", help="Rebuild the tables of this bench "
                                                     "directory without generating.")] = None,
    pair: Annotated[Optional[list[str]], typer.Option("--pair", help="A,B: compare A against B per case "
                                                      "(repeatable; default: each variant against the first).")] = None,
    clip_weights: Annotated[Optional[str], typer.Option("--clip-weights", help="[ARCH@]PATH of local CLIP "
                                                        "weights (default $PROCEDURA_BREP_CLIP_WEIGHTS; "
                                                        "none: CLIP not computed).")] = None,
    salt: Annotated[Optional[str], typer.Option("--salt", help="Salt of the opaque judge ids (default: "
                                                "the directory's, else random).")] = None,
    max_cost: Annotated[Optional[float], typer.Option("--max-cost", help="USD limit per run.")] = None,
    formats: Annotated[Optional[str], typer.Option(help=f"Exports per run: {FORMAT_LIST} (default: all).")] = None,
    no_simulate: Annotated[bool, typer.Option("--no-simulate", help="Skip the MuJoCo battery.")] = False,
    quiet: QuietOption = False,
) -> None:
    """Run a benchmark: generate every case x variant (resumable), judge blind, write tables."""
    from .bench import BenchOptions, rebuild, run_bench
    from .bench.cases import BenchError, parse_variants
    from .llm import ConfigError, LLMError
    from .llm.settings import resolve_model
    say = (lambda line: None) if quiet else (lambda line: typer.echo(line, err=True))
    try:
        if from_dir is not None:
            if out is not None and out.resolve() != from_dir.resolve():
                _err(f"--from {from_dir} rebuilds in place; drop -o {out}")
                raise typer.Exit(EXIT_USAGE)
            res = rebuild(from_dir, judge_model=judge_model, base_url=judge_base_url,
                          clip_weights=clip_weights, pairs=_pairs(pair), say=say)
        else:
            setting = resolve_model(model, base_url)
            if setting.model is None:
                _err("no model: pass --model PROVIDER:MODEL (or replay:DIR), or set PROCEDURA_BREP_MODEL")
                raise typer.Exit(EXIT_USAGE)
            if out is None:
                _err("say where the bench goes: -o DIR (or --from DIR to rebuild its tables)")
                raise typer.Exit(EXIT_USAGE)
            opts = BenchOptions(
                model=setting.model, base_url=setting.base_url, prompts=prompts,
                variants=parse_variants(variants),
                cases=tuple(c.strip() for c in cases.split(",") if c.strip()) if cases else None,
                judge_model=judge_model, judge_base_url=judge_base_url, jobs=jobs,
                ray=ray or ray_address is not None, ray_address=ray_address,
                simulate=not no_simulate, formats=_formats(formats) or None, max_cost_usd=max_cost,
                salt=salt, clip_weights=clip_weights, pairs=_pairs(pair))
            _output_dir(out)
            res = run_bench(out, opts, say=say)
    except (BenchError, ConfigError) as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_USAGE) from None
    except LLMError as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_FAIL) from None
    typer.echo(res.tables["summary.md"].read_text(encoding="utf-8"), nl=False)
    if res.run_errors:
        first = res.run_errors[0]
        _err(f"{len(res.run_errors)} run(s) ended in an error, scored as shipping nothing; run the same "
             f"command again to retry them (first: {first['case']}/{first['variant']}: {first['error']})")
    if res.judge_errors:
        _err(f"{res.judge_errors} judge call(s) gave no usable score (see {res.out}/judge/scores.json)")
    raise typer.Exit(EXIT_FAIL if res.judge_errors or res.run_errors else EXIT_OK)


if __name__ == "__main__":  # last: every command above is registered by now
    main()
