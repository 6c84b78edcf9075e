"""The exact common of two parts, bounded, and the depth of each of its solids.

Shared by the mate gate (a mate's two partners), the interference gate (every pair of parts) and
the battery's B3 rest scan, so all three see the same overlaps. Results are cached by the two
parts' digests.

**Budget.** OCCT's boolean grows much faster than the faces it is given (two parts of n crossed
plates: 25 plates 3.4 s, 100 plates 441 s). When ``faces(a) * faces(b)`` exceeds
``TOL.boolean_face_budget`` the exact common is skipped and a mesh estimate is used instead
(:func:`mesh_estimate`); the result says so (``exact=False``) and the gates add a
``boolean-budget`` warning naming the pair, the product and the budget. A boolean that OCCT
fails (or raises on) is estimated the same way, with a warning saying so.

**Depth** of one common solid ``s`` (mm) is its *thickness*, how far one part reaches into the
other:

* ``w``: the minimum width of ``s`` (the smallest extent of its points over the directions of its
  convex hull's facet normals, the three world axes and, when given, the mate axis). For a slab or
  a block pushed into a face this is the push.
* With a mate frame, a common that *surrounds* the mate axis without containing it (a ring: a
  press or snap fit's interference, or a collar sunk onto a column) measures its radial wall
  ``r_max - r_min`` about the axis, and the depth is ``min(w, r_max - r_min)``: a 0.02 mm press
  ring 20 mm long reads 0.02, a 2 mm gouge of a head onto its column reads 2. Between parts
  that are not partners (:meth:`CommonSolid.free_depth`) the candidate axes are the two parts'
  mate frames and the three world axes through the solid's box centre.

The points are the nodes of a tessellation of ``s`` whose linear deflection is
``TOL.common_deflection_rel`` of its smallest box side (nodes lie on the exact surfaces, so
planar and cylindrical walls are measured exactly; a curved extreme is missed by at most the
deflection).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import TOL
from .geometry import LRU, PartGeometry, boxes_near

log = logging.getLogger(__name__)

#: Common solids smaller than this (mm^3) are boolean noise, not interference.
MIN_COMMON_MM3: float = 1e-9
#: ``Common.face_product`` of a pair whose exact common OCCT could not compute (estimated).
FAILED: int = -1

_COMMON: LRU = LRU()
_FACES: LRU = LRU()


@dataclass
class CommonSolid:
    """One solid of the common of two parts (world mm)."""

    volume: float
    area: float
    lo: np.ndarray
    hi: np.ndarray
    nodes: np.ndarray
    width: float
    shape: Any = field(default=None, repr=False)

    def depth(self, frame: np.ndarray | None = None) -> float:
        """Thickness (mm), see the module doc; ``frame`` is a mate frame (world 4x4) or None."""
        if frame is None or not len(self.nodes):
            return self.width
        return min(self.width, self._ring_wall(frame))

    def free_depth(self, frames: list[np.ndarray] = ()) -> float:
        """Thickness with no mate of its own: the minimum width, or the radial wall of a ring
        about any of ``frames`` (the two parts' mate frames) or about a world axis through the
        solid's box centre."""
        c = (self.lo + self.hi) / 2.0
        axes = []
        for rot in (np.eye(3), np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float),
                    np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0]], float)):
            m = np.eye(4)
            m[:3, :3], m[:3, 3] = rot, c
            axes.append(m)
        return min([self.width] + [self._ring_wall(f) for f in [*frames, *axes]])

    def _ring_wall(self, frame: np.ndarray) -> float:
        """Radial wall (mm) of the solid as a ring about ``frame``'s Z axis (inf if not a ring)."""
        inv = np.linalg.inv(frame)
        p = self.nodes @ inv[:3, :3].T + inv[:3, 3]
        r = np.hypot(p[:, 0], p[:, 1])
        if not _surrounds(p) or _pierced(self.shape, frame, p[:, 2].min(), p[:, 2].max()):
            return math.inf
        return float(r.max() - r.min())

    def touches(self, frame: np.ndarray, radius: float, half_depth: float) -> bool:
        """True when the solid reaches into the cylinder ``|xy| <= radius, |z| <= half_depth``
        of ``frame`` (the mate's feature region): a node inside it, or the solid's box
        containing the frame origin."""
        inv = np.linalg.inv(frame)
        p = self.nodes @ inv[:3, :3].T + inv[:3, 3]
        if not len(p):
            return False
        if np.any((np.hypot(p[:, 0], p[:, 1]) <= radius) & (np.abs(p[:, 2]) <= half_depth)):
            return True
        return bool(np.all(self.lo <= frame[:3, 3]) and np.all(frame[:3, 3] <= self.hi))


