"""The per-part compile cache: keys, and a content-addressed store of final part solids.

A part's key hashes everything its final solid depends on: its function's source, the source
of every program function and class it uses (transitively), the values of the params and other
plain module-level constants those read, the text of the header and helpers sections, and for
every mate that touches it the mate's type, nominal value, fit, options and this part's frame.
A part that reads any other module-level object (``ARM = [Box(...)]``, built from params the
key would not see), directly, through a default argument or through a closure, gets no key and is rebuilt on every compile; the compiler also recomputes
the keys after the parts ran and drops any that changed (a part that mutated a value another
part reads). Editing one part, or adding a part, changes only the keys of that part and of the
partners whose features change; every other part is loaded from the cache instead of rebuilt.

The store is a folder of ``<key>.brep`` files (OCCT binary BRep). The sandbox child only reads
it; the parent writes the solids the child returned (:func:`store_model`).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import types
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ..paths import write_atomic
from .registry import Registry
from .sections import Sections


@lru_cache(maxsize=1)
def _engine_digest() -> str:
    """Hash of the code that turns a part into its final solid (invalidates on upgrades)."""
    from .. import __version__
    h = hashlib.sha256(__version__.encode())
    here = Path(__file__).resolve().parent.parent / "mates"
    for name in ("features.py", "fits.py", "vocabulary.py"):
        h.update((here / name).read_bytes())
    return h.hexdigest()


def _function_lines(source_lines: list[str], code: types.CodeType) -> str:
    lines = [ln for _, _, ln in code.co_lines() if ln]
    last = max(lines, default=code.co_firstlineno)
    return "\n".join(source_lines[code.co_firstlineno - 1:last])


_PLAIN = (int, float, bool, str, bytes, type(None))


def _plain(value: Any) -> bool:
    if isinstance(value, _PLAIN):
        return True
    if isinstance(value, (tuple, list, frozenset, set)):
        return all(_plain(v) for v in value)
    if isinstance(value, dict):
        return all(_plain(k) and _plain(v) for k, v in value.items())
    return False


def _api_object(name: str) -> Any:
    """The object the program API exports as ``name`` (what ``import *`` bound), or a sentinel."""
    import procedura_brep.program as api
    try:
        return getattr(api, name)
    except AttributeError:
        return _MISSING


_MISSING = object()


def _walk(code: types.CodeType, glb: dict[str, Any], params: dict[str, Any], source_lines: list[str],
          seen: set[str], out: list[str]) -> bool:
    """Append what ``code`` reads to ``out``; False when it reads module state that cannot be
    hashed (an object built at module level, such as ``ARM = [Box(...)]``): such a part gets no
    key and is never cached."""
    ok = True
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            ok &= _walk(const, glb, params, source_lines, seen, out)
    for n in sorted(names):
        if n in seen:
            continue
        seen.add(n)
        if n in params:
            out.append(f"param {n}={params[n]!r}")
            continue
        if n not in glb:
            continue  # a builtin or an attribute name
        obj = glb[n]
        fn_code = getattr(obj, "__code__", None)
        if isinstance(fn_code, types.CodeType) and fn_code.co_filename == "<program>":
            out.append(f"fn {n}:\n{_function_lines(source_lines, fn_code)}")
            ok &= _function_state(obj, out)
            ok &= _walk(fn_code, glb, params, source_lines, seen, out)
        elif _plain(obj):
            out.append(f"value {n}={obj!r}")  # a module-level constant outside the params
        elif obj is _api_object(n):
            continue  # build123d, math or the declarations, as imported
        elif isinstance(obj, type) and obj.__module__ == glb.get("__name__"):
            ok &= _walk_class(n, obj, glb, params, source_lines, seen, out)
        else:
            ok = False
    return ok


def _function_state(fn: Any, out: list[str]) -> bool:
    """Hash a program function's default arguments and closure cells (evaluated when it was
    defined, so not visible in its source); False when one is not a plain value."""
    state = [getattr(fn, "__defaults__", None), getattr(fn, "__kwdefaults__", None)]
    for cell in getattr(fn, "__closure__", None) or ():
        try:
            state.append(cell.cell_contents)
        except ValueError:  # an empty cell
            state.append(None)
    if not all(_plain(v) for v in state):
        return False
    out.append(f"state {state!r}")
    return True


def _walk_class(n: str, cls: type, glb: dict[str, Any], params: dict[str, Any],
                source_lines: list[str], seen: set[str], out: list[str]) -> bool:
    """A class the program defines: its methods' source and its plain attributes."""
    ok = True
    out.append(f"class {n}")
    for attr, val in sorted(vars(cls).items()):
        code = getattr(val, "__code__", None)
        if isinstance(code, types.CodeType) and code.co_filename == "<program>":
            out.append(f"method {attr}:\n{_function_lines(source_lines, code)}")
            ok &= _walk(code, glb, params, source_lines, seen, out)
        elif attr.startswith("__") and attr in ("__module__", "__qualname__", "__doc__", "__dict__",
                                                "__weakref__", "__firstlineno__", "__static_attributes__"):
            continue
        elif _plain(val):
            out.append(f"attr {attr}={val!r}")
        else:
            ok = False
    return ok


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


