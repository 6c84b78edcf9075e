"""``procedura-brep mcp``: the tool as an MCP server (the official ``mcp`` SDK, stdio).

One process for the server's lifetime, so its compile worker stays warm: the first call pays
for starting it, every later one reuses it and its part cache (a second ``check`` of a program
recompiles nothing). Programs are untrusted and run in the same sandbox as everywhere (forked,
limited children of the worker's zygote); the gates, renders and exports of what comes back run
in a limited child of this process, as the CLI's do. A call that fails (a program that does not
compile, runs out of time or memory, a bad argument) returns an error result and leaves the
server alive with its warm state.

Every tool returns structured content (findings with their codes, measured values, paths) and
a one-line text. Tools: ``new_program``, ``check``, ``build``, ``edit_params``, ``splice_part``,
``render`` (images), ``simulate``, ``export``, ``mate_vocabulary``. Resources:
``procedura-brep://reference`` (the program API and the mate vocabulary, as the model's build
requests state them) and ``procedura-brep://runs/{run}/<file>``: the report, mates, summary and
sheet of a run directory this server built (``build`` lists the URIs; no other path is served).
A ``check`` of a program whose compiled geometry and text this server has
gated already is answered from its memory (:func:`_gates`).
"""

from __future__ import annotations

import base64
import io
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcp_types import CallToolResult  # the tools' annotated return type, read by the SDK

from .errors import ProceduraError

log = logging.getLogger(__name__)

#: The views ``render`` draws when none are asked for.
DEFAULT_VIEWS: tuple[str, ...] = ("iso_se", "front", "top")


def _result(text: str, data: dict[str, Any], *, images: list[Any] = (), error: bool = False) -> Any:
    from mcp_types import ImageContent, TextContent
    content: list[Any] = [TextContent(type="text", text=text)]
    for name, png in images:
        content.append(ImageContent(type="image", data=base64.b64encode(png).decode("ascii"),
                                    mime_type="image/png", meta={"view": name}))
    return CallToolResult(content=content, structured_content=data, is_error=error)


def _guard(fn: Callable[..., Any]) -> Callable[..., Any]:
    """A tool body whose user-facing failures become error results (the server lives on)."""
    import functools

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        from .run.commands import StageError
        try:
            return fn(*args, **kwargs)
        except (ProceduraError, StageError, ValueError) as exc:
            findings = [f.as_dict() for f in getattr(exc, "findings", [])]
            return _result(f"error: {exc}", {"ok": False, "error": str(exc), "findings": findings},
                           error=True)
    return call


def _compile(program: str, name: str, time_limit_s: float | None = None) -> Any:
    """The program compiled in the warm sandbox worker; ``time_limit_s`` lowers the sandbox's
    CPU and wall limits for this call (never raises them)."""
    from .run import compile_model
    if time_limit_s is None:
        return compile_model(program, name=name)
    import dataclasses
    import math

    from .config import SANDBOX
    from .program.sandbox import compile_source
    cpu = max(1, min(SANDBOX.cpu_s, math.ceil(time_limit_s)))
    limits = dataclasses.replace(SANDBOX, cpu_s=cpu, wall_s=min(SANDBOX.wall_s, cpu * 1.5))
    return compile_source(program, name=name, limits=limits)


#: Gate reports of the programs this server has checked, by the compiled geometry (every part's
#: digest, every mate's frame) and the source: a check of an unchanged program is answered from
#: here; any change runs the gates again in a limited child.
_GATED: dict[str, dict[str, Any]] = {}
_GATED_MAX = 64


def _gates(model: Any, source: str) -> dict[str, Any]:
    """``run.commands.check`` (every gate, in a limited child), remembered per geometry."""
    import hashlib
    import json

    from .run import commands
    h = hashlib.sha256(source.encode("utf-8"))
    for p in model.parts:
        h.update(f"{p.name}\0{p.digest}\n".encode())
    for m in model.mates:
        h.update(json.dumps([m.name, [[round(float(x), 9) for x in row] for row in m.world_frame]]).encode())
    key = h.hexdigest()
    if key not in _GATED:
        if len(_GATED) >= _GATED_MAX:
            _GATED.pop(next(iter(_GATED)))
        _GATED[key] = commands.check(model, source)
    return _GATED[key]


def _blocking(data: dict[str, Any]) -> list[Any]:
    """The findings of a check report that fail it (the one policy, ``findings.blocking``)."""
    from .findings import blocking
    from .program.trust import finding_from_json
    return blocking([finding_from_json(f, f"findings[{i}]") for i, f in enumerate(data.get("findings", []))])


def _findings(data: dict[str, Any]) -> list[dict[str, Any]]:
    return [{k: v for k, v in f.items() if v is not None} for f in data.get("findings", [])]


