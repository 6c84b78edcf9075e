"""Per-part cache keys: a hash of exactly what one part's final solid depends on.

A part's key (:func:`part_keys`) hashes:

* the engine (:func:`engine_digest`: the package, build123d and OCP versions and the source
  of every module of ``mates/``: the mate types, fits and feature macros that turn a part into
  its final solid);
* the part's own function: its ``def`` through its last line, its other decorators, its
  default arguments and closure cells, and the ``@part`` options that are not
  :data:`UNKEYED_OPTIONS`; not its name (nor the part's): parts whose functions differ only
  in name (``wheel_fl``, ``wheel_rl``: ``return wheel(1)``) share a key, so the store holds
  their solid once and a compile builds it once (:mod:`.runtime`, twins);
* everything the function reads by name, transitively (``_Keyer.walk``): the source and state of
  every program function and class it calls or references (helper -> helper -> ...), a
  class's program base classes, and the values of the params and other plain module-level
  constants (numbers, strings, tuples/lists/dicts of them) any of those read;
* every mate that adds a feature to it, in declaration order: its role (child or parent),
  type, nominal value, fit, options and this part's frame matrix (not the mate's name, which
  reaches no solid).

``@paint`` regions are in no key: a painted part's key (and the cache entry) is its unpainted
solid's, and :mod:`procedura_brep.program.blocks` cuts the blocks after the solid is loaded.

So an unused helper, a new param, a new part and its frames change no other part's key; a
changed helper changes the keys of exactly the parts that reach it; a spliced part's mates
change its own key and its partners'. Line numbers are in no key (a splice shifts them).

Where the key cannot see what a part may depend on, it is conservative, never stale:

* a part that reads a module-level object that is not a plain value (``ARM = [Box(...)]``,
  a function with such a default, an instance) gets the empty key: it is rebuilt on every
  compile and never stored (a part could change such an object while it runs); a default or
  closure value that is library code the program API binds (``maker=lead_screw``,
  ``rounder=math.floor``) is hashed by its name, the engine digest covering its code;
* module-level code acts on parts through the values it binds (hashed where a part reads
  them); a statement that runs only for its side effect is what a key cannot see. Anything
  but imports, ``def``/``class``, assignments to names, string literals, the declaration
  calls :data:`DECLARATION_CALLS`, and ``for``/``while``/``if`` blocks made of those (a bare
  call, a ``with`` or ``try`` block, an item assignment, ``del``, ``from math import *`` ...)
  is listed by :func:`scan_module`; when there is any, every key also hashes the whole
  program text (outside the module docstring): any edit anywhere then rebuilds every part;
* a part can change a module-level list, dict or set in place (it cannot rebind a module
  name: the policy forbids ``global``), so the compiler recomputes, after the parts ran, the
  keys that hashed such a value (:func:`part_keys` ``volatile``) and stores none that changed.

Keys are computed in the sandbox child, from the executed module's globals.
"""

from __future__ import annotations

import ast
import hashlib
import math
import re
import types
from dataclasses import dataclass, field
from functools import cache, lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from .registry import PartDecl, Registry

#: Module-level calls the key covers through what they declare (the registry: frames and mates
#: reach a key as matrices and mate rows). Any other module-level call makes the keys
#: whole-program (see the module docstring). A new declaration function (a per-run material
#: library, say) belongs here only if what it declares reaches a key or never reaches a solid.
DECLARATION_CALLS: frozenset[str] = frozenset({"frames", "mate", "material", "couple"})
#: ``@part`` options that never reach the solid: the compiled part takes them from the
#: declaration on every compile, cache hit or not, so changing one keeps the cache.
UNKEYED_OPTIONS: tuple[str, ...] = ("material", "description", "mass", "hollow")
#: Values a key hashes by ``repr``: module-level constants that cannot hide geometry.
_PLAIN = (int, float, bool, str, bytes, type(None))
_MISSING = object()


