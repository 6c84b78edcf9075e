"""The materials stage of the staged agent (docs/agent.md, "The materials stage").

After refine, three model calls, each gated, each recorded in ``report.json`` (``materials``)
and, when it changes the program, in ``history/``:

1. ``materials``: a PBR library from the reference and the prompt, and one material per part
   (:func:`~procedura_brep.agent.paint.parse_assignment`; a malformed reply is retried with the
   parse error). It is spliced into the program deterministically
   (:func:`~procedura_brep.agent.paint.apply_materials`) and gated: the program compiles with no
   error and every part's geometry digest is unchanged (paint never changes shape).
2. ``material_critic``: sees a PBR render (albedo, metalness, roughness) with the legend (part,
   material, values) and corrects the assignment; applied and gated the same way.
3. ``subparts``: may split parts into colour blocks (``PAINT part``: ``@paint`` functions
   spliced after the part, :mod:`procedura_brep.agent.subparts`) or rewrite them (``REWRITE
   part``). A paint is refused when the program no longer compiles cleanly (a region that
   misses the part or reaches into a mate feature is a compile finding), when the part's gates
   fail, when another part's geometry changes, or when the part and its blocks do not add up
   to the part's volume before (``config.MATERIAL.paint_volume_rtol``); a rewrite is refused
   when the part's triangle count moves beyond ``config.MATERIAL.subparts_triangle_tol`` of
   the original's, or when it fails the part gates.

A stage that cannot use a reply keeps the program as it was and says why in the report.
"""

from __future__ import annotations

import io
from typing import Any

from ..config import MATERIAL
from ..errors import ProceduraError
from ..findings import blocking
from ..llm import Image, Message
from ..materials import CLASSES, MATERIALS
from ..paths import write_atomic
from ..program.model import CompiledModel
from ..program.splice import SpliceError, replace_part
from .paint import (
    Assignment,
    Entry,
    PaintError,
    apply_materials,
    declared_entries,
    merge,
    parse_assignment,
)
from .prompts import template
from .refine import findings_text
from .runstate import history_path
from .stages import StageHost
from .subparts import SubpartEdit, parse_subparts, splice_paint

#: Views the materials calls see (parts colours for the library, PBR for the critic).
MATERIAL_VIEWS: tuple[str, ...] = ("iso_se", "iso_nw")
STAGE = "materials"


def materials_stage(run: StageHost) -> str:
    """Run the stage on ``run.state.source`` (when ``run.options.materials``), record its report
    in ``run.state.materials`` and return the program (changed or not)."""
    st = run.state
    if run.options.materials and st.source:
        source, st.materials = run_materials(run, st.source)
        return source
    return st.source


def builtins_text() -> str:
    return "\n".join(f"- {m.name}: {m.material_class}, rgb {_rgb(m.rgb)}, metalness {m.metalness:g}, "
                     f"roughness {m.roughness:g}, density {m.density:g}" for m in MATERIALS.values())


def _rgb(rgb: tuple[float, float, float]) -> str:
    return "[" + ", ".join(f"{c:.3g}" for c in rgb) + "]"


def legend(model: CompiledModel) -> str:
    """One line per part: its material and that material's values (what the PBR render shows)."""
    rows = []
    for p in model.parts:
        m = model.material_of(p)
        rows.append(f"- {p.name}: {m.name} ({m.material_class}, rgb {_rgb(m.rgb)}, metalness "
                    f"{m.metalness:g}, roughness {m.roughness:g}, wear {m.wear:g})")
    return "\n".join(rows)


def _png(img: Any, name: str) -> Image:
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return Image(buf.getvalue(), name)


def pbr_views(model: CompiledModel, size: int) -> list[Image]:
    """The PBR render the material critic sees."""
    from ..render.api import render_images
    imgs = render_images(model, list(MATERIAL_VIEWS), mode="pbr", size=size)
    return [_png(img, f"pbr_{v}") for v, img in imgs.items()]


def triangles(model: CompiledModel, part: str) -> int:
    """A part's triangle count at the fixed meshing tolerance."""
    return len(model.part(part).mesh().faces)


