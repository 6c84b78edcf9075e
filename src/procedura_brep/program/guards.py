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
    * Lazy imports: the common codecs (:data:`CODECS`) are imported and one ``Text`` is made, so what text handling loads on first use (``encodings.mac_roman``, font tables)
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

    resolve_font.procedura_guard = True  # type: ignore[attr-defined]
    Compound.resolve_font = staticmethod(resolve_font)  # type: ignore[method-assign]
    Text("x", 5)


def builder_open() -> bool:
    """True when a build123d builder context (``with BuildPart():`` ...) is open."""
    try:
        from build123d.build_common import _build_scope
    except ImportError:  # pragma: no cover - an older build123d
        return False
    return _build_scope.get() is not None


def class_tables() -> dict[tuple[str, str], tuple[int, int, tuple[tuple[Any, int], ...]]]:
    """A fingerprint of build123d's mutable class-level tables (and exported containers):
    identity, size and the identity of every item."""
    import build123d
    out: dict[tuple[str, str], tuple[int, int, tuple[tuple[Any, int], ...]]] = {}

    def add(owner: str, attr: str, val: Any) -> None:
        if isinstance(val, dict):
            items = tuple((repr(k), id(v)) for k, v in val.items())
        elif isinstance(val, (list, set)):
            items = tuple(("", id(v)) for v in val)
        else:
            return
        out[(owner, attr)] = (id(val), len(val), items)

    for n in build123d.__all__:
        obj = getattr(build123d, n, None)
        if isinstance(obj, type):
            for klass in obj.__mro__:
                if klass.__module__.startswith("build123d"):
                    for attr, val in vars(klass).items():
                        add(klass.__qualname__, attr, val)
        else:
            add("build123d", n, obj)
    return out


def changed_tables(before: dict[Any, Any]) -> list[str]:
    after = class_tables()
    return sorted(f"{o}.{a}" for (o, a) in set(before) | set(after) if before.get((o, a)) != after.get((o, a)))
