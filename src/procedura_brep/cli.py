"""The ``procedura-brep`` command line: argument parsing and exit codes only.

Exit codes: 0 success; 1 the program built but a gate or check failed (or the build failed on
its own findings); 2 usage errors, unreadable input, or a program that does not compile.
Errors are one line on stderr, never a traceback (``-v`` logs details).
"""

from __future__ import annotations

import functools
from enum import Enum
import logging
from pathlib import Path
from typing import Annotated, Any, Callable, Optional

import typer

app = typer.Typer(
    name="procedura-brep", add_completion=False, no_args_is_help=True,
    pretty_exceptions_show_locals=False,
    help="Text prompt -> editable CAD assembly: build123d parts joined by typed, checked mates.")

EXIT_OK, EXIT_FAIL, EXIT_USAGE = 0, 1, 2


class StepSchema(str, Enum):
    """STEP application protocols the exporter writes."""

    AP214 = "AP214"
    AP242 = "AP242"


FormatsOption = Annotated[Optional[str], typer.Option(
    help="Comma list of step,obj,glb,usd,urdf,mjcf (default: all).")]
StepSchemaOption = Annotated[StepSchema, typer.Option("--step-schema", help="STEP application protocol.")]


def _err(msg: str) -> None:
    typer.echo(f"error: {msg}", err=True)


