"""The bundle writer: every export format of one model into one run directory.

``write_bundle(model, out_dir)`` writes ``model.step`` (when :mod:`procedura_brep.export.step` is
importable), ``model.obj``/``model.mtl``, ``model.glb``, ``model.usda``, ``urdf/`` (both profiles
plus ``meshes/``) and ``model.xml`` (MJCF, meshes shared with ``urdf/meshes``). ``program.py``,
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

log = logging.getLogger(__name__)

#: Every format name ``--formats`` accepts, in writing order.
FORMATS: tuple[str, ...] = ("step", "obj", "glb", "usd", "urdf", "mjcf")


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
    needs_tree = any(f in fmts for f in ("usd", "urdf", "mjcf"))
    art = art or (articulate(model) if needs_tree else None)
    masses = link_masses(model, art) if art is not None else None
    times = timings if timings is not None else {}
    times["articulate"] = time.perf_counter() - t
    for fmt in fmts:
        t = time.perf_counter()
        if fmt == "step":
            from .step import step_bytes
            out["model.step"] = step_bytes(model, schema=step_schema)
        elif fmt == "obj":
            from .obj import obj_files
            out.update(obj_files(model))
        elif fmt == "glb":
            from .glb import glb_bytes
            out["model.glb"] = glb_bytes(model)
        elif fmt == "usd":
            from .usd import usda_text
            out["model.usda"] = usda_text(model, art=art, masses=masses).encode()
        elif fmt == "urdf":
            from .urdf import urdf_files
            out.update({f"urdf/{k}": v for k, v in urdf_files(model, art=art, masses=masses).items()})
        elif fmt == "mjcf":
            from .mjcf import mjcf_files
            out.update(mjcf_files(model, art=art, masses=masses))
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
