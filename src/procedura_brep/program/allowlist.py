"""The static half of the sandbox: an AST allowlist every program must pass before it runs.

Rules (docs/program-format.md, "Security"):
  * imports: only ``from procedura_brep.program import *``, ``import math``, ``from math import ...``;
  * no name or attribute that starts with an underscore (so no dunder escapes such as
    ``x.__globals__``, ``().__class__``, ``__import__``, ``__builtins__``);
  * no call to ``open``, ``exec``, ``eval``, ``compile``, ``globals``, ``locals``, ``vars``,
    ``getattr``, ``setattr``, ``delattr``, ``input``, ``breakpoint``, ``help``, ``exit``,
    ``quit``, ``memoryview``, ``type``, ``super``, ``object``, ``classmethod``, ``staticmethod``,
    ``property``: these names may not appear at all;
  * no assignment to attributes (``obj.attr = ...``): a program may not monkeypatch the kernel;
  * no attribute that reaches frames, code or globals (``gi_frame``, ``f_back``, ``f_globals``,
    ``tb_frame``, ``co_code``, ``mro``, and ``str.format``, whose fields read attributes by
    name: use f-strings);
  * no ``match`` statements (class patterns read attributes by name);
  * from the program API only ``import *``; no imported name starting with ``_``;
  * no ``global``/``nonlocal``, ``async`` code, or ``del`` of attributes;
  * no keyword argument that names a file (``font_path=``, ``file=`` ...);
  * no writes into what the import brought in: no item assignment or deletion
    (``Solid.shape_constructors[k] = fn``, ``FONT_ASPECT[k] = v``) and no call of a mutating
    container method (``update``, ``append``, ``pop`` ...) on anything rooted at a name the
    program did not bind itself (build123d's class-level tables are the kernel's state; the
    runtime also compares them before and after the program runs).
The dynamic half (resource limits, scratch dir, stripped environment, restricted builtins) is
in :mod:`procedura_brep.program.sandbox` and :mod:`procedura_brep.program.runtime`.
"""

from __future__ import annotations

import ast
from collections.abc import Callable
from typing import Any, cast

from ..errors import ProgramFormatError

FORBIDDEN_NAMES = frozenset({
    "open", "exec", "eval", "compile", "globals", "locals", "vars", "getattr", "setattr",
    "delattr", "input", "breakpoint", "help", "exit", "quit", "memoryview", "type", "super",
    "object", "classmethod", "staticmethod", "property", "dir", "id", "hasattr",
})
ALLOWED_IMPORTS = {"math"}
#: Attributes that lead from ordinary objects to frames, code or globals (and so to the
#: interpreter): generator/coroutine frames, frame and traceback links, code objects.
FORBIDDEN_ATTRIBUTES = frozenset({
    "gi_frame", "gi_code", "gi_yieldfrom", "gi_running", "cr_frame", "cr_code", "cr_await",
    "cr_origin", "ag_frame", "ag_code", "ag_await", "f_back", "f_globals", "f_locals",
    "f_builtins", "f_code", "f_trace", "f_lasti", "tb_frame", "tb_next", "tb_lasti",
    "co_code", "co_consts", "co_names", "co_varnames", "func_globals", "func_code", "mro",
    "format", "format_map", "with_traceback",
})
#: Keyword arguments that name files (e.g. ``Text(..., font_path=...)``): programs touch no files.
FORBIDDEN_KEYWORDS = frozenset({"font_path", "file", "filename", "file_name"})
PROGRAM_MODULE = "procedura_brep.program"
#: Container methods that change their receiver.
MUTATORS = frozenset({"update", "setdefault", "pop", "popitem", "clear", "append", "extend",
                      "insert", "remove", "discard", "add"})


class PolicyViolation(ProgramFormatError):
    """The program uses a construct the sandbox forbids."""


def check(source: str, filename: str = "<program>", *, tree: ast.Module | None = None) -> None:
    """Raise :class:`PolicyViolation` (with the line) at the first forbidden construct.

    ``tree`` is ``source`` already parsed (:attr:`.sections.Sections.tree`); it is what the
    compiler then runs, so the policy checks exactly the code that runs."""
    if tree is None:
        try:
            tree = ast.parse(source, filename=filename)
        except SyntaxError as exc:
            raise ProgramFormatError(f"syntax error: {exc.msg}", line=exc.lineno) from None
    nodes = _walk(tree)  # walked once: the three passes below read the list
    for node in nodes:
        _check_node(node)
    bound = _bound_names(nodes)
    for node in nodes:
        if isinstance(node, (ast.Subscript, ast.Call)):
            _check_write(node, bound)


