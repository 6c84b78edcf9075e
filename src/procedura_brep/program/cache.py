"""The per-part compile cache: a content-addressed store of final part solids.

Each part's final solid (its function's result with every mate feature applied, in part-local
coordinates) is stored under its key (:mod:`procedura_brep.program.cachekeys` says what a key
hashes: the part's own code, the helpers, classes, params and constants it reaches, and the
mates that add features to it). A compile loads the solid of every part whose key is stored
and runs only the others, so an edit, or a splice of one more part, rebuilds the parts whose
inputs changed and nothing else.

The store outlives the process (:func:`persistent_dir`): a ``build`` leaves its parts there,
and a ``check``, ``render`` or ``edit`` of the same program right after loads every one
instead of compiling it again, whether or not a warm server (``procedura-brep serve``) runs.
Its folder is per code digest (:func:`procedura_brep.program.server.code_digest`: this
package's sources, the interpreter, build123d's version), so a changed install never reads a
solid an older one made (a mate feature's code is ours, not the key's); ``PROCEDURA_BREP_CACHE``
names another folder or turns it off.

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


#: The environment variable naming the persistent store's folder, or ``off``.
ENV_CACHE = "PROCEDURA_BREP_CACHE"
#: Digest folders of other code versions unused this long are removed (seconds).
STALE_AFTER_S = 14 * 24 * 3600
#: The current digest folder is trimmed (oldest files first) to this many bytes.
MAX_BYTES = 2 * 1024 ** 3


def persistent_root() -> Path | None:
    """``$PROCEDURA_BREP_CACHE`` (None when ``off``), else
    ``$XDG_CACHE_HOME/procedura-brep/parts``, else ``~/.cache/procedura-brep/parts``."""
    value = os.environ.get(ENV_CACHE, "").strip()
    if value.lower() == "off":
        return None
    if value:
        return Path(value).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "procedura-brep" / "parts"


def persistent_dir() -> str | None:
    """This code version's folder of the persistent store (created; see the module doc), after
    a best-effort cleanup of other versions' stale folders and a trim of this one; None when
    the store is off or cannot be made (a read-only home: the worker then keeps a private
    temporary store, as before)."""
    from .server import code_digest
    root = persistent_root()
    if root is None:
        return None
    folder = root / code_digest()[:16]
    try:
        root.mkdir(parents=True, exist_ok=True, mode=0o700)
        root.chmod(0o700)  # the sandbox child reads the store through an open folder fd only
        folder.mkdir(exist_ok=True)
        folder.chmod(0o755)
        os.utime(folder)  # in use: not stale
    except OSError:
        return None
    try:
        prune(root, keep=folder)
    except OSError:  # pragma: no cover - a best effort (a concurrent prune, a full disk)
        pass
    return str(folder)


def prune(root: Path, *, keep: Path, stale_after_s: float = STALE_AFTER_S,
          max_bytes: int = MAX_BYTES) -> int:
    """Remove other code versions' folders unused for ``stale_after_s`` and trim ``keep`` to
    ``max_bytes`` (oldest files first); returns how many files went."""
    import shutil
    import time
    gone = 0
    now = time.time()
    for other in root.iterdir():
        if other != keep and other.is_dir() and now - other.stat().st_mtime > stale_after_s:
            gone += sum(1 for _ in other.iterdir())
            shutil.rmtree(other, ignore_errors=True)
    files = [(f.stat().st_mtime, f.stat().st_size, f) for f in keep.iterdir() if f.is_file()]
    total = sum(size for _, size, _ in files)
    for _, size, f in sorted(files, key=lambda row: row[0]):
        if total <= max_bytes:
            break
        f.unlink(missing_ok=True)
        total -= size
        gone += 1
    return gone


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