class MaterialsBench:
    """The stage's deterministic work over one host run: compile, splice, gate, history."""

    def __init__(self, host: StageHost, source: str) -> None:
        self.host = host
        self.source = source
        self.model = host.tools.compile_model(source, host.name)
        self.entries: tuple[Entry, ...] = declared_entries(source, self.model.materials)
        self.steps: list[dict[str, Any]] = []

    @property
    def parts(self) -> list[str]:
        return [p.name for p in self.model.parts]

    def ask(self, role: str, system: str, messages: list[Message], parse: Any) -> tuple[Any, int, list[str]]:
        """Call ``role`` until ``parse`` accepts the reply (at most ``reply_attempts`` times);
        returns (parsed or None, attempts, the parse errors)."""
        errors: list[str] = []
        for attempt in range(1, MATERIAL.reply_attempts + 1):
            text = self.host.call(role, system, messages, max_tokens=8000)
            try:
                return parse(text), attempt, errors
            except (PaintError, SpliceError) as exc:
                errors.append(str(exc))
                self.host.progress(STAGE, f"{role}: unusable reply ({exc})")
                messages = [*messages, Message.assistant(text),
                            Message.user(f"The reply could not be used: {exc}\nReply again, in the format asked.")]
        return None, MATERIAL.reply_attempts, errors

    def apply(self, entries: tuple[Entry, ...], assign: dict[str, str]) -> tuple[bool, str]:
        """Splice ``entries`` and ``assign`` and gate the result: it compiles with no error, every
        part keeps its geometry digest, every assigned part carries its material."""
        try:
            new = apply_materials(self.source, entries, assign)
            model = self.host.tools.compile_model(new, self.host.name)
        except (PaintError, ProceduraError) as exc:
            return False, str(exc)
        errors = blocking(model.findings)
        if errors:
            return False, findings_text(errors, 6).replace("\n", " ")
        before = {p.name: p.digest for p in self.model.parts}
        after = {p.name: p.digest for p in model.parts}
        changed = sorted(n for n in before if after.get(n) != before[n]) + sorted(set(after) - set(before))
        if changed:
            return False, f"the splice changed the shape of {', '.join(changed)} (paint never changes shape)"
        wrong = [n for n, m in assign.items() if model.part(n).material != m]
        if wrong:
            return False, f"the splice did not set the material of {', '.join(wrong)} (internal error)"
        self.source, self.model, self.entries = new, model, entries
        return True, ""

    def history(self, label: str) -> None:
        write_atomic(history_path(self.host.out_dir, f"{STAGE}-{label}"), self.source)

    def assignment(self) -> dict[str, str]:
        return {p.name: p.material for p in self.model.parts}


def run_materials(host: StageHost, source: str) -> tuple[str, dict[str, Any]]:
    """The three calls over ``source``; returns the program and the stage's report."""
    try:
        bench = MaterialsBench(host, source)
    except ProceduraError as exc:
        return source, {"ok": False, "reason": f"the program does not compile: {exc}", "steps": []}
    size = getattr(host.tools, "render_size", 384)
    _library_step(bench, size)
    _critic_step(bench, size)
    _subparts_step(bench, size)
    report = {"ok": all(s["ok"] for s in bench.steps), "steps": bench.steps,
              "library": [bench.model.materials[e.name].as_dict() | {"declared": e.values}
                          for e in bench.entries if e.name in bench.model.materials],
              "assign": bench.assignment()}
    return bench.source, report


def _parts_text(model: CompiledModel) -> str:
    return "\n".join(f"- {p.name}: {p.description or '(no description)'}; now {p.material}"
                     for p in model.parts)


def _library_step(bench: MaterialsBench, size: int) -> None:
    host, lo_hi = bench.host, MATERIAL.density_range
    system = (template("materials_system").replace("{builtins}", builtins_text())
              .replace("{density_lo}", f"{lo_hi[0]:g}").replace("{density_hi}", f"{lo_hi[1]:g}")
              .replace("{classes}", ", ".join(CLASSES)))
    views, colours = host.tools.render(bench.model, list(MATERIAL_VIEWS))
    msgs = [Message.user(f"Object: {host.prompt}\n\nParts (name: description; current material):\n"
                         f"{_parts_text(bench.model)}\n\nColour legend of the views: {colours}",
                         *host.refs(), *views)]
    parsed, attempts, errors = bench.ask("materials", system, msgs,
                                         lambda t: parse_assignment(t, parts=bench.parts, complete=True))
    step: dict[str, Any] = {"step": "library", "attempts": attempts, "parse_errors": errors}
    if parsed is None:
        bench.steps.append({**step, "ok": False, "reason": "no usable reply; materials kept"})
        return
    ok, why = bench.apply(parsed.library, parsed.assign)
    step.update({"ok": ok, "summary": parsed.summary, "entries": [e.name for e in parsed.library],
                 "assign": parsed.assign})
    if not ok:
        step["reason"] = f"refused: {why}"
    else:
        bench.history("library")
    bench.steps.append(step)
    host.progress(STAGE, f"library: {len(parsed.library)} entries, {len(parsed.assign)} parts"
                  + ("" if ok else f" (refused: {why})"))