@dataclass
class Common:
    """The common of two parts: its solids (exact) or a mesh estimate when over budget."""

    solids: list[CommonSolid]
    exact: bool = True
    face_product: int = 0
    estimate_depth: float = 0.0

    @property
    def volume(self) -> float:
        return float(sum(s.volume for s in self.solids))

    def depth(self, frame: np.ndarray | None = None) -> float:
        if not self.exact:
            return self.estimate_depth
        return max((s.depth(frame) for s in self.solids), default=0.0)


def face_count(geo: PartGeometry) -> int:
    """Number of B-rep faces of a part (cached by digest)."""
    hit = _FACES.get(geo.digest)
    if hit is None:
        from OCP.TopAbs import TopAbs_FACE
        from OCP.TopExp import TopExp_Explorer

        n = 0
        for s in geo.solids:
            exp = TopExp_Explorer(s, TopAbs_FACE)
            while exp.More():
                n += 1
                exp.Next()
        hit = _FACES.put(geo.digest, n)
    return hit


def common(ga: PartGeometry, shape_a: Any, gb: PartGeometry, shape_b: Any) -> Common:
    """The (cached) common of two placed parts; empty when their boxes are disjoint."""
    key = (ga.digest, gb.digest) if ga.digest <= gb.digest else (gb.digest, ga.digest)
    hit = _COMMON.get(key)
    if hit is not None:
        return hit
    if not boxes_near((ga.lo, ga.hi), (gb.lo, gb.hi), TOL.mesh_linear_mm):
        return _COMMON.put(key, Common([]))
    product = face_count(ga) * face_count(gb)
    if product > TOL.boolean_face_budget:
        log.info("common %s & %s skipped: face product %d > budget %d; mesh estimate",
                 ga.name, gb.name, product, TOL.boolean_face_budget)
        return _COMMON.put(key, Common([], False, product, mesh_estimate(ga, gb)))
    try:
        solids = exact_common(shape_a, shape_b)
    except Exception as exc:  # noqa: BLE001  OCCT raised (a broken solid): estimate, never crash
        log.warning("common %s & %s failed in OCCT (%s); mesh estimate", ga.name, gb.name, exc)
        return _COMMON.put(key, Common([], False, FAILED, mesh_estimate(ga, gb)))
    if solids is None:
        return _COMMON.put(key, Common([], False, FAILED, mesh_estimate(ga, gb)))
    return _COMMON.put(key, Common(solids, True, product))


def exact_common(shape_a: Any, shape_b: Any) -> list[CommonSolid] | None:
    """The solids of the OCCT common of two located shapes (no budget, no cache); None when
    OCCT reports the boolean not done."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common

    from .. import kernel

    op = BRepAlgoAPI_Common(shape_a, shape_b)
    if not op.IsDone():
        return None
    out = []
    for s in kernel.solids(op.Shape()):
        vol = abs(kernel.volume(s))
        if vol <= MIN_COMMON_MM3:
            continue
        area = max(kernel.area(s), 1e-300)
        lo, hi = (np.array(c, float) for c in kernel.bbox(s))  # exact: ring axes are centred on it
        nodes = _nodes(s, float(np.min(hi - lo)))
        out.append(CommonSolid(vol, area, lo, hi, nodes, _min_width(nodes), s))
    return out


def _nodes(solid: Any, size: float) -> np.ndarray:
    """Tessellation nodes of ``solid`` (on its exact surfaces), deflection relative to ``size``
    (its smallest box side): a thin slab is meshed finely enough to read its thickness, a ring's
    wall is read from nodes on its two cylinders whatever the density."""
    from .. import kernel

    linear = min(TOL.mesh_linear_mm, max(TOL.common_deflection_min_mm,
                                         TOL.common_deflection_rel * size))
    mesh = kernel.tessellate(solid, linear=linear, angular=TOL.mesh_angular_rad)
    return np.asarray(mesh.vertices, float)


def _min_width(p: np.ndarray) -> float:
    """Smallest extent of the points over hull facet normals and the world axes (mm)."""
    if len(p) < 4:
        return float(np.max(p.max(0) - p.min(0))) if len(p) else 0.0
    dirs = [np.eye(3)]
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(p)
        q = p[hull.vertices]
        dirs.append(hull.equations[:, :3])
    except QhullError:  # flat or degenerate point set: the axes suffice
        q = p
    n = np.vstack(dirs)
    proj = q @ n.T
    return float((proj.max(0) - proj.min(0)).min())


def _surrounds(p: np.ndarray) -> bool:
    """True when the points wind all round the frame's Z axis (no angular gap of 180 deg)."""
    r = np.hypot(p[:, 0], p[:, 1])
    if not len(p) or r.min() <= 1e-9:
        return False
    ang = np.sort(np.arctan2(p[:, 1], p[:, 0]))
    gaps = np.diff(np.concatenate([ang, ang[:1] + 2 * math.pi]))
    return bool(gaps.max() < math.pi)


