"""The sub-parts pass's reply (materials stage, step 3): colour blocks and part rewrites.

A ``subparts`` reply is ``REWRITES: none``, or, per part, one of:

* ``REWRITE part_name`` followed by the part's five blocks (a whole-part rewrite, gated on its
  triangle count; :func:`procedura_brep.agent.materials._rewrite`);
* ``PAINT part_name`` followed by one ```python block holding one or more
  ``@paint("part_name", material=...)`` functions, each returning a region in the part's local
  coordinates (see docs/program-format.md, colour blocks)::

      PAINT arm
      ```python
      @paint("arm", material="rubber", description="rubber grip at the arm's tip")
      def arm_tip():
          return Pos(70, 0, 0) * Box(30, 30, 30, align=(Align.MIN, Align.CENTER, Align.CENTER))
      ```

:func:`parse_subparts` checks the form strictly (a PAINT block holds nothing but such functions,
each naming its part and a material of the run's library, with a new snake_case name);
:func:`splice_paint` puts the functions after the part (after its earlier blocks); the stage
then compiles, gates and checks volume conservation.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from typing import Literal

from .paint import PaintError

_HEAD_RE = re.compile(r"^\s*(REWRITE|PAINT)\s+`?([a-z][a-z0-9_]*)`?\s*:?\s*$", re.M)
_NONE_RE = re.compile(r"^\s*REWRITES\s*:\s*none\.?\s*$", re.I | re.M)
_PY_FENCE_RE = re.compile(r"```(?:python|py)?[ \t]*\n(.*?)\n[ \t]*```", re.S)
_NAME_RE = re.compile(r"[a-z][a-z0-9_]{0,63}")


@dataclass(frozen=True)
class SubpartEdit:
    """One edit of the reply: a whole-part rewrite (its five blocks) or paint (its code)."""

    kind: Literal["rewrite", "paint"]
    part: str
    text: str
    blocks: tuple[str, ...] = ()


def _paint_call(fn: ast.FunctionDef) -> ast.Call | None:
    if len(fn.decorator_list) != 1:
        return None
    d = fn.decorator_list[0]
    if isinstance(d, ast.Call) and isinstance(d.func, ast.Name) and d.func.id == "paint":
        return d
    return None


def _check_paint_code(code: str, part: str, *, taken: set[str], library: set[str]) -> tuple[str, ...]:
    """The block names of a PAINT block's code, after checking its form."""
    where = f"PAINT {part}"
    try:
        tree = ast.parse(code)
    except SyntaxError as exc:
        raise PaintError(f"{where}: the python block does not parse: {exc.msg} (line {exc.lineno})") from None
    if not tree.body:
        raise PaintError(f"{where}: the python block is empty")
    names: list[str] = []
    for stmt in tree.body:
        call = _paint_call(stmt) if isinstance(stmt, ast.FunctionDef) else None
        if call is None:
            raise PaintError(f"{where}: the python block may hold only functions decorated with "
                             f"@paint(\"{part}\", material=...) (line {stmt.lineno} is not one)")
        fn = stmt
        assert isinstance(fn, ast.FunctionDef)
        if fn.args.args or fn.args.kwonlyargs or fn.args.vararg or fn.args.kwarg:
            raise PaintError(f"{where}: {fn.name}() must take no arguments")
        first = call.args[0] if len(call.args) == 1 else None
        if not (isinstance(first, ast.Constant) and first.value == part):
            raise PaintError(f"{where}: {fn.name} must be decorated @paint(\"{part}\", material=...)")
        kw = {k.arg: k.value for k in call.keywords}
        mat = kw.get("material")
        if not (isinstance(mat, ast.Constant) and isinstance(mat.value, str)):
            raise PaintError(f"{where}: {fn.name}: give material=\"name\" (a material of the run's library)")
        if mat.value not in library:
            raise PaintError(f"{where}: {fn.name}: material {mat.value!r:.40} is not in the run's "
                             f"library: {', '.join(sorted(library))}")
        extra = sorted(set(kw) - {"material", "description"})
        if extra:
            raise PaintError(f"{where}: {fn.name}: @paint takes material= and description= only, "
                             f"not {', '.join(str(e) for e in extra)}")
        if not _NAME_RE.fullmatch(fn.name):
            raise PaintError(f"{where}: block name {fn.name!r} must be snake_case [a-z][a-z0-9_]*")
        if fn.name in taken or fn.name in names:
            raise PaintError(f"{where}: the name {fn.name!r} is taken (a part, a block, or twice "
                             f"in the reply); give each block a new name")
        names.append(fn.name)
    return tuple(names)


def parse_subparts(text: str, *, parts: list[str], library: set[str]) -> list[SubpartEdit]:
    """A ``subparts`` reply: ``[]`` for ``REWRITES: none``, else its edits in reply order.

    Args:
        parts: the names of the compiled model's parts (blocks included).
        library: the run's material names.

    Raises:
        PaintError: neither form, a part not in the program, a part edited twice, a PAINT
            without exactly one python block or with anything but well-formed @paint functions.
    """
    heads = list(_HEAD_RE.finditer(text))
    if not heads:
        if _NONE_RE.search(text):
            return []
        raise PaintError("reply 'REWRITES: none', or put a line 'REWRITE part_name' before each "
                         "rewritten part's five blocks, or 'PAINT part_name' before one ```python "
                         "block of @paint functions")
    out: list[SubpartEdit] = []
    taken = set(parts)
    for k, h in enumerate(heads):
        kind, name = h.group(1), h.group(2)
        if name not in parts:
            raise PaintError(f"{kind} {name}: no such part; parts: {', '.join(parts)}")
        if any(e.part == name for e in out):
            raise PaintError(f"part {name} is edited twice")
        end = heads[k + 1].start() if k + 1 < len(heads) else len(text)
        body = text[h.end():end]
        if kind == "REWRITE":
            out.append(SubpartEdit("rewrite", name, body))
            continue
        fences = _PY_FENCE_RE.findall(body)
        if len(fences) != 1:
            raise PaintError(f"PAINT {name}: follow it with exactly one ```python block of @paint "
                             f"functions (found {len(fences)})")
        blocks = _check_paint_code(fences[0], name, taken=taken, library=library)
        taken |= set(blocks)
        out.append(SubpartEdit("paint", name, fences[0].strip() + "\n", blocks))
    return out


def _paints_of(stmt: ast.stmt, part: str) -> bool:
    call = _paint_call(stmt) if isinstance(stmt, ast.FunctionDef) else None
    first = call.args[0] if call is not None and call.args else None
    return isinstance(first, ast.Constant) and first.value == part


def splice_paint(source: str, part: str, code: str) -> str:
    """``source`` with ``code`` (``@paint`` functions) inserted after ``part``'s function and
    after the blocks already painted on it; nothing else changes.

    Raises:
        PaintError: ``part`` has no top-level function in the program.
    """
    src = source.replace("\r\n", "\n")
    tree = ast.parse(src)
    fn = next((s for s in tree.body if isinstance(s, ast.FunctionDef) and s.name == part), None)
    if fn is None:
        raise PaintError(f"part {part} has no function in the program")
    end = max([fn.end_lineno or fn.lineno] + [s.end_lineno or s.lineno for s in tree.body
                                             if _paints_of(s, part)])
    lines = src.split("\n")
    tail = [""] if end < len(lines) and lines[end].strip() else []
    lines[end:end] = [""] + code.rstrip("\n").split("\n") + tail
    return "\n".join(lines)