def _critic_step(bench: MaterialsBench, size: int) -> None:
    host = bench.host
    try:
        views = pbr_views(bench.model, size)
    except (ProceduraError, ValueError) as exc:
        bench.steps.append({"step": "critic", "ok": False, "reason": f"no PBR render: {exc}"})
        return
    msgs = [Message.user(f"Object: {host.prompt}\n\nLegend (part: material and its values):\n"
                         f"{legend(bench.model)}\n\nThe PBR views of the build follow.",
                         *host.refs(), *views)]
    current = bench.entries
    parsed: Assignment | None
    parsed, attempts, errors = bench.ask(
        "material_critic", template("material_critic_system"), msgs,
        lambda t: parse_assignment(t, parts=bench.parts, current=current, complete=False))
    step: dict[str, Any] = {"step": "critic", "attempts": attempts, "parse_errors": errors}
    if parsed is None:
        bench.steps.append({**step, "ok": False, "reason": "no usable reply; assignment kept"})
        return
    changes = {p: m for p, m in parsed.assign.items() if bench.model.part(p).material != m}
    step.update({"summary": parsed.summary, "changes": changes,
                 "entries": [e.name for e in parsed.library]})
    if not changes and not parsed.library:
        bench.steps.append({**step, "ok": True})
        host.progress(STAGE, "critic: no change")
        return
    ok, why = bench.apply(merge(current, parsed.library), {**bench.assignment(), **changes})
    step["ok"] = ok
    if ok:
        bench.history("critic")
    else:
        step["reason"] = f"refused: {why}"
    bench.steps.append(step)
    revised = [e.name for e in parsed.library if e not in current]
    step["library_changes"] = revised
    host.progress(STAGE, f"critic: {len(changes)} part(s) reassigned, {len(revised)} material(s) "
                  f"revised" + ("" if ok else f" (refused: {why})"))


def _subparts_step(bench: MaterialsBench, size: int) -> None:
    host = bench.host
    tol = MATERIAL.subparts_triangle_tol
    system = template("subparts_system").replace("{tolerance_pct}", f"{100 * tol:g}")
    try:
        views = pbr_views(bench.model, size)
    except (ProceduraError, ValueError):
        views = []
    library = set(bench.model.materials)
    msgs = [Message.user(f"Object: {host.prompt}\n\nLegend (part: material and its values):\n"
                         f"{legend(bench.model)}\n\nThe run's library (the materials a PAINT may "
                         f"use):\n{library_text(bench.model)}\n\nThe program:\n```python\n"
                         f"{bench.source}```", *host.refs(), *views)]
    parsed, attempts, errors = bench.ask(
        "subparts", system, msgs, lambda t: parse_subparts(t, parts=bench.parts, library=library))
    step: dict[str, Any] = {"step": "subparts", "attempts": attempts, "parse_errors": errors,
                            "tolerance": tol, "rewrites": []}
    if parsed is None:
        bench.steps.append({**step, "ok": False, "reason": "no usable reply; parts kept"})
        return
    for edit in parsed:
        row = _paint(bench, edit) if edit.kind == "paint" else _rewrite(bench, edit.part, edit.text, tol)
        step["rewrites"].append(row)
        host.progress(STAGE, f"subparts {edit.kind} {edit.part}: "
                      + ("accepted" if row["accepted"] else row["reason"]))
    step["ok"] = True  # a refused rewrite is a verdict of the gate, not a failure of the stage
    bench.steps.append(step)