def guarded(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Turn any library error into a one-line message and an exit code."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        from .errors import CompileError, EditError, ProceduraError, ProgramFormatError
        try:
            return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except (EditError, ProgramFormatError, CompileError) as exc:
            _err(str(exc))
            raise typer.Exit(EXIT_USAGE) from None
        except ProceduraError as exc:
            _err(str(exc))
            raise typer.Exit(EXIT_FAIL) from None
        except (FileNotFoundError, IsADirectoryError, PermissionError, UnicodeDecodeError) as exc:
            _err(f"cannot read input: {exc}")
            raise typer.Exit(EXIT_USAGE) from None
        except KeyboardInterrupt:
            _err("interrupted")
            raise typer.Exit(130) from None
        except Exception as exc:  # noqa: BLE001 - never a traceback for users
            logging.getLogger(__name__).debug("internal error", exc_info=True)
            _err(f"internal error: {type(exc).__name__}: {exc} (run with -v for details)")
            raise typer.Exit(3) from None

    return wrapper


@app.callback()
def main_callback(verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log details.")] = False
                  ) -> None:
    logging.basicConfig(level=logging.DEBUG if verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")


def _read(program: Path) -> str:
    if not program.is_file():
        from .errors import EditError
        raise EditError(f"program {program} does not exist or is not a file")
    return program.read_text(encoding="utf-8")


def _formats(text: str | None) -> tuple[str, ...]:
    """``--formats`` -> validated format names (None: all), as a usage error when unknown."""
    from .errors import EditError
    from .export.bundle import parse_formats
    try:
        return parse_formats(text)
    except ValueError as exc:
        raise EditError(str(exc)) from None


def _do_build(program: Path, out: Path, formats: tuple[str, ...], source: str | None = None,
              gates: bool = True, simulate: bool = False, step_schema: str = "AP214") -> int:
    from .pipeline import build
    res = build(program, out, formats=formats, source=source, gates=gates, simulate=simulate,
                step_schema=step_schema)
    if res.ok:
        n = len(res.model.parts) if res.model else 0
        t = res.report.get("timings", {}).get("total_s", 0.0)
        typer.echo(f"built {n} parts, {len(res.model.mates) if res.model else 0} mates -> {out} "
                   f"({t:.1f} s)")
        return EXIT_OK
    _err(f"build failed: {res.reason}")
    if res.status == "gates_failed":
        return EXIT_FAIL
    return EXIT_USAGE if res.model is None or not res.model.parts else EXIT_FAIL


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
) -> None:
    """Compile PROGRAM in the sandbox, place its parts and write the run directory."""
    source = _read(program)
    raise typer.Exit(_do_build(program, out, _formats(formats), source=source, gates=not no_gates,
                               simulate=simulate, step_schema=step_schema.value))


@app.command()
@guarded
def export(
    program: Annotated[Path, typer.Argument(help="The program to export.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="Directory for the exports.")],
    formats: FormatsOption = None,
    step_schema: StepSchemaOption = StepSchema.AP214,
) -> None:
    """Write the export bundle of PROGRAM (no gates, no report)."""
    from .export.bundle import write_bundle
    model = _compile(program)
    files = write_bundle(model, out, formats=_formats(formats), step_schema=step_schema.value)
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
) -> None:
    """Run the MuJoCo battery B0-B7; exit 1 when any check fails."""
    import json

    from .sim import run_battery
    if not target.exists():
        from .errors import EditError
        raise EditError(f"{target} does not exist; pass a run directory or a program file")
    if target.is_dir() and not (target / "program.py").is_file():
        from .errors import EditError
        raise EditError(f"{target} has no program.py; build it first or pass a program file")
    report = run_battery(target, out_dir=out)
    data = report.as_dict()
    if json_:
        typer.echo(json.dumps(data, indent=2, default=str))
    else:
        _print_battery(data)
    raise typer.Exit(EXIT_OK if report.passed else EXIT_FAIL)


def _print_battery(data: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table
    t = Table(title="MuJoCo battery")
    for col in ("check", "name", "verdict", "measured", "limits", "message"):
        t.add_column(col, overflow="fold")
    for c in data["checks"]:
        verdict = "[yellow]skip[/]" if c.get("skipped") else ("[green]pass[/]" if c["passed"] else "[red]FAIL[/]")
        meas = ", ".join(f"{k}={_short(v)}" for k, v in (c.get("measured") or {}).items())
        lim = ", ".join(f"{k}={_short(v)}" for k, v in (c.get("limits") or {}).items())
        t.add_row(c["id"], c.get("name", ""), verdict, meas, lim, c.get("message", ""))
    con = Console()
    con.print(t)
    for n in data.get("notes", []):
        con.print(f"note: {n}")
    con.print("[green]all checks pass[/]" if data["passed"] else "[red]a check failed[/]")


def _short(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    text = str(v)
    return text if len(text) < 60 else text[:57] + "..."


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
) -> None:
    """Change named params (only their lines; comments and formatting kept).

    The edited program is compiled and gated first; an edit that breaks a mate or a gate is
    reported and not written (unless --force).
    """
    from .pipeline import build as run_build
    from .paths import program_name, write_atomic
    from .pipeline import compile_file
    from .program.edit import parse_assignment, set_params
    source = _read(program)
    values = dict(parse_assignment(s) for s in set_)
    new = set_params(source, values)
    target = output or program
    problem = None
    if build_dir is not None:
        res = run_build(target, build_dir, source=new, name=program_name(program))
        problem = None if res.ok else res.reason
    elif not no_check:
        from .gates import check_model
        model = compile_file(new, program_name(program))
        errs = [f for f in model.findings if f.severity == "error"]
        if not errs:
            errs = [f for f in check_model(model, new).findings if f.severity == "error"]
        problem = errs[0].message if errs else None
    edits = ", ".join(f"{k}={v}" for k, v in values.items())
    if problem and not force:
        _err(f"edit {edits} rejected, {target} unchanged: {problem} (--force writes it anyway)")
        raise typer.Exit(EXIT_FAIL)
    write_atomic(target, new)
    typer.echo(f"set {edits} -> {target}" + (f" (with a problem: {problem})" if problem else ""))
    raise typer.Exit(EXIT_FAIL if problem else EXIT_OK)


def _compile(program: Path, source: str | None = None):
    """Compile PROGRAM in the sandbox; a program that fails is a usage error (exit 2)."""
    from .errors import CompileError
    from .paths import program_name
    from .pipeline import compile_file
    model = compile_file(_read(program) if source is None else source, program_name(program))
    if not model.ok:
        errs = [f for f in model.findings if f.severity == "error"]
        raise CompileError(f"{program} does not compile: {errs[0].message}"
                           + (f" (+{len(errs) - 1} more)" if len(errs) > 1 else ""), errs)
    return model


@app.command()
@guarded
def check(
    program: Annotated[Path, typer.Argument(help="The program to check.")],
    json_: Annotated[bool, typer.Option("--json", help="Print the report as JSON.")] = False,
) -> None:
    """Run every gate (compile, mate, connectivity) and the mesh metrics on PROGRAM.

    Exit 0 when every gate passes, 1 when a gate fails, 2 on usage or compile errors.
    """
    import json

    from .gates import check_model
    source = _read(program)
    model = _compile(program, source)
    report = check_model(model, source)
    data = report.as_dict()
    if json_:
        typer.echo(json.dumps(data, indent=2))
    else:
        _print_check(data)
    raise typer.Exit(EXIT_OK if report.passed else EXIT_FAIL)


def _print_check(data: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table
    con = Console()
    tp = Table(title=f"parts: {data['model']}")
    for col in ("part", "triangles", "errors", "verdict"):
        tp.add_column(col)
    for name, tris in data["triangles_per_part"].items():
        errs = [f for f in data["findings"] if f.get("part") == name and f.get("severity") == "error"]
        tp.add_row(name, str(tris), "; ".join(f.get("code", "") for f in errs),
                   "[red]FAIL[/]" if errs else "[green]pass[/]")
    con.print(tp)
    t = Table(title=f"mate gate: {data['model']}")
    for col in ("mate", "area mm^2", "limit", "penetration mm", "limit", "verdict"):
        t.add_column(col)
    for name, m in data["mates"].items():
        ok = m.get("passed")
        t.add_row(name, f"{m.get('area_mm2', float('nan')):.3g}", f"{m.get('area_limit_mm2', float('nan')):.3g}",
                  f"{m.get('penetration_mm', float('nan')):.3g}",
                  f"{m.get('penetration_limit_mm', float('nan')):.3g}",
                  "[green]pass[/]" if ok else "[red]FAIL[/]")
    con.print(t)
    conn, met = data["connectivity"], data["metrics"]
    t2 = Table(title="connectivity and metrics")
    t2.add_column("measure")
    t2.add_column("value")
    for k, v in (("N_vis (tau = %g)" % conn.get("tau", 0.01), conn.get("n_vis")),
                 ("components", conn.get("components")), ("span mm", conn.get("span_mm")),
                 ("triangles", met.get("triangles")), ("Shrp60 mm", met.get("shrp60_mm")),
                 ("Shrp60 / span", met.get("shrp60_per_span")), ("Dih95 deg", met.get("dih95_deg"))):
        t2.add_row(k, str(v))
    con.print(t2)
    for f in data["findings"]:
        colour = "red" if f.get("severity") == "error" else "yellow"
        con.print(f"[{colour}]{f.get('severity')}[/] {f.get('code')}: {f.get('message')}")
    con.print("[green]all gates pass[/]" if data["passed"] else "[red]a gate failed[/]")


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
) -> None:
    """Render views of PROGRAM (parts-colour, grey clay or PBR), with cache and staleness."""
    from .errors import EditError
    from .render import render_to_dir
    model = _compile(program)
    try:
        res = render_to_dir(model, out, views=views, mode=mode, size=size, sheet=sheet,  # type: ignore[arg-type]
                            close_up=close_up, frames_overlay=frames)
    except ValueError as exc:
        raise EditError(str(exc)) from None
    typer.echo(f"{len(res.rendered)} rendered, {len(res.cached)} from cache "
               f"({res.seconds:.2f} s) -> {out}")
    if res.stale_before:
        typer.echo(f"replaced stale views: {', '.join(res.stale_before)}")
    for key, path in sorted(res.paths.items()):
        typer.echo(f"  {key}: {path}")


@app.command()
@guarded
def generate(
    prompt: Annotated[str, typer.Argument(help="What to model, in words.")],
    out: Annotated[Path, typer.Option("-o", "--out", help="The run directory.")],
    model: Annotated[str, typer.Option("--model", "-m", help="provider:model, e.g. openai:gpt-4o, "
                                                             "anthropic:..., replay:TAPE, exchange:DIR")],
    base_url: Annotated[Optional[str], typer.Option("--base-url", help="OpenAI-compatible server URL.")] = None,
    image: Annotated[Optional[Path], typer.Option("--image", help="A reference PNG.")] = None,
    max_cost: Annotated[Optional[float], typer.Option("--max-cost", help="Stop before spending more "
                                                                         "than this many USD.")] = None,
    attempts: Annotated[int, typer.Option(min=1, max=10, help="Model calls allowed.")] = 3,
    timeout: Annotated[Optional[float], typer.Option(help="Seconds to wait for one reply.")] = None,
    formats: Annotated[Optional[str], typer.Option(help="Exports (default: all).")] = None,
) -> None:
    """Generate a program from PROMPT with a model (one-shot mode), then build it."""
    from .agent.oneshot import generate as run
    from .llm import ConfigError, LLMError
    png = image.read_bytes() if image else None
    try:
        res = run(prompt, out, model=model, base_url=base_url, max_cost_usd=max_cost,
                  attempts=attempts, image=png, timeout_s=timeout, formats=_formats(formats))
    except ConfigError as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_USAGE) from None
    except LLMError as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_FAIL) from None
    cost = (res.usage.get("total") or {}).get("cost_usd")
    tail = f", cost ${cost:.4f}" if isinstance(cost, (int, float)) else ""
    if res.status == "ok":
        typer.echo(f"generated and built in {res.attempts} call(s) -> {out}{tail}")
        raise typer.Exit(EXIT_OK)
    _err(f"generate {res.status} after {res.attempts} call(s): {res.message} (work kept in {out})")
    raise typer.Exit(EXIT_FAIL)


@app.command()
@guarded
def doctor(
    model: Annotated[Optional[str], typer.Option("--model", "-m", help="Also check this provider.")] = None,
    base_url: Annotated[Optional[str], typer.Option("--base-url")] = None,
    ping: Annotated[bool, typer.Option("--ping", help="Make a 1-token call to the provider.")] = False,
) -> None:
    """Check the CAD kernel, renderer, MuJoCo, USD, FreeCAD and the provider."""
    from .doctor import run_checks
    checks = run_checks(model=model, base_url=base_url, ping=ping)
    for c in checks:
        typer.echo(c.line())
    missing = [c for c in checks if not c.ok and not c.optional]
    raise typer.Exit(EXIT_FAIL if missing else EXIT_OK)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
