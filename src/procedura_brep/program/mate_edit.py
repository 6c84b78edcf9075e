"""Mate edits: rewrite exactly one ``mate(...)`` declaration of the assembly section.

``set_mate(source, "arm_pivot", options={"limits": (-30, 30)})`` replaces that one statement with
the same call, its type and fit changed where asked and its keyword options set, added or (with
:data:`REMOVE`) dropped; every other byte of the program is unchanged. This is how the
articulation stage turns its plan into program edits, so the program stays the one source of the
links, joints and limits.
"""

from __future__ import annotations

import ast
import json
from collections.abc import Mapping
from typing import Any

from ..errors import EditError, ProgramFormatError
from .sections import parse_sections

#: An option value meaning "drop this keyword from the call".
REMOVE = object()


def _literal(value: Any) -> str:
    """Python source for a mate option value (numbers, None, booleans, strings, pairs)."""
    if isinstance(value, str):
        return json.dumps(value)
    if value is None or isinstance(value, bool):
        return repr(value)
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, (tuple, list)):
        return "(" + ", ".join(_literal(v) for v in value) + ("," if len(value) == 1 else "") + ")"
    raise EditError(f"cannot write the option value {value!r} into a program")


def _const(node: ast.AST) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def mate_name(call: ast.Call) -> str | None:
    """The mate's stable id: its ``name=`` or ``<child part>_<child frame>`` (None when it is
    not a literal)."""
    for kw in call.keywords:
        if kw.arg == "name":
            return _const(kw.value)
    child = _const(call.args[0]) if call.args else None
    if child is None or "." not in child:
        return None
    part, frame = child.split(".", 1)
    return f"{part}_{frame}"


def _mate_calls(source: str) -> list[tuple[ast.stmt, ast.Call]]:
    try:
        sec = parse_sections(source)
        tree = ast.parse(source)
    except (ProgramFormatError, SyntaxError) as exc:
        raise EditError(f"cannot edit: {exc}") from None
    out: list[tuple[ast.stmt, ast.Call]] = []
    for stmt in tree.body:
        if sec.section_of(stmt.lineno) != "assembly":
            continue
        if (isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call)
                and isinstance(stmt.value.func, ast.Name) and stmt.value.func.id == "mate"):
            out.append((stmt, stmt.value))
    return out


def mate_names(source: str) -> list[str]:
    """The ids of the mates declared as plain top-level ``mate(...)`` statements."""
    return [n for _, c in _mate_calls(source) if (n := mate_name(c)) is not None]


def set_mate(source: str, name: str, *, type: str | None = None, fit: str | None = None,
             options: Mapping[str, Any] | None = None) -> str:
    """Return ``source`` with the mate ``name`` rewritten (see the module doc).

    Raises:
        EditError: no top-level ``mate(...)`` statement has that id (the message lists the
            ids), its type is not a literal string, or a value cannot be written.
    """
    calls = _mate_calls(source)
    hit = [(s, c) for s, c in calls if mate_name(c) == name]
    if not hit:
        names = ", ".join(n for _, c in calls if (n := mate_name(c))) or "none"
        raise EditError(f"no mate named {name!r} in the assembly section (a mate declared in a "
                        f"loop cannot be edited here); mates: {names}")
    stmt, call = hit[0]
    if len(call.args) < 3 or _const(call.args[2]) is None:
        raise EditError(f"mate {name!r}: its type is not a literal string; edit it by hand")
    seg = ast.get_source_segment
    args = [seg(source, a) or "" for a in call.args]
    if type is not None:
        args[2] = json.dumps(type)
    kws: dict[str, str] = {}
    for kw in call.keywords:
        if kw.arg is None:
            raise EditError(f"mate {name!r} uses **options; edit it by hand")
        kws[kw.arg] = seg(source, kw.value) or ""
    if fit is not None:
        kws["fit"] = json.dumps(fit)
    for key, value in (options or {}).items():
        if value is REMOVE:
            kws.pop(key, None)
        else:
            kws[key] = _literal(value)
    text = "mate(" + ", ".join(args + [f"{k}={v}" for k, v in kws.items()]) + ")"
    lines = source.splitlines(keepends=True)
    first, last = stmt.lineno - 1, stmt.end_lineno - 1  # type: ignore[operator]  # a parsed stmt has end_lineno
    indent = lines[first][: len(lines[first]) - len(lines[first].lstrip())]
    tail = lines[last][stmt.end_col_offset:]  # a trailing comment stays
    lines[first:last + 1] = [indent + text + (tail if tail.strip() else "\n")]
    return "".join(lines)


__all__ = ["REMOVE", "mate_name", "mate_names", "set_mate"]
