"""The bundle writer: every export format of one model into one run directory.

``write_bundle(model, out_dir)`` writes every format of :mod:`.registry` (one row each):
``model.step``, ``model.obj``/``model.mtl``, ``model.glb``, ``model.usda``, ``urdf/`` (both
profiles plus ``meshes/``) and ``model.xml`` (MJCF, meshes shared with ``urdf/meshes``). ``program.py``,
``mates.json`` and ``report.json`` belong to the caller. Articulation, masses and meshes are
computed once and shared, so all formats agree by construction; each file is written to a
temporary name and renamed.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Literal

from ..articulation import Articulation, articulate, link_masses
from ..paths import write_atomic
from ..program.model import CompiledModel
from .registry import FORMAT_NAMES, REGISTRY, ExportJob

log = logging.getLogger(__name__)

#: Every format name ``--formats`` accepts, in writing order (the rows of :mod:`.registry`).
FORMATS: tuple[str, ...] = FORMAT_NAMES


def parse_formats(text: str | Iterable[str] | None) -> tuple[str, ...]:
    """``"step,obj"`` or a list -> validated names (None = all).

    Raises:
        ValueError: an unknown format, naming the allowed ones.
    """
    if text is None:
        return FORMATS
    items = [s.strip().lower() for s in (text.split(",") if isinstance(text, str) else text)]
    items = [s for s in items if s]
    bad = [s for s in items if s not in FORMATS]
    if bad:
        raise ValueError(f"unknown export format(s) {', '.join(bad)}; use any of {','.join(FORMATS)}")
    return tuple(f for f in FORMATS if f in items)


def bundle_bytes(model: CompiledModel, *, formats: str | Iterable[str] | None = None,
                 timings: dict[str, float] | None = None,
                 step_schema: Literal["AP214", "AP242"] = "AP214",
                 art: Articulation | None = None) -> dict[str, bytes]:
    """``{relative path: bytes}`` for the requested formats (pure; nothing is written); ``art``
    is the articulation the USD, URDF and MJCF files are written from (default
    :func:`articulate` of ``model``, once for all three)."""
    fmts = parse_formats(formats)
    out: dict[str, bytes] = {}
    t = time.perf_counter()
    needs_tree = any(REGISTRY[f].articulated for f in fmts)
    art = art or (articulate(model) if needs_tree else None)
    masses = link_masses(model, art) if art is not None else None
    times = timings if timings is not None else {}
    times["articulate"] = time.perf_counter() - t
    job = ExportJob(model, art, masses, step_schema)
    for fmt in fmts:
        t = time.perf_counter()
        out.update(REGISTRY[fmt].write(job))
        times[fmt] = time.perf_counter() - t
    return out


def write_bundle(model: CompiledModel, out_dir: str | os.PathLike[str], *,
                 formats: str | Iterable[str] | None = None,
                 timings: dict[str, float] | None = None,
                 step_schema: Literal["AP214", "AP242"] = "AP214",
                 art: Articulation | None = None) -> dict[str, Path]:
    """Write the requested formats (default: all) under ``out_dir``.

    Returns:
        ``{relative path: absolute Path}`` of every file written.

    Raises:
        ArticulationError: the mate graph is not a tree (names the loop or the orphan).
        ValueError: an unknown format name.
    """
    root = Path(out_dir)
    files = bundle_bytes(model, formats=formats, timings=timings, step_schema=step_schema, art=art)
    written = {rel: write_atomic(root / rel, data) for rel, data in files.items()}
    log.info("wrote %d files to %s", len(written), root)
    return written
