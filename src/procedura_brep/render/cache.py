"""Render cache keys and the manifest that records which program each image shows.

Every image written by :func:`procedura_brep.render.render_to_dir` is listed in
``<out_dir>/renders.json`` with two keys: ``geometry`` (sha256 over every part's name and
:attr:`CompiledPart.digest`, i.e. what the program compiles to) and ``key`` (geometry plus the
settings that change pixels: mode, size, view, close-up target, overlay, materials, mate frames,
renderer version). An image whose ``key`` matches is reused; an image is *current* when its
``geometry`` equals the model's.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..program.model import CompiledModel
from .palette import part_colors

RENDER_VERSION: int = 4
"""Bump when shaders, lights or layout change, so cached images are redrawn."""
MANIFEST: str = "renders.json"


def geometry_key(model: CompiledModel) -> str:
    """sha256 over (name, digest) of every part, in model order."""
    h = hashlib.sha256()
    for p in model.parts:
        h.update(p.name.encode("utf-8") + b"\0" + p.digest.encode("ascii") + b"\n")
    return h.hexdigest()


def image_key(model: CompiledModel, geometry: str, settings: dict[str, Any]) -> str:
    """sha256 of the geometry key, the settings, part materials and mate frames."""
    extra = {
        "v": RENDER_VERSION,
        "materials": [(p.name, p.material, m.as_dict() if (m := model.materials.get(p.material)) else None)
                      for p in model.parts],
        "mates": [(m.name, np.round(np.asarray(m.world_frame, float), 6).tolist()) for m in model.mates],
        "frames": [(p.name, sorted(p.frames)) for p in model.parts],
        "colors": sorted(part_colors([p.name for p in model.parts]).items()),
    }
    blob = json.dumps({"g": geometry, "s": settings, "x": extra}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


@dataclass
class Manifest:
    """The images in one render directory: file name -> {key, geometry, view, mode, size}."""

    path: Path
    images: dict[str, dict[str, Any]] = field(default_factory=dict)

    @classmethod
    def load(cls, out_dir: Path) -> Manifest:
        path = Path(out_dir) / MANIFEST
        try:
            data = json.loads(path.read_text())
            images = data.get("images", {}) if data.get("version") == RENDER_VERSION else {}
        except (OSError, ValueError):
            images = {}
        return cls(path, images)

    def hit(self, name: str, key: str) -> bool:
        entry = self.images.get(name)
        return bool(entry and entry.get("key") == key and (self.path.parent / name).is_file())

    def save(self) -> None:
        tmp = self.path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps({"version": RENDER_VERSION, "images": self.images},
                                  indent=1, sort_keys=True))
        os.replace(tmp, self.path)


@dataclass(frozen=True)
class ViewStatus:
    """Which images in a render directory show the current program.

    Attributes:
        geometry: the current model's geometry key.
        current: image files that show it.
        stale: image files that show an older program (or a missing file).
    """

    geometry: str
    current: tuple[str, ...]
    stale: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """True when at least one image exists and none is stale."""
        return bool(self.current) and not self.stale


def views_status(model: CompiledModel, out_dir: str | Path, *, files: list[str] | None = None) -> ViewStatus:
    """Whether the images in ``out_dir`` (or just ``files``) show ``model`` as compiled now."""
    man = Manifest.load(Path(out_dir))
    geo = geometry_key(model)
    names = list(man.images) if files is None else list(files)
    cur = tuple(n for n in names if n in man.images and man.images[n].get("geometry") == geo
                and (Path(out_dir) / n).is_file())
    return ViewStatus(geo, cur, tuple(n for n in names if n not in cur))
