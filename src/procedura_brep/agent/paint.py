"""The materials stage's deterministic side: its reply formats, parsed strictly, and the splice
of a material library and an assignment into a program.

A ``materials`` or ``material_critic`` reply is one JSON object (in a code fence or bare)::

    {"summary": "red hull, black tyres, brushed-steel axles",
     "library": [{"name": "hull_paint", "base": "painted_steel", "rgb": [0.8, 0.1, 0.1],
                  "roughness": 0.4, "wear": 0.2}],
     "assign": {"hull": "hull_paint", "wheel_fl": "rubber"}}

``library`` entries take the fields of ``material(...)`` (:func:`procedura_brep.program.api.material`);
``base`` is a built-in material. The first call assigns every part; a critic's ``assign`` names only
the parts it changes, and its ``library`` adds entries or replaces same-named ones. A ``subparts``
reply is ``REWRITES: none`` or one ``REWRITE part_name`` line before each rewritten part's five
blocks, or a ``PAINT part_name`` line before ``@paint`` functions
(:mod:`procedura_brep.agent.subparts`).

:func:`apply_materials` writes the library as ``material(...)`` lines at the top of the parts
section (replacing every declaration the program had) and sets each assigned part's
``@part(material=...)``; nothing else in the program changes.
"""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ..errors import ProceduraError
from ..materials import MATERIALS, Material, MaterialError, declare
from ..program.sections import marker, parse_sections

FIELDS: tuple[str, ...] = ("base", "rgb", "roughness", "metalness", "density", "material_class", "wear")
_FENCE_RE = re.compile(r"```(?:json)?\s*\n(.*?)\n\s*```", re.S)


def _text(v: Any) -> str:
    """A value as program text (strings in double quotes, as the programs write them)."""
    return json.dumps(v) if isinstance(v, str) else repr(v)


class PaintError(ProceduraError):
    """A materials-stage reply that cannot be used (the retry is told why)."""


@dataclass(frozen=True)
class Entry:
    """One library entry as the program declares it: a name and the fields it gives."""

    name: str
    values: dict[str, Any] = field(default_factory=dict)

    def material(self) -> Material:
        return declare(self.name, library=MATERIALS, **self.values)

    def call(self) -> str:
        """The ``material(...)`` line that declares it."""
        args = [_text(self.name)]
        for k in FIELDS:
            if k in self.values:
                v = self.values[k]
                args.append(f"{k}={tuple(v)!r}" if k == "rgb" else f"{k}={_text(v)}")
        return f"material({', '.join(args)})"


@dataclass(frozen=True)
class Assignment:
    """A parsed reply: a one-line summary, library entries, part -> material."""

    summary: str
    library: tuple[Entry, ...]
    assign: dict[str, str]


def _json_object(text: str) -> dict[str, Any]:
    m = _FENCE_RE.search(text)
    body = m.group(1) if m else text[text.find("{"):text.rfind("}") + 1]
    if not body.strip():
        raise PaintError("the reply holds no JSON object")
    try:
        obj = json.loads(body)
    except ValueError as exc:
        raise PaintError(f"the JSON does not parse: {exc}") from None
    if not isinstance(obj, dict):
        raise PaintError("the reply must be one JSON object with summary, library and assign")
    return obj


def parse_entry(row: Any, i: int) -> Entry:
    """One ``library`` row, validated like a ``material(...)`` declaration."""
    if not isinstance(row, dict) or not isinstance(row.get("name"), str):
        raise PaintError(f"library[{i}] must be an object with a \"name\"")
    extra = sorted(set(row) - {"name", *FIELDS})
    if extra:
        raise PaintError(f"library[{i}] ({row['name']}): unknown field(s) {', '.join(extra)}; "
                         f"fields are name, {', '.join(FIELDS)}")
    values = {k: (tuple(v) if k == "rgb" and isinstance(v, list) else v) for k, v in row.items()
              if k != "name"}
    if values.get("base") is not None and values["base"] not in MATERIALS:
        raise PaintError(f"library[{i}] ({row['name']}): base {values['base']!r:.40} is not a built-in "
                         f"material; built-ins: {', '.join(MATERIALS)}")
    entry = Entry(row["name"], values)
    try:
        entry.material()
    except MaterialError as exc:
        raise PaintError(f"library[{i}]: {exc}") from None
    return entry


def merge(current: tuple[Entry, ...], new: tuple[Entry, ...]) -> tuple[Entry, ...]:
    """``current`` with ``new`` entries replacing same-named ones and the rest appended."""
    out = {e.name: e for e in current}
    out.update({e.name: e for e in new})
    return tuple(out.values())


def parse_assignment(text: str, *, parts: list[str], current: tuple[Entry, ...] = (),
                     complete: bool = True) -> Assignment:
    """Parse a ``materials`` (``complete``: every part assigned) or ``material_critic`` reply.

    Args:
        parts: the program's parts, in order.
        current: the program's declared entries (a critic may use or replace them).

    Raises:
        PaintError: bad JSON, an unknown key or field, an entry out of range, a part that is not
            in the program or (``complete``) is not assigned, a material not in the library.
    """
    obj = _json_object(text)
    extra = sorted(set(obj) - {"summary", "library", "assign"})
    if extra:
        raise PaintError(f"unknown key(s) {', '.join(extra)}; the object has summary, library, assign")
    rows = obj.get("library", [])
    if not isinstance(rows, list):
        raise PaintError("\"library\" must be a list of entries")
    new = tuple(parse_entry(r, i) for i, r in enumerate(rows))
    names = [e.name for e in new]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise PaintError(f"library entries named twice: {', '.join(dup)}")
    assign = obj.get("assign")
    if not isinstance(assign, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                                for k, v in assign.items()):
        raise PaintError("\"assign\" must be an object mapping part names to material names")
    unknown = [p for p in assign if p not in parts]
    if unknown:
        raise PaintError(f"assign names part(s) not in the program: {', '.join(unknown)}; parts: "
                         f"{', '.join(parts)}")
    if complete:
        missing = [p for p in parts if p not in assign]
        if missing:
            raise PaintError(f"assign one material to every part; missing: {', '.join(missing)}")
    library = {**MATERIALS, **{e.name: e for e in merge(current if not complete else (), new)}}
    bad = [f"{p}: {m!r:.40}" for p, m in assign.items() if m not in library]
    if bad:
        raise PaintError(f"unknown material(s) in assign ({'; '.join(bad)}); use a built-in or a "
                         f"library entry: {', '.join(library)}")
    summary = obj.get("summary", "")
    return Assignment(summary if isinstance(summary, str) else str(summary), new, dict(assign))