def _pierced(solid: Any, frame: np.ndarray, z0: float, z1: float) -> bool:
    """True when the frame's Z axis passes through the solid between local heights z0..z1."""
    if solid is None:
        return False
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_IN

    for t in np.linspace(0.1, 0.9, 5):
        z = z0 + t * (z1 - z0)
        w = frame[:3, 3] + z * frame[:3, 2]
        c = BRepClass3d_SolidClassifier(solid, gp_Pnt(*map(float, w)), 1e-7)
        if c.State() == TopAbs_IN:
            return True
    return False


def _surface_samples(geo: PartGeometry, lo: np.ndarray, hi: np.ndarray,
                     cap: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and outward normals on ``geo``'s triangles inside the box ``lo..hi``, about
    ``cap`` of them (plus the triangles' corners)."""
    tri = geo.vertices[geo.faces]
    sel = np.all(tri.max(1) >= lo, 1) & np.all(tri.min(1) <= hi, 1)
    tri = tri[sel]
    if not len(tri):
        return np.zeros((0, 3)), np.zeros((0, 3))
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(n, axis=1)
    n = n / np.maximum(2 * area, 1e-300)[:, None]
    # about area / h^2 points per triangle (stratified by count, deterministic), so thin
    # triangles get few points and the total stays near ``cap``
    h2 = max(area.sum(), 1e-12) / cap
    k = np.minimum(np.ceil(area / h2), cap).astype(np.int64)
    rng = np.random.default_rng(0)
    owner = np.repeat(np.arange(len(tri)), k)
    u, w = rng.random(len(owner)), rng.random(len(owner))
    flip = u + w > 1
    u[flip], w[flip] = 1 - u[flip], 1 - w[flip]
    t = tri[owner]
    p = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + w[:, None] * (t[:, 2] - t[:, 0])
    return np.vstack([tri.reshape(-1, 3), p]), np.vstack([np.repeat(n, 3, axis=0), n[owner]])


def mesh_estimate(ga: PartGeometry, gb: PartGeometry) -> float:
    """Depth estimate (mm) of two overlapping parts from their meshes, no boolean.

    Points sampled on each part's surface (inside the two boxes' overlap) are signed against the
    other part's surface samples (inside when behind the nearest sample's outward normal); the
    estimate is the largest height of an inside point below that sample's tangent plane. It is
    an estimate (coarse samples, tangent planes): the finding that comes with it says so.
    """
    from scipy.spatial import cKDTree

    lo = np.maximum(ga.lo, gb.lo) - TOL.mesh_linear_mm
    hi = np.minimum(ga.hi, gb.hi) + TOL.mesh_linear_mm
    if np.any(lo > hi):
        return 0.0
    cap = TOL.mesh_estimate_samples
    pa, na = _surface_samples(ga, lo, hi, cap)
    pb, nb = _surface_samples(gb, lo, hi, cap)
    if not len(pa) or not len(pb):
        return 0.0
    depth = 0.0
    for p, q, nq in ((pa, pb, nb), (pb, pa, na)):
        _, idx = cKDTree(q).query(p, k=1)
        height = np.einsum("ij,ij->i", p - q[idx], nq[idx])  # along the nearest sample's normal
        inside = height < -TOL.contact_mm
        if inside.any():
            depth = max(depth, float((-height[inside]).max()))
    return depth


def clear() -> None:
    """Forget cached commons and face counts."""
    _COMMON.clear()
    _FACES.clear()