#: The run directories this server built, by the id its resources name them with
#: (``procedura-brep://runs/{run}/{file}``); only these are served, never another path.
_RUNS: dict[str, Path] = {}
#: The files of a run directory served as resources, with their MIME types.
RUN_FILES: dict[str, str] = {"report.json": "application/json", "mates.json": "application/json",
                             "summary.md": "text/markdown", "sheet.png": "image/png"}


def _run_id(out: Path) -> str:
    """The resource id of a run directory: its name (``[a-z0-9_-]``), made unique."""
    import re
    for known, path in _RUNS.items():
        if path == out.resolve():
            return known
    base = re.sub(r"[^a-z0-9_-]+", "_", out.name.lower()).strip("_") or "run"
    rid, n = base, 1
    while rid in _RUNS:
        n += 1
        rid = f"{base}_{n}"
    _RUNS[rid] = out.resolve()
    return rid


def _run_resources(out: Path) -> dict[str, str]:
    """``{file: resource URI}`` of the run directory's served files that exist."""
    rid = _run_id(out)
    return {f: f"procedura-brep://runs/{rid}/{f}" for f in RUN_FILES if (out / f).is_file()}


def _run_file(file: str) -> Callable[[str], str | bytes]:
    """The reader of one served file of the run directories this server built."""
    from mcp.server.mcpserver.exceptions import ResourceNotFoundError

    def read(run: str) -> str | bytes:
        if run not in _RUNS:
            known = ", ".join(sorted(_RUNS)) or "none yet: build one"
            raise ResourceNotFoundError(f"unknown run {run!r}; this server built: {known}")
        path = _RUNS[run] / file
        if not path.is_file():
            raise ResourceNotFoundError(f"{run} has no {file} (its build did not write it)")
        return path.read_bytes() if file.endswith(".png") else path.read_text(encoding="utf-8")
    return read