@lru_cache(maxsize=1)
def engine_digest() -> str:
    """Hash of the code that turns a part into its final solid (invalidates on upgrades of
    this package, build123d, OCP or py_gearworks, and on any change of the mates or of the
    transmission helpers, ``program/gearing.py``)."""
    import build123d
    import OCP

    from .. import __version__
    h = hashlib.sha256(__version__.encode())
    for module in (build123d, OCP):  # both imported already: no file is read for them
        h.update(f"{module.__name__} {getattr(module, '__version__', '?')}".encode())
    here = Path(__file__).resolve().parent.parent / "mates"
    for path in sorted(here.rglob("*.py")):  # mate types, fits, feature macros, placement
        h.update(path.relative_to(here).as_posix().encode() + b"\0" + path.read_bytes())
    # the transmission helpers (gears, racks, threads) and the gear library they call
    from importlib.metadata import PackageNotFoundError, version
    gearing = Path(__file__).resolve().parent / "gearing.py"
    h.update(b"gearing.py\0" + gearing.read_bytes())
    try:
        h.update(f"py_gearworks {version('py_gearworks')}".encode())
    except PackageNotFoundError:
        h.update(b"py_gearworks ?")
    return h.hexdigest()


def mutable(value: Any) -> bool:
    """A plain value a part could change in place (a list, dict or set, or one inside a tuple)."""
    if isinstance(value, (list, dict, set)):
        return True
    return isinstance(value, (tuple, frozenset)) and any(mutable(v) for v in value)


def plain(value: Any) -> bool:
    """A value a key may hash by ``repr``: numbers, strings, None and containers of them."""
    if isinstance(value, _PLAIN):
        return True
    if isinstance(value, (tuple, list, frozenset, set)):
        return all(plain(v) for v in value)
    if isinstance(value, dict):
        return all(plain(k) and plain(v) for k, v in value.items())
    return False


@dataclass
class ModuleScan:
    """What :func:`scan_module` found in the program's module body.

    Attributes:
        defs: first line of a ``def`` (its first decorator's line when decorated) -> the
            function's node, to cut its text without line numbers.
        opaque: ``(line, what)`` of each module-level statement the keys cannot see through.
        doc: 1-based lines of the module docstring.
    """

    defs: dict[int, ast.FunctionDef] = field(default_factory=dict)
    opaque: list[tuple[int, str]] = field(default_factory=list)
    doc: set[int] = field(default_factory=set)


def _names_only(target: ast.expr) -> bool:
    if isinstance(target, ast.Name):
        return True
    if isinstance(target, (ast.Tuple, ast.List)):
        return all(_names_only(t) for t in target.elts)
    return False


def _opaque(stmt: ast.stmt) -> str | None:
    """Why a module-level statement hides state from the keys, or None when it does not."""
    if isinstance(stmt, (ast.FunctionDef, ast.ClassDef, ast.Import, ast.Pass)):
        return None
    if isinstance(stmt, ast.ImportFrom):
        if any(a.name == "*" for a in stmt.names) and stmt.module != "procedura_brep.program":
            return f"from {stmt.module} import *"
        return None
    if isinstance(stmt, ast.Assign):
        return None if all(_names_only(t) for t in stmt.targets) else "an assignment into an object"
    if isinstance(stmt, (ast.AnnAssign, ast.AugAssign)):
        return None if isinstance(stmt.target, ast.Name) else "an assignment into an object"
    if isinstance(stmt, ast.Expr):
        v = stmt.value
        if isinstance(v, ast.Constant) and isinstance(v.value, str):
            return None
        if isinstance(v, ast.Call) and isinstance(v.func, ast.Name) and v.func.id in DECLARATION_CALLS:
            return None
        return "a module-level expression run for its side effect"
    if isinstance(stmt, (ast.For, ast.While, ast.If)):  # a loop of frames(...) or mate(...)
        if isinstance(stmt, ast.For) and not _names_only(stmt.target):
            return "a loop assigning into an object"
        return next((why for s in stmt.body + stmt.orelse if (why := _opaque(s))), None)
    return f"a module-level {type(stmt).__name__.lower()} statement"