def _walk(tree: ast.AST) -> list[ast.AST]:
    """Every node of ``tree`` in :func:`ast.walk`'s order (breadth first, fields in order), as a
    list: the same nodes, without a generator per node."""
    out = [tree]
    AST = ast.AST
    i = 0
    while i < len(out):
        node = out[i]
        i += 1
        for name in node._fields:
            v = getattr(node, name, None)
            if isinstance(v, AST):
                out.append(v)
            elif isinstance(v, list):
                out.extend(x for x in v if isinstance(x, AST))
    return out


def _bound_names(nodes: list[ast.AST]) -> set[str]:
    """Every name the program binds anywhere (assignments, arguments, defs, imports, loops),
    from every node of its tree."""
    out: set[str] = set()
    for node in nodes:
        kind = _of(_BINDS, type(node), _BIND_MEMO)
        if kind is None:
            continue
        # ``kind`` says the node's class (_BINDS); cast, not isinstance: this loop sees every node
        if kind == "name":
            name = cast(ast.Name, node)
            if isinstance(name.ctx, (ast.Store, ast.Del)):
                out.add(name.id)
        elif kind == "arg":
            out.add(cast(ast.arg, node).arg)
        elif kind == "def":
            out.add(cast("ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef", node).name)
        elif kind == "alias":
            alias = cast(ast.alias, node)
            out.add(alias.asname or alias.name.split(".")[0])
        else:
            handler = cast(ast.ExceptHandler, node)
            if handler.name:  # an except handler's ``as`` name
                out.add(handler.name)
    return out


def _root(node: ast.AST) -> ast.AST:
    while isinstance(node, (ast.Attribute, ast.Subscript)):
        node = node.value
    return node


def _imported(node: ast.AST, bound: set[str]) -> bool:
    """True when ``node`` (an expression) is rooted at a name the program did not bind."""
    root = _root(node)
    return isinstance(root, ast.Name) and root.id not in bound


def _check_write(node: ast.AST, bound: set[str]) -> None:
    if isinstance(node, ast.Subscript) and isinstance(node.ctx, (ast.Store, ast.Del)) \
            and _imported(node.value, bound):
        _deny(node, f"writing into {ast.unparse(node.value)[:60]} (the kernel's own tables; "
                    f"build your own dict or list)")
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
            and node.func.attr in MUTATORS and isinstance(node.func.value, (ast.Name, ast.Attribute)) \
            and _imported(node.func.value, bound):
        _deny(node, f"calling {ast.unparse(node.func)[:60]}(...) (it would change the kernel's "
                    f"own tables)")


def _deny(node: ast.AST, why: str) -> None:
    raise PolicyViolation(f"not allowed in a program: {why}", line=getattr(node, "lineno", None))


def _reserved(name: str | None) -> bool:
    if not name:
        return False
    return name.startswith("_") or name in FORBIDDEN_NAMES


def _import(node: ast.Import) -> None:
    for alias in node.names:
        if alias.name not in ALLOWED_IMPORTS or _reserved(alias.asname):
            _deny(node, f"import {alias.name} (programs may import only math and "
                        f"{PROGRAM_MODULE})")


def _import_from(node: ast.ImportFrom) -> None:
    if node.module not in ALLOWED_IMPORTS | {PROGRAM_MODULE} or node.level:
        _deny(node, f"from {node.module} import ... (programs may import only math and "
                    f"{PROGRAM_MODULE})")
    names = [a.name for a in node.names]
    if node.module == PROGRAM_MODULE and names != ["*"]:
        _deny(node, f"from {PROGRAM_MODULE} import {', '.join(names)} (write "
                    f"`from {PROGRAM_MODULE} import *`)")
    for alias in node.names:
        if _reserved(alias.name if alias.name != "*" else None) or _reserved(alias.asname):
            _deny(node, f"importing the name {alias.name!r}")


def _match(node: ast.AST) -> None:
    _deny(node, "match statements (their class patterns read attributes by name)")


def _handler(node: ast.ExceptHandler) -> None:
    if _reserved(node.name):
        _deny(node, f"the name {node.name!r}")


def _name(node: ast.Name) -> None:
    if node.id.startswith("_"):
        _deny(node, f"the name {node.id!r} (names starting with '_' are reserved)")
    if node.id in FORBIDDEN_NAMES:
        _deny(node, f"the builtin {node.id!r}")


def _attribute(node: ast.Attribute) -> None:
    if node.attr.startswith("_"):
        _deny(node, f"the attribute {node.attr!r} (attributes starting with '_' are reserved)")
    if node.attr in FORBIDDEN_ATTRIBUTES:
        _deny(node, f"the attribute {node.attr!r} (frames, code and globals are off limits)")
    if isinstance(node.ctx, (ast.Store, ast.Del)):
        _deny(node, f"assigning to the attribute {node.attr!r} (no monkeypatching)")


