"""Run-directory basics shared by every layer: stable names and atomic file writes."""

from __future__ import annotations

import os
import re
import tempfile
import unicodedata
from pathlib import Path


def program_name(path: Path) -> str:
    """A stable identifier ``[a-z_][a-z0-9_]*`` (valid in USD paths, MJCF and URDF): the folder of
    ``program.py`` files, else the file stem; ``model_`` is prefixed when it would start with a
    digit, and ``model`` stands in for an empty name."""
    stem = path.parent.name if path.name == "program.py" and path.parent.name else path.stem
    text = unicodedata.normalize("NFKD", stem).encode("ascii", "ignore").decode("ascii").lower()
    text = re.sub(r"[^a-z0-9_]+", "_", text).strip("_")
    if not text:
        return "model"
    return f"model_{text}" if text[0].isdigit() else text


def json_default(o: object) -> object:
    """``json.dumps(default=...)`` for NumPy arrays and scalars and tuples."""
    import numpy as np
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, tuple):
        return list(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_atomic(path: Path, data: bytes | str, *, mode: int = 0o644) -> Path:
    """Write ``data`` to ``path`` through a temp file in the same folder and a rename, so a
    killed process never leaves a half-written file. Returns ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        os.fchmod(fd, mode)
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