def scan_module(source: str, tree: ast.Module | None = None) -> ModuleScan:
    """Index the program's functions and list its opaque module-level statements (``tree``:
    ``source`` already parsed)."""
    scan = ModuleScan()
    if tree is None:
        try:
            tree = ast.parse(source)
        except SyntaxError:
            scan.opaque.append((0, "a syntax error"))
            return scan
    body = tree.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        scan.doc = set(range(body[0].lineno, (body[0].end_lineno or body[0].lineno) + 1))
    for stmt in body:
        why = _opaque(stmt)
        if why:
            scan.opaque.append((stmt.lineno, why))
    # the functions a key may name: module-level defs and methods (a def nested in a function
    # is part of its text; one under an ``if`` is opaque code, and keyed by its lines)
    todo: list[ast.stmt] = list(body)
    while todo:
        node = todo.pop()
        if isinstance(node, ast.FunctionDef):
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            scan.defs.setdefault(first, node)
        elif isinstance(node, ast.ClassDef):
            todo += node.body
    return scan


@cache
def _api_object(name: str) -> Any:
    """What ``from procedura_brep.program import *`` binds as ``name`` (or a sentinel)."""
    import procedura_brep.program as api
    try:
        return getattr(api, name)
    except AttributeError:
        return _MISSING


def _is_part_decorator(node: ast.expr) -> bool:
    call = node.func if isinstance(node, ast.Call) else node
    return isinstance(call, ast.Name) and call.id == "part"


class _Keyer:
    """One key computation: the module's globals, params, source lines and scan."""

    def __init__(self, source: str, glb: dict[str, Any], params: dict[str, Any],
                 scan: ModuleScan) -> None:
        self.source, self.lines = source, source.splitlines()
        self.glb, self.params, self.scan = glb, params, scan
        self.volatile = False  # the current part's key hashed a value a part could mutate

    def value(self, text: str, value: Any, out: list[str]) -> None:
        out.append(f"{text}={value!r}")
        self.volatile |= mutable(value)

    def state(self, fn: Any, out: list[str]) -> bool:
        ok = function_state(fn, out)
        if ok:
            self.volatile |= mutable(_state_values(fn))
        return ok

    def text(self, code: types.CodeType, *, skip_part: bool = False) -> str:
        """A function's text without line numbers: decorators (but ``@part`` when
        ``skip_part``: its options are hashed by value) and ``def`` to the last line."""
        node = self.scan.defs.get(code.co_firstlineno)
        if node is None or node.name != code.co_name:  # a lambda
            lines = [ln for _, _, ln in code.co_lines() if ln]
            last = max(lines, default=code.co_firstlineno)
            return "\n".join(self.lines[code.co_firstlineno - 1:last])
        out = [ast.get_source_segment(self.source, d) or ast.dump(d)
               for d in node.decorator_list if not (skip_part and _is_part_decorator(d))]
        out.append("\n".join(self.lines[node.lineno - 1:node.end_lineno]))
        return "\n".join(out)

    def library(self, name: str, obj: Any) -> bool:
        """``obj`` is what the program API or ``math`` binds (an import, kept as imported)."""
        return _is_library(name, obj)

    def program_fn(self, obj: Any) -> types.CodeType | None:
        code = getattr(obj, "__code__", None)
        if isinstance(code, types.CodeType) and code.co_filename == "<program>":
            return code
        return None

    def walk(self, code: types.CodeType, seen: set[str], out: list[str]) -> bool:
        """Append what ``code`` reads to ``out``; False when it reads module state that cannot
        be hashed (an object built at module level, such as ``ARM = [Box(...)]``)."""
        ok = True
        for const in code.co_consts:
            if isinstance(const, types.CodeType):
                ok &= self.walk(const, seen, out)
        for n in sorted(set(code.co_names)):
            if n in seen:
                continue
            seen.add(n)
            if n in self.params:
                self.value(f"param {n}", self.params[n], out)
                continue
            if n not in self.glb:
                continue  # a builtin or an attribute name
            obj = self.glb[n]
            fn_code = self.program_fn(obj)
            if fn_code is not None:
                out.append(f"fn {n}:\n{self.text(fn_code)}")
                ok &= self.state(obj, out)
                ok &= self.walk(fn_code, seen, out)
            elif plain(obj):
                self.value(f"value {n}", obj, out)  # a module-level constant outside the params
            elif self.library(n, obj):
                continue  # build123d, math or the declarations, as imported
            elif isinstance(obj, type) and obj.__module__ == self.glb.get("__name__"):
                ok &= self.walk_class(n, obj, seen, out)
            else:
                ok = False
        return ok

    def walk_class(self, n: str, cls: type, seen: set[str], out: list[str]) -> bool:
        """A class the program defines: its methods, plain attributes and base classes."""
        ok = True
        out.append(f"class {n}({', '.join(b.__qualname__ for b in cls.__bases__)})")
        for base in cls.__bases__:
            if base.__module__ == self.glb.get("__name__"):
                if base.__qualname__ not in seen:
                    seen.add(base.__qualname__)
                    ok &= self.walk_class(base.__qualname__, base, seen, out)
            elif not (base.__module__ == "builtins" or self.library(base.__name__, base)):
                ok = False
        for attr, val in sorted(vars(cls).items()):
            code = self.program_fn(val)
            if code is not None:
                out.append(f"method {attr}:\n{self.text(code)}")
                ok &= self.state(val, out)
                ok &= self.walk(code, seen, out)
            elif attr in ("__module__", "__qualname__", "__doc__", "__dict__", "__weakref__",
                          "__firstlineno__", "__static_attributes__"):
                continue
            elif plain(val):
                self.value(f"attr {attr}", val, out)
            else:
                ok = False
        return ok