def _rewrite(bench: MaterialsBench, part: str, text: str, tol: float) -> dict[str, Any]:
    """Gate one sub-part rewrite: splice, compile, triangle count, the part gates."""
    row: dict[str, Any] = {"part": part, "kind": "rewrite", "accepted": False}
    try:
        result = replace_part(bench.source, text)
    except SpliceError as exc:
        return {**row, "reason": f"refused: {exc}"}
    if result.part != part:
        return {**row, "reason": f"refused: the reply defines part {result.part!r}, not {part!r}"}
    before = triangles(bench.model, part)
    verdict = bench.host.tools.gate_part(result.source, part, baseline=_n_vis(bench), name=bench.host.name)
    if not verdict.compiled or verdict.model is None or part not in {p.name for p in verdict.model.parts}:
        return {**row, "triangles_before": before,
                "reason": "refused: " + findings_text(verdict.errors, 4).replace("\n", " ")}
    after = triangles(verdict.model, part)
    row.update({"triangles_before": before, "triangles_after": after})
    change = abs(after - before) / max(before, 1)
    if change > tol:
        return {**row, "reason": f"refused: the triangle count changed from {before} to {after} "
                                 f"({100 * change:.1f}% > {100 * tol:g}%): paint never changes shape"}
    if not verdict.ok:
        return {**row, "reason": "refused: " + findings_text(verdict.errors, 4).replace("\n", " ")}
    bench.source, bench.model = result.source, verdict.model
    bench.entries = declared_entries(result.source, verdict.model.materials)
    bench.history(f"subparts-{part}")
    return {**row, "accepted": True}


def library_text(model: CompiledModel) -> str:
    """The run's library, one line per material (the program's own first, then built-ins)."""
    own = [m for m in model.materials.values() if m.name in model.declared_materials]
    rest = [m for m in model.materials.values() if m.name not in model.declared_materials]
    return "\n".join(f"- {m.name}: {m.material_class}, rgb {_rgb(m.rgb)}, metalness {m.metalness:g}, "
                     f"roughness {m.roughness:g}" for m in own + rest)


def _family_volume(model: CompiledModel, part: str) -> float:
    """The volume of ``part`` and every colour block painted on it, mm^3."""
    from .. import kernel
    return sum(kernel.volume(p.local_shape()) for p in model.parts if p.owner == part)


def _paint(bench: MaterialsBench, edit: SubpartEdit) -> dict[str, Any]:
    """Gate one PAINT: splice, compile with no blocking finding, every block cut from the part,
    the part's gates, no other part's geometry changed, volume conserved."""
    part = edit.part
    row: dict[str, Any] = {"part": part, "kind": "paint", "blocks": list(edit.blocks), "accepted": False}
    try:
        source = splice_paint(bench.source, part, edit.text)
    except PaintError as exc:
        return {**row, "reason": f"refused: {exc}"}
    verdict = bench.host.tools.gate_part(source, part, baseline=_n_vis(bench), name=bench.host.name)
    model = verdict.model
    errors = blocking(model.findings) if model is not None else []
    if not verdict.compiled or model is None or errors:
        return {**row, "reason": "refused: " + findings_text(errors or verdict.errors, 4).replace("\n", " ")}
    got = {p.name: p for p in model.parts}
    missing = [b for b in edit.blocks if b not in got or got[b].block_of != part]
    if missing:
        return {**row, "reason": f"refused: no block {', '.join(missing)} was cut from {part}"}
    if verdict.errors:
        return {**row, "reason": "refused: " + findings_text(verdict.errors, 4).replace("\n", " ")}
    moved = sorted(p.name for p in bench.model.parts
                   if p.owner != part and (p.name not in got or got[p.name].digest != p.digest))
    if moved:
        return {**row, "reason": f"refused: the splice changed the shape of {', '.join(moved)}"}
    before, after = _family_volume(bench.model, part), _family_volume(model, part)
    rel = abs(after - before) / before if before > 0 else 0.0
    row.update({"volume_before": round(before, 6), "volume_after": round(after, 6)})
    if rel > MATERIAL.paint_volume_rtol:
        return {**row, "reason": f"refused: {part} and its blocks hold {after:.6g} mm^3, not the "
                                 f"{before:.6g} mm^3 it had (relative change {rel:.3g} > "
                                 f"{MATERIAL.paint_volume_rtol:g}): paint never changes shape"}
    bench.source, bench.model = source, model
    bench.history(f"subparts-paint-{part}")
    return {**row, "accepted": True,
            "materials": {b: got[b].material for b in edit.blocks}}


def _n_vis(bench: MaterialsBench) -> int:
    from ..gates import check_model
    return int(check_model(bench.model).gate("connectivity").measured.get("n_vis", 0))
