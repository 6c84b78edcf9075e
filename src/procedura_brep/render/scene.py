"""Scene geometry: one tessellation per part digest, smooth-within-crease normals, vertex arrays.

Meshes come from :func:`procedura_brep.kernel.tessellate` (serial mesher, never the parallel
one) and are cached in-process by :attr:`CompiledPart.digest`, which changes exactly when the
local BRep or the placement does.
"""

from __future__ import annotations

import logging
import math
from collections import OrderedDict

import numpy as np

from .. import materials
from ..program.model import CompiledModel, CompiledPart

log = logging.getLogger(__name__)

CREASE_DEG: float = 35.0
"""Faces meeting at a sharper dihedral than this keep separate normals (a visible edge)."""
MESH_CACHE_SIZE: int = 512
"""Parts whose render meshes stay cached in this process (keyed by digest)."""

_MESHES: OrderedDict[str, tuple[np.ndarray, np.ndarray]] = OrderedDict()


def corner_normals(vertices: np.ndarray, faces: np.ndarray, *, crease_deg: float = CREASE_DEG) -> np.ndarray:
    """Per-corner normals (3M, 3): area-weighted over faces at the vertex within the crease angle."""
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(cross, axis=1, keepdims=True)
    unit = cross / np.maximum(norm, 1e-30)
    m = len(faces)
    vc = faces.reshape(-1)
    fc = np.repeat(np.arange(m), 3)
    order = np.argsort(vc, kind="stable")
    counts = np.bincount(vc, minlength=len(vertices))
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    deg = counts[vc]
    total = int(deg.sum())
    corner = np.repeat(np.arange(3 * m), deg)
    offs = np.arange(total) - np.repeat(np.cumsum(deg) - deg, deg)
    partner = fc[order[np.repeat(starts[vc], deg) + offs]]
    keep = np.einsum("ij,ij->i", unit[fc[corner]], unit[partner]) > math.cos(math.radians(crease_deg))
    acc = np.zeros((3 * m, 3))
    np.add.at(acc, corner[keep], cross[partner[keep]])
    out = acc / np.maximum(np.linalg.norm(acc, axis=1, keepdims=True), 1e-30)
    return out


def part_mesh(part: CompiledPart) -> tuple[np.ndarray, np.ndarray]:
    """World-space (positions (3M, 3), normals (3M, 3)) float32 for ``part``, cached by digest."""
    key = part.digest
    hit = _MESHES.get(key)
    if hit is not None:
        _MESHES.move_to_end(key)
        return hit
    mesh = part.mesh()
    if len(mesh.faces) == 0:
        log.warning("part %s tessellated to no triangles; it will not be drawn", part.name)
        out = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32))
    else:
        pos = mesh.vertices[mesh.faces].reshape(-1, 3)
        out = (pos.astype(np.float32), corner_normals(mesh.vertices, mesh.faces).astype(np.float32))
    _MESHES[key] = out
    while len(_MESHES) > MESH_CACHE_SIZE:
        _MESHES.popitem(last=False)
    return out


def material_of(model: CompiledModel, part: CompiledPart) -> materials.Material:
    """The part's material from the model's library, falling back to steel (logged) for an
    unknown key."""
    try:
        return model.material_of(part)
    except materials.MaterialError:
        log.warning("part %s: unknown material %r, rendering as steel", part.name, part.material)
        return materials.get("steel")


def vertex_array(model: CompiledModel, colors: dict[str, tuple[int, int, int]],
                 names: list[str] | None = None) -> np.ndarray:
    """Interleaved float32 rows: position 3, normal 3, part colour 3, base colour 3, metal, rough, id.

    ``id`` is the part's index in ``model.parts`` plus one (0 means background).
    """
    rows = []
    for i, part in enumerate(model.parts):
        if names is not None and part.name not in names:
            continue
        pos, nrm = part_mesh(part)
        if not len(pos):
            continue
        mat = material_of(model, part)
        attrs = np.array([*(c / 255 for c in colors[part.name]), *mat.rgb, mat.metalness,
                          mat.roughness, i + 1], np.float32)
        rows.append(np.hstack([pos, nrm, np.broadcast_to(attrs, (len(pos), len(attrs)))]))
    if not rows:
        return np.zeros((0, 15), np.float32)
    return np.ascontiguousarray(np.vstack(rows), dtype=np.float32)


def bounds(model: CompiledModel, names: list[str] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned world box (lo, hi) of the rendered meshes (of ``names`` if given)."""
    pts = [part_mesh(p)[0] for p in model.parts if names is None or p.name in names]
    pts = [p for p in pts if len(p)]
    if not pts:
        return np.zeros(3), np.ones(3)
    allp = np.vstack(pts)
    return allp.min(axis=0).astype(float), allp.max(axis=0).astype(float)