def _definition(node: ast.FunctionDef | ast.ClassDef | ast.AsyncFunctionDef) -> None:
    if node.name.startswith("_"):
        _deny(node, f"the definition {node.name!r} (names starting with '_' are reserved)")
    if isinstance(node, ast.AsyncFunctionDef):
        _deny(node, "async functions")


def _argument(node: ast.arg) -> None:
    if node.arg.startswith("_"):
        _deny(node, f"the argument {node.arg!r}")


def _scope(node: ast.AST) -> None:
    _deny(node, "global/nonlocal statements")


def _async(node: ast.AST) -> None:
    _deny(node, "async code")


def _keyword(node: ast.keyword) -> None:
    if node.arg and (node.arg.startswith("_") or node.arg in FORBIDDEN_KEYWORDS):
        _deny(node, f"the keyword {node.arg!r} (programs touch no files)")


def _constant(node: ast.Constant) -> None:
    if isinstance(node.value, str) and "__" in node.value:
        _deny(node, "string literals containing '__'")


#: The rule for each node class that has one (a table: the walk looks each node's class up
#: once instead of testing it against every rule).
_RULES: dict[type, Callable[[Any], None]] = {
    ast.Import: _import, ast.ImportFrom: _import_from,
    **{t: _match for t in (ast.Match, ast.match_case, ast.MatchValue, ast.MatchSingleton,
                           ast.MatchSequence, ast.MatchMapping, ast.MatchClass, ast.MatchStar,
                           ast.MatchAs, ast.MatchOr)},
    ast.ExceptHandler: _handler, ast.Name: _name, ast.Attribute: _attribute,
    ast.FunctionDef: _definition, ast.ClassDef: _definition, ast.AsyncFunctionDef: _definition,
    ast.arg: _argument, ast.Global: _scope, ast.Nonlocal: _scope,
    ast.AsyncFor: _async, ast.AsyncWith: _async, ast.Await: _async,
    ast.keyword: _keyword, ast.Constant: _constant,
}
#: Node classes that bind a name (:func:`_bound_names`), by how.
_BINDS: dict[type, str] = {ast.Name: "name", ast.arg: "arg", ast.FunctionDef: "def",
                           ast.ClassDef: "def", ast.AsyncFunctionDef: "def", ast.alias: "alias",
                           ast.ExceptHandler: "handler"}


def _of(table: dict[type, Any], cls: type, memo: dict[type, Any]) -> Any:
    """``table``'s entry for ``cls``, or for its nearest base in the table (a subclass of a
    ruled class, never made by the parser, is held to its base's rule); None when neither.
    Resolved once per class (``memo``)."""
    try:
        return memo[cls]
    except KeyError:
        hit = memo[cls] = next((table[t] for t in cls.__mro__ if t in table), None)
        return hit


_RULE_MEMO: dict[type, Any] = {}
_BIND_MEMO: dict[type, Any] = {}


def _check_node(node: ast.AST) -> None:
    """Apply the rule of ``node``'s class (:data:`_RULES`), if it has one."""
    rule = _of(_RULES, type(node), _RULE_MEMO)
    if rule is not None:
        rule(node)


_PARAM_NODES = (ast.Expression, ast.Constant, ast.Name, ast.Load, ast.BinOp, ast.UnaryOp,
                ast.operator, ast.unaryop, ast.Call, ast.Attribute, ast.Tuple)


def check_param_expr(expr: str, *, line: int | None = None, known: set[str] | None = None) -> None:
    """A param expression may use numbers, earlier params, arithmetic and ``math.<fn>(...)`` only.

    Args:
        expr: the expression text.
        line: its program line, for the message.
        known: the params defined before it (None: any name is accepted as a param).
    """
    def bad(why: str) -> None:
        raise ProgramFormatError(f"param expression {expr!r}: {why}; params hold only numbers, "
                                 f"earlier params, arithmetic and math functions", line=line)

    try:
        tree = ast.parse(expr, mode="eval")
    except SyntaxError:
        raise ProgramFormatError(f"param expression {expr!r} is not valid Python", line=line) from None
    for node in ast.walk(tree):
        if not isinstance(node, _PARAM_NODES):
            bad(f"{type(node).__name__} is not allowed")
        if isinstance(node, ast.Name) and node.id != "math" and (
                node.id.startswith("_") or (known is not None and node.id not in known)):
            bad(f"{node.id!r} is not an earlier param")
        if isinstance(node, ast.Attribute) and not (
                isinstance(node.value, ast.Name) and node.value.id == "math"
                and not node.attr.startswith("_")):
            bad("only math.<name> attributes")
        if isinstance(node, ast.Call) and not (
                isinstance(node.func, ast.Attribute) and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "math"):
            bad("only math functions may be called")
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            bad("strings are not allowed")
