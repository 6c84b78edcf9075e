"""The program layer: format, parse, param edits, sandboxed compile, and the program API.

``from procedura_brep.program import *`` (the first line of every program) gives build123d's
modelling vocabulary, ``math``, and :func:`material`, :func:`part`, :func:`frames`, :func:`mate`. Names are
resolved lazily (PEP 562) so that importing this package for parsing or editing does not pay
build123d's multi-second import.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

#: build123d names a program must not see: anything that reads or writes files or meshes,
#: or registers fonts from the file system.
_DENY_SUBSTRINGS = ("import", "export", "Export", "Mesher", "Import", "FontManager", "fonts")
_API = ("material", "part", "paint", "frames", "mate", "couple")
#: Transmission geometry (:mod:`.gearing`): gears, racks, lead screws, pulleys.
_GEARING = ("spur_gear", "ring_gear", "rack", "lead_screw", "lead_nut", "pulley")
#: The same helpers as ``make_<name>``: a part named like a helper (``def rack():``) hides the
#: helper's name inside the program, never these.
GEARING_ALIASES = {f"make_{n}": n for n in _GEARING}
_LAZY = {"compile_source": ".sandbox", "Worker": ".sandbox", "CompileOptions": ".sandbox",
         "parse_sections": ".sections", "Sections": ".sections", "set_params": ".edit"}


@lru_cache(maxsize=1)
def _build123d_names() -> tuple[str, ...]:
    import build123d
    return tuple(n for n in build123d.__all__ if not any(s in n for s in _DENY_SUBSTRINGS))


@lru_cache(maxsize=1)
def _submodules() -> frozenset[str]:
    import pkgutil
    return frozenset(m.name for m in pkgutil.iter_modules(__path__))


def build123d_names() -> list[str]:
    """The build123d names re-exported to programs (build123d's ``__all__`` minus file I/O)."""
    return list(_build123d_names())


def __getattr__(name: str) -> Any:
    if name == "__all__":
        return [*_API, *_GEARING, *GEARING_ALIASES, "math", *build123d_names()]
    if name in _API:
        from . import api
        return getattr(api, name)
    if name in _GEARING or name in GEARING_ALIASES:
        from . import gearing
        return getattr(gearing, GEARING_ALIASES.get(name, name))
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    if name == "math":
        import math
        return math
    if name in _submodules():  # ``from . import caps``: the import system loads the module
        raise AttributeError(f"module {__name__!r} has no attribute {name!r} (yet)")
    if not name.startswith("_"):
        if name in _build123d_names():
            import build123d
            return getattr(build123d, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