def build_server() -> Any:
    """The MCP server with every tool and resource registered (``run("stdio")`` serves it)."""
    from mcp.server.mcpserver import MCPServer

    server = MCPServer("procedura-brep", instructions=(
        "Write a CAD assembly as a procedura-brep program (build123d parts, frames, typed mates): "
        "new_program gives the template, the reference resource the API; check gates it, "
        "render shows it, build writes STEP/GLB/USD/URDF/MJCF, simulate runs the MuJoCo battery."))

    @server.tool(description="A new program: the five sections and the API import, with the "
                             "description as its docstring. Returns its text.")
    @_guard
    def new_program(description: str) -> CallToolResult:
        from .program.splice import empty_program
        src = empty_program(description)
        return _result("a new program (five empty sections)", {"ok": True, "program": src})

    @server.tool(description="Compile a program in the sandbox and run every gate (mates, "
                             "interference, connectivity, origin). Returns passed, the findings "
                             "with their codes and each mate's measured bearing and penetration. "
                             "time_limit_s lowers the compile's CPU limit (default 60 s).")
    @_guard
    def check(program: str, name: str = "model", time_limit_s: float | None = None) -> CallToolResult:
        model = _compile(program, name, time_limit_s)
        data = _gates(model, program)
        errors = _blocking(data)
        text = ("all gates pass" if data["passed"] else
                f"{len(errors)} error(s); first: {errors[0].message if errors else '?'}")
        return _result(text, {"ok": True, "passed": data["passed"], "findings": _findings(data),
                              "mates": data.get("mates", {}), "parts": list(data.get("triangles_per_part", {}))})

    @server.tool(description="Set params of a program (name -> number); the edit is compiled and "
                             "gated. Returns the new program text and the gates' verdict.")
    @_guard
    def edit_params(program: str, params: dict[str, float], name: str = "model") -> CallToolResult:
        from .program.edit import set_params
        new = set_params(program, params)
        data = _gates(_compile(new, name), new)
        return _result(f"set {', '.join(params)}; gates {'pass' if data['passed'] else 'fail'}",
                       {"ok": True, "program": new, "passed": data["passed"], "findings": _findings(data)})

    @server.tool(description="Splice one part reply (five blocks: ## params, ## helpers, ## body, "
                             "## frames, ## mates) into a program and gate that part. Returns the "
                             "new program, the part's name and its findings; refused when it fails.")
    @_guard
    def splice_part(program: str, reply: str, name: str = "model") -> CallToolResult:
        from .agent.tools import Tools
        from .program.splice import SpliceError, splice
        try:
            res = splice(program, reply)
        except SpliceError as exc:
            return _result(f"refused: {exc}", {"ok": False, "error": str(exc), "findings": []}, error=True)
        verdict = Tools().gate_part(res.source, res.part, baseline=0, name=name)
        found = [f.as_dict() for f in verdict.errors]
        text = f"part {res.part}: " + ("passes its gates" if verdict.ok else f"{len(found)} finding(s)")
        return _result(text, {"ok": verdict.ok, "part": res.part, "program": res.source if verdict.ok else program,
                              "findings": found, "renamed_helpers": dict(res.renames)}, error=not verdict.ok)

    @server.tool(description="Render views of a program (one flat colour per part, the legend in "
                             "the result), or a close-up of a part, a mate or a pair 'a+b' (the "
                             "rest ghosted). Views: iso_se, iso_nw, front (from -Y), top, ...")
    @_guard
    def render(program: str, views: list[str] | None = None, close_up: str | None = None,
               size: int = 384, name: str = "model") -> CallToolResult:
        from .render import render_images
        from .render.api import legend_of
        model = _compile(program, name)
        imgs = render_images(model, list(views or DEFAULT_VIEWS), mode="parts", size=size, focus=close_up)
        pngs = []
        for view, img in imgs.items():
            buf = io.BytesIO()
            img.save(buf, format="PNG")
            pngs.append((view, buf.getvalue()))
        legend = {n: "#{:02x}{:02x}{:02x}".format(*c) for n, c in legend_of(model)}
        return _result(f"{len(pngs)} view(s): {', '.join(v for v, _ in pngs)}",
                       {"ok": True, "views": [v for v, _ in pngs], "legend": legend}, images=pngs)

    @server.tool(description="Build a run directory: compile, gates, every export (STEP, OBJ, "
                             "GLB, USD, URDF, MJCF) and, with simulate, the MuJoCo battery.")
    @_guard
    def build(program: str, out_dir: str, simulate: bool = False, name: str = "model") -> CallToolResult:
        from .run.build import build as run_build
        out = Path(out_dir)
        res = run_build(out / "program.py", out, source=program, simulate=simulate, name=name)
        files = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.is_file())
        return _result(f"{res.status}: {out}", {"ok": res.ok, "status": res.status, "out_dir": str(out),
                                                 "reason": res.reason if not res.ok else "",
                                                 "findings": [f.as_dict() for f in res.errors],
                                                 "files": files, "resources": _run_resources(out)},
                       error=not res.ok)

    @server.tool(description="Export a program's bundle (formats: step, obj, glb, usd, urdf, mjcf) "
                             "into a directory, without gating it.")
    @_guard
    def export(program: str, out_dir: str, formats: list[str] | None = None,
               name: str = "model") -> CallToolResult:
        from .export.bundle import parse_formats
        from .run import commands
        fmts = parse_formats(",".join(formats) if formats else None)
        files = commands.export(_compile(program, name), Path(out_dir), formats=fmts, step_schema="AP214")
        return _result(f"wrote {len(files)} file(s) to {out_dir}", {"ok": True, "files": sorted(files)})

    @server.tool(description="Run the MuJoCo battery B0-B8 on a program (model fidelity, settle, "
                             "joint sweeps, rest contact, wheels, URDF and USD round trips, smoke, transmission).")
    @_guard
    def simulate(program: str, out_dir: str | None = None, name: str = "model") -> CallToolResult:
        import tempfile

        from .run import commands
        model = _compile(program, name)
        with tempfile.TemporaryDirectory() as tmp:
            target = Path(tmp) / "program.py"
            target.write_text(program, encoding="utf-8")
            data = commands.simulate(model, target, out=Path(out_dir) if out_dir else None)
        failed = [c["id"] for c in data["checks"] if c["status"] == "fail"]
        text = "all checks pass" if data["passed"] else f"failed: {', '.join(failed)}"
        checks = [{k: c.get(k) for k in ("id", "name", "status", "message", "measured", "limits")}
                  for c in data["checks"]]
        return _result(text, {"ok": True, "passed": data["passed"], "checks": checks})

    @server.tool(description="The mate vocabulary: every type, its kind, degrees of freedom, fits "
                             "and options (default, range, meaning).")
    @_guard
    def mate_vocabulary() -> CallToolResult:
        from .agent.prompts import option_line
        from .mates import TYPES
        rows = [{"type": t.name, "kind": t.kind, "dof": t.dof.count, "doc": t.doc,
                 "fits": [t.default_fit] + [f for f in t.fits if f != t.default_fit],
                 "options": [option_line(k, o) for k, o in t.options.items()]} for t in TYPES.values()]
        return _result(f"{len(rows)} mate types", {"ok": True, "types": rows})

    @server.resource("procedura-brep://reference", mime_type="text/markdown",
                     description="The program API and the mate vocabulary, as the build requests state them")
    def reference() -> str:
        from .agent.prompts import part_format, reference
        return part_format() + "\n\n" + reference()

    for file, mime in RUN_FILES.items():
        server.resource(f"procedura-brep://runs/{{run}}/{file}", name=f"run {file}", mime_type=mime,
                        description=f"{file} of a run directory this server built (the build "
                                    f"tool's result lists the URIs)")(_run_file(file))

    return server


def serve(http_port: int | None = None) -> None:
    """Serve over stdio until the client closes the stream, or with ``http_port`` over streamable
    HTTP on 127.0.0.1 (loopback only: the tools read and write local files)."""
    server = build_server()
    if http_port is None:
        server.run("stdio")
    else:
        server.run("streamable-http", host="127.0.0.1", port=http_port)