def _state_values(fn: Any) -> tuple[Any, ...]:
    state = [getattr(fn, "__defaults__", None), getattr(fn, "__kwdefaults__", None)]
    for cell in getattr(fn, "__closure__", None) or ():
        try:
            state.append(cell.cell_contents)
        except ValueError:  # an empty cell
            state.append(None)
    return tuple(state)


def function_state(fn: Any, out: list[str]) -> bool:
    """Hash a program function's default arguments and closure cells (evaluated when it was
    defined, so not visible in its source); False when one is not a plain value."""
    shown = _shown(_state_values(fn))
    if shown is None:
        return False
    out.append(f"state {shown}")
    return True


def _shown(value: Any) -> str | None:
    """How a key hashes a default or closure value: ``repr`` of a plain one, ``lib NAME`` of
    library code (:func:`_library_value`), tuples and dicts of those item by item; None for
    anything else (the part then gets no key)."""
    if plain(value):
        return repr(value)
    if isinstance(value, tuple):
        items = [_shown(v) for v in value]
        return None if None in items else f"({', '.join(items)})"  # type: ignore[arg-type]
    if isinstance(value, dict):
        pairs = [(repr(k), _shown(v)) for k, v in value.items()]
        return None if any(v is None for _, v in pairs) else "{" + ", ".join(f"{k}: {v}" for k, v in pairs) + "}"
    return _library_value(value)


def _library_value(value: Any) -> str | None:
    """``lib NAME`` when ``value`` is what the program API (build123d, the gearing helpers, the
    declarations) or ``math`` binds to NAME: library code, which :func:`engine_digest` covers
    (a helper bound as a default, ``maker=lead_screw``, so that a part of the same name cannot
    hide it); else None."""
    name = getattr(value, "__name__", None)
    if not isinstance(name, str) or name.startswith("_"):
        return None
    return f"lib {name}" if _is_library(name, value) else None


def _is_library(name: str, obj: Any) -> bool:
    """``obj`` is what the program API or ``math`` binds to ``name`` (or ``math`` itself)."""
    if obj is math or getattr(math, name, _MISSING) is obj:
        return True
    return _api_object(name) is obj


