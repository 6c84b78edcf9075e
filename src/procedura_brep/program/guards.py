"""Guards around the CAD kernel for untrusted programs (used inside the sandbox child and,
once, in the worker before it forks).

* :func:`harden_kernel`: build123d's font resolution refuses font files and path-like names;
  the lazy imports of ``Text`` are done before a child drops privileges.
* :func:`builder_open`: whether a build123d builder context is open in the current context.
* :func:`class_tables` / :func:`changed_tables`: a fingerprint of build123d's mutable
  class-level tables, and what a program changed in them.
"""

from __future__ import annotations

from typing import Any

#: Codecs imported in the worker before any child drops privileges (font tables use mac_roman
#: and UTF-16; the rest are what programs' own ``str.encode`` calls plausibly name).
CODECS = ("mac_roman", "utf_16", "utf_16_be", "utf_16_le", "utf_32", "latin_1", "ascii",
          "cp1252", "utf_8")


def harden_kernel() -> None:
    """Defence in depth, applied once in the worker (the zygote) before any program runs.

    * Fonts: every text path of build123d (``Text``, ``Compound.make_text``, positional or
      ``**{"font" + "_path": p}``) resolves its font through ``Compound.resolve_font``; the
      wrapper refuses any font file and any font name that looks like a path, so programs use
      the built-in and system fonts by family name only.
    * Lazy imports: the common codecs (:data:`CODECS`) are imported and one ``Text`` is made, so
      what text handling loads on first use (``encodings.mac_roman``, font tables)
      is in memory before a child drops privileges: as its own uid, the child often cannot
      read the interpreter's standard library (here it lives under ``/root``), which is why
      plain ``Text("x", 5)`` failed with ``LookupError: unknown encoding: mac_roman``.
    """
    import importlib
    for codec in CODECS:
        importlib.import_module(f"encodings.{codec}")
    from build123d import Compound, Text
    original = Compound.resolve_font
    if getattr(original, "procedura_guard", False):
        return

    def resolve_font(font: str = "Arial", font_path: Any = None, *args: Any, **kwargs: Any) -> Any:
        if font_path is not None:
            raise ValueError("programs may not load font files (font_path); use a font name "
                             "such as 'Arial' or the default")
        if not isinstance(font, str) or any(c in font for c in "/\\~") or font.startswith("."):
            raise ValueError(f"font {font!r:.60} must be a font family name, not a path")
        return original(font, None, *args, **kwargs)

    resolve_font.procedura_guard = True  # type: ignore[attr-defined]  # a marker set on the function
    Compound.resolve_font = staticmethod(resolve_font)  # type: ignore[method-assign]  # the guard wraps build123d's
    Text("x", 5)


def builder_open() -> bool:
    """True when a build123d builder context (``with BuildPart():`` ...) is open."""
    try:
        from build123d.build_common import _build_scope
    except ImportError:  # pragma: no cover - an older build123d
        return False
    return _build_scope.get() is not None


Fingerprint = tuple[int, int, tuple[tuple[str, int], ...]]


def _fingerprint(val: Any) -> Fingerprint | None:
    if isinstance(val, dict):
        return (id(val), len(val), tuple((repr(k), id(v)) for k, v in val.items()))
    if isinstance(val, (list, set)):
        return (id(val), len(val), tuple(("", id(v)) for v in val))
    return None


def _tables() -> dict[tuple[str, str], tuple[Any, str]]:
    """Every public mutable class-level table of build123d (and exported container):
    ``(owner name, attr) -> (owner object, attr)``. Programs cannot reach ``_`` names nor add
    class attributes (the policy), so this set is fixed once build123d is imported."""
    import build123d
    out: dict[tuple[str, str], tuple[Any, str]] = {}
    for n in build123d.__all__:
        obj = getattr(build123d, n, None)
        if isinstance(obj, type):
            for klass in obj.__mro__:
                if klass.__module__.startswith("build123d"):
                    for attr, val in vars(klass).items():
                        if not attr.startswith("_") and _fingerprint(val) is not None:
                            out[(klass.__qualname__, attr)] = (klass, attr)
        elif _fingerprint(obj) is not None:
            out[("build123d", n)] = (build123d, n)
    return out


_TABLES: list[dict[tuple[str, str], tuple[Any, str]]] = []
_BASELINE: list[dict[tuple[str, str], Fingerprint | None]] = []


def class_tables() -> dict[tuple[str, str], Fingerprint | None]:
    """A fingerprint of each table (identity, size, identity of every item)."""
    if not _TABLES:
        _TABLES.append(_tables())
    return {key: _fingerprint(getattr(owner, attr, None)) for key, (owner, attr) in _TABLES[0].items()}


def baseline() -> dict[tuple[str, str], Fingerprint | None]:
    """The fingerprint taken once in the worker before it forks (every child starts from the
    same tables)."""
    if not _BASELINE:
        _BASELINE.append(class_tables())
    return _BASELINE[0]


def changed_tables(before: dict[tuple[str, str], Fingerprint | None]) -> list[str]:
    """The tables whose fingerprint differs from ``before``, as ``Owner.attr``."""
    after = class_tables()
    return sorted(f"{o}.{a}" for (o, a) in before if before[(o, a)] != after.get((o, a)))
