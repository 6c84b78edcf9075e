"""The per-part compile cache: a content-addressed store of final part solids.

Each part's final solid (its function's result with every mate feature applied, in part-local
coordinates) is stored under its key (:mod:`procedura_brep.program.cachekeys` says what a key
hashes: the part's own code, the helpers, classes, params and constants it reaches, and the
mates that add features to it). A compile loads the solid of every part whose key is stored
and runs only the others, so an edit, or a splice of one more part, rebuilds the parts whose
inputs changed and nothing else.

The store is a folder of ``<key>.brep`` files (OCCT binary BRep), each with a ``<key>.fig``
beside it: the solid's size figures (:class:`~procedura_brep.program.caps.Figures`), measured
by the parent when it stores the solid, so a compile that hits the cache checks its caps
without reading the BRep back. The sandbox child only reads the store; the parent writes the
solids the child returned (:func:`store_model`).
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

from ..paths import write_atomic

KEY_RE = re.compile(r"[0-9a-f]{64}")


def valid_key(key: object) -> bool:
    """A cache key is a sha256 hex digest, nothing else (it becomes a file name)."""
    return isinstance(key, str) and KEY_RE.fullmatch(key) is not None


def load(cache_dir: str | os.PathLike[str] | int, key: str, suffix: str = ".brep") -> bytes | None:
    """The cached BRep (or, with ``suffix=".fig"``, its figures' JSON) for ``key``, or None.
    ``cache_dir`` may be an open directory fd (the sandbox child reads the cache through one
    after dropping privileges)."""
    if not valid_key(key) or suffix not in (".brep", ".fig"):
        return None
    name = f"{key}{suffix}"
    try:
        if isinstance(cache_dir, int):
            fd = os.open(name, os.O_RDONLY, dir_fd=cache_dir)
            with os.fdopen(fd, "rb") as fh:
                return fh.read()
        return (Path(cache_dir) / name).read_bytes()
    except OSError:
        return None


def load_figures(cache_dir: str | os.PathLike[str] | int, key: str) -> dict[str, Any] | None:
    """The figures stored beside ``key``'s BRep (:func:`store_model`), or None when there are
    none or they do not read as figures (:func:`~procedura_brep.program.caps.figures_from_json`;
    the caller then measures the solid itself)."""
    from .caps import figures_from_json
    raw = load(cache_dir, key, ".fig")
    if raw is None or len(raw) > 4096:
        return None
    try:
        d = json.loads(raw)
    except ValueError:
        return None
    return d if figures_from_json(d) is not None else None


def has(cache_dir: str | os.PathLike[str], key: str) -> bool:
    """Whether ``key`` has a stored BRep (without reading it)."""
    return valid_key(key) and (Path(cache_dir) / f"{key}.brep").is_file()


def store(cache_dir: str | os.PathLike[str], key: str, data: bytes,
          figures: dict[str, Any] | None = None) -> None:
    """Store ``data`` (and its ``figures``, if given) under ``key`` atomically (safe with
    concurrent writers). The figures are written first, so a BRep never lacks them for long.

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
        if figures is not None:
            write_atomic(folder / f"{key}.fig", json.dumps(figures).encode(), mode=0o644)
        write_atomic(target, data, mode=0o644)  # readable by the unprivileged sandbox child


def store_model(cache_dir: str | os.PathLike[str], model: Any, limits: Any = None) -> int:
    """Store every part of a compiled model that carries a key; returns how many were new.
    A painted part is stored unpainted (its colour blocks are cut again on every compile).

    Each new solid is measured here, in the parent (:func:`~procedura_brep.program.caps.measure`,
    bounded like the child's own), and its figures are stored beside it when the measure
    completed under ``limits`` (default ``config.SANDBOX``): a partial count, stopped at a
    cap, is never stored as a figure.
    """
    from .. import kernel
    from ..config import SANDBOX
    from . import caps
    limits = limits or SANDBOX
    new = 0
    for p in model.parts:
        if p.cache_key and not has(cache_dir, p.cache_key):
            data = getattr(p, "unpainted", b"") or p.brep
            figures = None
            try:
                shape = p.local_shape() if data is p.brep else kernel.read_brep(data)
                fig = caps.measure(shape, limits)
                if caps.part_violation(p.name, fig, limits) is None:
                    figures = caps.figures_json(fig)
            except Exception:  # noqa: BLE001 - OCCT raises its own types: store no figures
                figures = None
            store(cache_dir, p.cache_key, data, figures)
            new += 1
    return new