def _decl_options(decl: PartDecl) -> str:
    opts = {"detail": decl.detail, "material": decl.material, "description": decl.description,
            "pieces": decl.pieces, "mass": decl.mass, "hollow": decl.hollow}
    return "options " + repr({k: v for k, v in opts.items() if k not in UNKEYED_OPTIONS})


def _mate_rows(mates: list[dict[str, Any]], only: set[str] | None) -> dict[str, list[str]]:
    """Part name -> one row per mate that adds a feature to it, in declaration order."""
    rows: dict[str, list[str]] = {}
    for m in mates:
        d = m["decl"]
        ends = [(r, f) for r, f in (("child", "fc"), ("parent", "fp"))
                if only is None or getattr(d, r) in only]
        if not ends:
            continue
        common = repr((m["type"].name, m["d"], sorted(m["fit"].as_dict().items()),
                       sorted(m["options"].items())))
        for role, frame in ends:
            rows.setdefault(getattr(d, role), []).append(
                f"mate {role} {common} {np.round(m[frame], 12).tolist()!r}")
    return rows


def part_keys(source: str, reg: Registry, params: dict[str, Any], mates: list[dict[str, Any]],
              glb: dict[str, Any], *, scan: ModuleScan | None = None,
              only: set[str] | None = None, volatile: set[str] | None = None) -> dict[str, str]:
    """The cache key of every declared part (see the module docstring); ``""`` for a part that
    reads module-level state the key cannot cover (it is rebuilt on every compile).

    Args:
        scan: :func:`scan_module` of ``source`` (computed when not given).
        only: key these parts only.
        volatile: filled with the parts whose key hashed a value a running part could change
            in place (a list, dict or set): only those need keying again after the parts ran.
    """
    scan = scan_module(source) if scan is None else scan
    keyer = _Keyer(source, glb, params, scan)
    whole: list[str] = []
    shadowed = [n for n in DECLARATION_CALLS if n in glb and not keyer.library(n, glb[n])]
    if scan.opaque or shadowed:
        whole = ["module:\n" + "\n".join(ln for i, ln in enumerate(keyer.lines, 1)
                                         if i not in scan.doc)]
    rows = _mate_rows(mates, only)
    keys: dict[str, str] = {}
    for name, decl in reg.parts.items():
        if only is not None and name not in only:
            continue
        code = decl.fn.__code__
        parts = [engine_digest(), _decl_options(decl),
                 _unnamed(keyer.text(code, skip_part=True), code.co_name), *whole]
        keyer.volatile = False
        if not (keyer.state(decl.fn, parts) & keyer.walk(code, set(), parts)):
            keys[name] = ""  # reads module state that is not hashable: never cached
            continue
        if keyer.volatile and volatile is not None:
            volatile.add(name)
        parts += rows.get(name, [])
        keys[name] = hashlib.sha256("\n".join(parts).encode()).hexdigest()
    return keys


def _unnamed(text: str, name: str) -> str:
    """A part function's text with its own name left out of its ``def`` line: the name reaches
    no solid (a function that calls itself reads its name, which its key then hashes)."""
    return re.sub(rf"\bdef\s+{re.escape(name)}\s*\(", "def (", text, count=1)


def params_read(code: types.CodeType, glb: dict[str, Any], params: dict[str, Any],
                seen: set[str] | None = None) -> list[str]:
    """The params a function reads, directly or through program functions it calls."""
    seen = set() if seen is None else seen
    found: list[str] = []
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            found += params_read(const, glb, params, seen)
    for n in code.co_names:
        if n in seen:
            continue
        seen.add(n)
        if n in params:
            found.append(n)
            continue
        fn_code = getattr(glb.get(n), "__code__", None)
        if isinstance(fn_code, types.CodeType) and fn_code.co_filename == "<program>":
            found += params_read(fn_code, glb, params, seen)
    return sorted(set(found))
