"""The per-part compile cache: a content-addressed store of final part solids.

Each part's final solid (its function's result with every mate feature applied, in part-local
coordinates) is stored under its key (:mod:`procedura_brep.program.keys` says what a key
hashes: the part's own code, the helpers, classes, params and constants it reaches, and the
mates that add features to it). A compile loads the solid of every part whose key is stored
and runs only the others, so an edit, or a splice of one more part, rebuilds the parts whose
inputs changed and nothing else.

The store is a folder of ``<key>.brep`` files (OCCT binary BRep). The sandbox child only reads
it; the parent writes the solids the child returned (:func:`store_model`).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

from ..paths import write_atomic

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
    """Store every part of a compiled model that carries a key; returns how many were new.
    A painted part is stored unpainted (its colour blocks are cut again on every compile)."""
    new = 0
    for p in model.parts:
        if p.cache_key and load(cache_dir, p.cache_key) is None:
            store(cache_dir, p.cache_key, getattr(p, "unpainted", b"") or p.brep)
            new += 1
    return new