def _docstring_lines(source: str) -> set[int]:
    """1-based lines of the module docstring (it cannot change any geometry)."""
    import ast
    try:
        body = ast.parse(source).body
    except SyntaxError:
        return set()
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
            and isinstance(body[0].value.value, str):
        return set(range(body[0].lineno, (body[0].end_lineno or body[0].lineno) + 1))
    return set()


def part_keys(source: str, sections: Sections, reg: Registry, params: dict[str, Any],
              mates: list[dict[str, Any]], glb: dict[str, Any]) -> dict[str, str]:
    """The cache key of every declared part (see the module docstring); ``""`` for a part that
    reads module-level state the key cannot cover (it is rebuilt on every compile)."""
    lines = source.splitlines()
    # Anything else a part may read (program classes, objects built at module level) is covered
    # conservatively: the module's text outside the params, parts, frames and assembly sections.
    header = lines[:sections.starts["params"] - 1]
    doc = _docstring_lines(source)
    context = "\n".join([ln for i, ln in enumerate(header, 1) if i not in doc]
                        + lines[sections.starts["helpers"]:sections.starts["parts"] - 1])
    keys: dict[str, str] = {}
    for name, decl in reg.parts.items():
        parts = [_engine_digest(), f"part {name}", context]
        code = decl.fn.__code__
        parts.append(_function_lines(lines, code))
        if not (_function_state(decl.fn, parts) & _walk(code, glb, params, lines, set(), parts)):
            keys[name] = ""  # reads module state that is not hashable: never cached
            continue
        for m in mates:
            d = m["decl"]
            for role, frame in (("child", "fc"), ("parent", "fp")):
                if getattr(d, role) == name:
                    parts.append(json.dumps({
                        "mate": d.name, "role": role, "type": m["type"].name, "d": m["d"],
                        "fit": m["fit"].as_dict(), "options": m["options"],
                        "frame": np.round(m[frame], 12).tolist()}, sort_keys=True, default=str))
        keys[name] = hashlib.sha256("\n".join(parts).encode()).hexdigest()
    return keys


KEY_RE = re.compile(r"[0-9a-f]{64}")


def valid_key(key: object) -> bool:
    """A cache key is a sha256 hex digest, nothing else (it becomes a file name)."""
    return isinstance(key, str) and KEY_RE.fullmatch(key) is not None


def load(cache_dir: str | os.PathLike[str] | int, key: str) -> bytes | None:
    """The cached BRep for ``key``, or None. ``cache_dir`` may be an open directory fd (the
    sandbox child reads the cache through one after dropping privileges)."""
    if not valid_key(key):
        return None
    name = f"{key}.brep"
    try:
        if isinstance(cache_dir, int):
            fd = os.open(name, os.O_RDONLY, dir_fd=cache_dir)
            with os.fdopen(fd, "rb") as fh:
                return fh.read()
        return (Path(cache_dir) / name).read_bytes()
    except OSError:
        return None


def store(cache_dir: str | os.PathLike[str], key: str, data: bytes) -> None:
    """Store ``data`` under ``key`` atomically (safe with concurrent writers).

    Raises:
        ValueError: ``key`` is not a sha256 hex digest (it would name a file elsewhere).
    """
    if not valid_key(key):
        raise ValueError(f"cache key {key!r:.80} is not a sha256 hex digest")
    folder = Path(cache_dir)
    folder.mkdir(parents=True, exist_ok=True)
    folder.chmod(0o755)
    target = folder / f"{key}.brep"
    if not target.exists():
        write_atomic(target, data, mode=0o644)  # readable by the unprivileged sandbox child


def store_model(cache_dir: str | os.PathLike[str], model: Any) -> int:
    """Store every part of a compiled model that carries a key; returns how many were new."""
    new = 0
    for p in model.parts:
        if p.cache_key and load(cache_dir, p.cache_key) is None:
            store(cache_dir, p.cache_key, p.brep)
            new += 1
    return new
