"""Shared meshes for every exporter: exact visual tessellation and convex collision pieces.

Visual meshes come from :func:`procedura_brep.kernel.tessellate` (serial mesher, fixed settings)
and are cached by part digest, so every format in a bundle writes the same triangles. Collision
geometry is a set of convex pieces per part: the convex hull of each connected component of the
tessellation, or, when ``coacd`` is installed and a component is clearly non-convex, a capped
CoACD decomposition (see :data:`COACD_MAX_HULLS`).
"""

from __future__ import annotations

import logging

import numpy as np

from ..config import TOL
from ..kernel import Mesh
from ..program.model import CompiledPart

log = logging.getLogger(__name__)

#: At most this many convex pieces per component from CoACD (caps its cost).
COACD_MAX_HULLS = 8
#: CoACD concavity threshold (its ``threshold`` argument); larger is faster and coarser.
COACD_THRESHOLD = 0.08
#: Components with fewer triangles than this are skipped in collision (slivers).
MIN_COMPONENT_FACES = 4

_COLLISION: dict[str, list[Mesh]] = {}


def part_mesh(part: CompiledPart) -> Mesh:
    """The part's exact visual mesh in WORLD coordinates, mm (cached by digest)."""
    return part.mesh()


def transform(mesh: Mesh, matrix: np.ndarray, *, scale: float = 1.0) -> Mesh:
    """``mesh`` moved by the 4x4 ``matrix`` then scaled (e.g. 1e-3 for mm -> m)."""
    v = mesh.vertices @ matrix[:3, :3].T + matrix[:3, 3]
    return Mesh(v * scale, mesh.faces)


def to_local_m(mesh: Mesh, frame: np.ndarray) -> Mesh:
    """A world-mm mesh expressed in ``frame`` (4x4 world, mm), in metres."""
    inv = np.linalg.inv(frame)
    return transform(mesh, inv, scale=1e-3)


def _components(mesh: Mesh) -> list[Mesh]:
    import trimesh
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    out = []
    for c in tm.split(only_watertight=False):
        if len(c.faces) >= MIN_COMPONENT_FACES:
            out.append(Mesh(np.asarray(c.vertices), np.asarray(c.faces, dtype=np.int64)))
    return out or [mesh]


def _hull(mesh: Mesh) -> Mesh | None:
    import trimesh
    try:
        h = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).convex_hull
    except Exception as exc:  # qhull fails on flat components
        log.debug("convex hull failed: %s", exc)
        return None
    return Mesh(np.asarray(h.vertices), np.asarray(h.faces, dtype=np.int64))


def _coacd(mesh: Mesh) -> list[Mesh] | None:
    try:
        import coacd  # optional dependency
    except ImportError:
        return None
    try:
        coacd.set_log_level("error")
        parts = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces),
                                threshold=COACD_THRESHOLD, max_convex_hull=COACD_MAX_HULLS)
    except Exception as exc:
        log.warning("coacd failed (%s); using the convex hull", exc)
        return None
    return [Mesh(np.asarray(v), np.asarray(f, dtype=np.int64)) for v, f in parts]


def collision_pieces(part: CompiledPart) -> list[Mesh]:
    """Convex pieces (world, mm) that approximate the part for collision (cached by digest)."""
    key = part.digest
    if key in _COLLISION:
        return _COLLISION[key]
    import trimesh
    pieces: list[Mesh] = []
    for comp in _components(part_mesh(part)):
        hull = _hull(comp)
        if hull is None:
            continue
        tm = trimesh.Trimesh(comp.vertices, comp.faces, process=False)
        vol = abs(float(tm.volume)) if tm.is_watertight else 0.0
        hvol = abs(float(trimesh.Trimesh(hull.vertices, hull.faces, process=False).volume))
        if vol > 0 and hvol > TOL.nonconvex_ratio * vol:
            dec = _coacd(comp)
            if dec:
                pieces.extend(dec)
                continue
        pieces.append(hull)
    _COLLISION[key] = pieces
    return pieces


def stl_bytes(mesh: Mesh) -> bytes:
    """Binary STL of ``mesh`` (units as given)."""
    import trimesh
    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).export(file_type="stl")


def clear_cache() -> None:
    """Forget every cached mesh (tests)."""
    from ..program.model import clear_mesh_cache
    clear_mesh_cache()
    _COLLISION.clear()