# the splice ---------------------------------------------------------------------------------

def _is_material_call(stmt: ast.stmt) -> bool:
    return (isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call)
            and isinstance(stmt.value.func, ast.Name) and stmt.value.func.id == "material")


def declared_entries(source: str, model_materials: Mapping[str, Material] | None = None) -> tuple[Entry, ...]:
    """The program's ``material(...)`` declarations as entries (literal arguments; a call with
    computed ones is read back from ``model_materials``, the compiled model's library)."""
    out: list[Entry] = []
    for stmt in ast.parse(source).body:
        if not _is_material_call(stmt):
            continue
        call = stmt.value  # type: ignore[attr-defined]  # an ast.Expr: _is_material_call checked it
        try:
            name = ast.literal_eval(call.args[0])
            values = {k.arg: ast.literal_eval(k.value) for k in call.keywords if k.arg}
            out.append(Entry(name, values))
        except (ValueError, IndexError, SyntaxError, TypeError):
            if model_materials is None:
                continue
            first = call.args[0] if call.args else None
            name = first.value if isinstance(first, ast.Constant) else None
            m = model_materials.get(name) if isinstance(name, str) else None
            if m is not None:
                out.append(Entry(m.name, {k: v for k, v in m.as_dict().items() if k != "name"}))
    return tuple(out)


def _offset(line_starts: list[int], lines: list[str], lineno: int, col: int) -> int:
    """Character offset of an AST (line, UTF-8 byte column) position."""
    text = lines[lineno - 1]
    return line_starts[lineno - 1] + len(text.encode("utf-8")[:col].decode("utf-8", "ignore"))


def _decorator_edit(fn: ast.FunctionDef, material: str) -> tuple[ast.AST, str] | None:
    """(node to replace, new text) that makes ``fn``'s ``@part`` (or a colour block's
    ``@paint``) name ``material``."""
    for d in fn.decorator_list:
        if isinstance(d, ast.Call) and isinstance(d.func, ast.Name) and d.func.id == "paint":
            k = next((k for k in d.keywords if k.arg == "material"), None)
            return (k.value, _text(material)) if k is not None else None
        if isinstance(d, ast.Name) and d.id == "part":
            return d, f"part(material={_text(material)})"
        if isinstance(d, ast.Call) and isinstance(d.func, ast.Name) and d.func.id == "part":
            for k in d.keywords:
                if k.arg == "material":
                    return k.value, _text(material)
            if d.keywords:
                k0 = d.keywords[0]
                return k0, None  # type: ignore[return-value]  # insert before the first keyword
            return d, f"part(material={_text(material)})"
    return None


def apply_materials(source: str, library: tuple[Entry, ...], assign: Mapping[str, str]) -> str:
    """``source`` with its material declarations replaced by ``library`` (at the top of the parts
    section) and each part in ``assign`` set to its material. Deterministic; nothing else moves.

    Raises:
        PaintError: a part of ``assign`` is not a ``@part`` function of the program.
    """
    src = source.replace("\r\n", "\n")
    tree = ast.parse(src)
    lines = src.split("\n")
    starts = [0]
    for t in lines[:-1]:
        starts.append(starts[-1] + len(t) + 1)
    spans: list[tuple[int, int, str]] = []  # (start, end, replacement) in characters
    defs = {s.name: s for s in tree.body if isinstance(s, ast.FunctionDef)}
    for part, mat in assign.items():
        fn = defs.get(part)
        edit = _decorator_edit(fn, mat) if fn is not None else None
        if edit is None:
            raise PaintError(f"part {part} has no @part(...) function in the program")
        node, text = edit
        a = _offset(starts, lines, node.lineno, node.col_offset)
        if text is None:  # insert before the first keyword
            spans.append((a, a, f"material={_text(mat)}, "))
        else:
            spans.append((a, _offset(starts, lines, node.end_lineno, node.end_col_offset), text))
    for stmt in tree.body:
        if _is_material_call(stmt):
            a = starts[stmt.lineno - 1]
            end_line = stmt.end_lineno or stmt.lineno
            b = starts[end_line] if end_line < len(lines) else len(src)
            spans.append((a, b, ""))
    out = src
    for a, b, text in sorted(spans, reverse=True):
        out = out[:a] + text + out[b:]
    sec = parse_sections(out)
    at = sec.starts["parts"]
    rows = out.split("\n")
    # drop blank lines left at the top of the parts section, then write the block
    while at < len(rows) and not rows[at].strip():
        rows.pop(at)
    block = [e.call() for e in library] + ([""] if library else [])
    rows[at:at] = block
    if rows[at - 1].strip() != marker("parts"):
        raise PaintError("the parts marker moved while splicing materials (internal error)")
    return "\n".join(rows)
