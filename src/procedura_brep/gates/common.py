"""The exact common of two parts, bounded, and the depth of each of its solids.

Shared by the mate gate (a mate's two partners), the interference gate (every pair of parts) and
the battery's B3 rest scan, so all three see the same overlaps. Results are cached by the two
parts' digests.

**Bound.** OCCT's boolean costs about what the face pairs it must intersect cost: the pairs of
faces, one from each part, whose boxes overlap (two parts of n crossed plates: n^2 pairs, 25
plates 3.4 s, 100 plates 441 s). Those pairs are counted first, from per-face boxes cached by
digest (:func:`face_pairs`); within ``TOL.boolean_pair_budget`` the exact common runs on the two
solids. Over it, both solids are cropped to the region where they can meet (the overlap of their
boxes grown by ``TOL.crop_margin_mm``: the common lies inside it, so the crops' common is the
parts' common) and the pairs are counted again on the crops' faces; within the budget the exact
common runs on the crops. Within the budget, a part of many faces that reaches far beyond that
region (a long threaded screw against its nut) is cut down to a tile holding it all the same
(:func:`_trimmed`: halves of halves of the part, shared by every pair along it): OCCT's boolean
still visits every face. Otherwise, or when OCCT fails on the
boolean, the pair is **not
verified** (``Common.exact`` False, ``Common.reason`` says what stopped it): the gates report a
``not-verified`` warning, never a pass and never a blocking error. No depth is ever estimated
from meshes: every reported depth is the exact one.

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
from .geometry import LRU, PartGeometry, box_pairs, boxes_near

log = logging.getLogger(__name__)

#: Common solids smaller than this (mm^3) are boolean noise, not interference.
MIN_COMMON_MM3: float = 1e-9

_COMMON: LRU = LRU()
_FACES: LRU = LRU()
_TILES: LRU = LRU()  # (part digest, halving path) -> (the part's tile, its face count)
_REGIONS: LRU = LRU()  # part digest -> how many regions :func:`_trimmed` has cut it to


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

    def inner_point(self) -> np.ndarray:
        """A point of the solid (its tessellation node nearest its box centre), world mm: where
        the overlap happens, for findings."""
        c = (self.lo + self.hi) / 2.0
        if not len(self.nodes):
            return c
        return self.nodes[int(np.argmin(np.linalg.norm(self.nodes - c, axis=1)))]

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
    """The exact common of two parts, or why it was not computed.

    Attributes:
        solids: the common's solids (empty when the parts do not overlap, or not verified).
        exact: the common was computed; False means the pair is **not verified**.
        reason: why the pair is not verified ("" when exact).
    """

    solids: list[CommonSolid]
    exact: bool = True
    reason: str = ""

    @property
    def volume(self) -> float:
        return float(sum(s.volume for s in self.solids))

    def depth(self, frame: np.ndarray | None = None) -> float:
        return max((s.depth(frame) for s in self.solids), default=0.0)


def face_boxes(geo: PartGeometry) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) arrays (n, 3) of the boxes of a part's B-rep faces, world mm (cached by digest)."""
    hit = _FACES.get(geo.digest)
    if hit is None:
        hit = _FACES.put(geo.digest, _boxes_of_faces(geo.solids))
    return hit


def face_count(geo: PartGeometry) -> int:
    """Number of B-rep faces of a part (cached by digest)."""
    return int(len(face_boxes(geo)[0]))


def _boxes_of_faces(shapes: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    from .. import kernel

    out = [kernel.bbox(f, optimal=False) for s in shapes for f in kernel.faces(s)]
    if not out:
        return np.zeros((0, 3)), np.zeros((0, 3))
    arr = np.asarray(out, float)
    return arr[:, 0], arr[:, 1]


def face_pairs(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> int:
    """Face pairs (one face of each part) whose boxes, grown by ``TOL.crop_margin_mm``, overlap."""
    return int(len(box_pairs(a[0], a[1], TOL.crop_margin_mm, b[0], b[1])))


def common(ga: PartGeometry, shape_a: Any, gb: PartGeometry, shape_b: Any) -> Common:
    """The (cached) exact common of two placed parts, bounded (see the module doc); empty when
    their boxes are disjoint."""
    key = (ga.digest, gb.digest) if ga.digest <= gb.digest else (gb.digest, ga.digest)
    hit = _COMMON.get(key)
    if hit is not None:
        return hit
    if not boxes_near((ga.lo, ga.hi), (gb.lo, gb.hi), TOL.mesh_linear_mm):
        return _COMMON.put(key, Common([]))
    return _COMMON.put(key, _bounded_common(ga, shape_a, gb, shape_b))


def _bounded_common(ga: PartGeometry, shape_a: Any, gb: PartGeometry, shape_b: Any) -> Common:
    budget = TOL.boolean_pair_budget
    pairs = face_pairs(face_boxes(ga), face_boxes(gb))
    lo = np.maximum(ga.lo, gb.lo) - TOL.crop_margin_mm
    hi = np.minimum(ga.hi, gb.hi) + TOL.crop_margin_mm
    over = pairs > budget
    try:
        cut = ((crop(shape_a, lo, hi), crop(shape_b, lo, hi)) if over else
               (_trimmed(ga, shape_a, lo, hi), _trimmed(gb, shape_b, lo, hi)))
    except Exception as exc:  # noqa: BLE001  OCCT raised on a broken solid: say so, never crash
        return _unverified(ga, gb, f"OCCT failed cropping them ({_first_line(exc)})")
    if cut[0] is None or cut[1] is None:
        return _unverified(ga, gb, "OCCT failed cropping them")
    shape_a, shape_b = cut
    if over:
        full = pairs
        pairs = face_pairs(_boxes_of_faces([shape_a]), _boxes_of_faces([shape_b]))
        if pairs > budget:
            return _unverified(ga, gb, (
                f"{full} face pairs meet ({pairs} after cropping both to their boxes' overlap), "
                f"over the budget of {budget} (config TOL.boolean_pair_budget)"))
        log.info("common %s & %s: %d face pairs, %d after cropping", ga.name, gb.name, full, pairs)
    try:
        solids = exact_common(shape_a, shape_b)
    except Exception as exc:  # noqa: BLE001  OCCT raised (a broken solid): say so, never crash
        return _unverified(ga, gb, f"OCCT failed on their boolean ({_first_line(exc)})")
    if solids is None:
        return _unverified(ga, gb, "OCCT could not compute their boolean")
    return Common(solids)


#: A part of at least this many faces whose box is more than ``1 / TRIM_FRACTION`` times the
#: region where it can meet the other part, and one of whose faces there reaches more than
#: ``1 / TRIM_FRACTION`` times the region's longest side, is cropped to that region before the
#: common, even within the pair budget: OCCT's boolean still works through every such face
#: whole (a 460 mm threaded lead screw against its 18 mm nut: 50 s whole, 20 s cropped). Where
#: the faces that meet the region end near it (a wheel's hub bore), OCCT skips the others by
#: their boxes and a crop only adds a boolean (the rover's gates: 1.7 s with, 1.25 s without).
TRIM_FACES: int = 64
TRIM_FRACTION: float = 0.25


#: The tiles of :func:`_trimmed` are halved at most this many times.
TILE_DEPTH: int = 16
#: A part's first this many regions are cropped from the whole part, the later ones from its
#: tiles. A crop costs about what the piece it keeps costs: half of a 460 mm thread took 16.5 s
#: to cut, its nut's 18 mm region 2.5 s, so a part that few others meet is cut to each region
#: directly, and only a part that many meet (a base plate under a row of posts) is tiled.
DIRECT_CROPS: int = 4


def _trimmed(geo: PartGeometry, shape: Any, lo: np.ndarray, hi: np.ndarray) -> Any | None:
    """``shape`` (of ``geo``) cut down to a tile holding ``lo..hi``, the region where it can
    meet the other part, when it is a large many-faced part reaching far beyond it with faces
    that do too (:data:`TRIM_FACES`, :data:`TRIM_FRACTION`), else as it is. The common lies inside the
    region, so the tile's common is the part's.

    The tiles halve the part's box along its longest side, again and again (a tile of the
    part is a crop of the tile it halves, cached by the part's digest): a region descends to
    the smallest tile that holds it whole, until the tile has fewer than :data:`TRIM_FACES`
    faces or the region fills :data:`TRIM_FRACTION` of it. A base plate with a socket for each
    of n posts is cropped about log n times per post from ever smaller tiles, not n times whole
    (each crop of the whole plate visits its every face: B3 grew as n^2). The part's first
    :data:`DIRECT_CROPS` regions are cropped from the whole part instead (a thread, whose
    halves cost far more to cut than the few regions its nut and carriage need)."""
    region = float(np.prod(np.maximum(hi - lo, 0.0)))
    whole = float(np.prod(np.maximum(geo.hi - geo.lo, 1e-9)))
    if face_count(geo) < TRIM_FACES or region >= TRIM_FRACTION * whole:
        return shape
    flo, fhi = face_boxes(geo)
    meet = np.all(flo <= hi, axis=1) & np.all(fhi >= lo, axis=1)
    reach = float((fhi - flo)[meet].max(initial=0.0))
    if reach * TRIM_FRACTION <= float(np.max(hi - lo)):
        return shape  # the faces there end near it (a wheel's hub bore): OCCT skips the rest by their boxes
    if _REGIONS.put(geo.digest, int(_REGIONS.get(geo.digest) or 0) + 1) <= DIRECT_CROPS:
        return crop(shape, lo, hi)
    tile_lo, tile_hi, tile, path = np.array(geo.lo, float), np.array(geo.hi, float), shape, ""
    for _ in range(TILE_DEPTH):
        axis = int(np.argmax(tile_hi - tile_lo))
        mid = float(tile_lo[axis] + tile_hi[axis]) / 2.0
        if hi[axis] <= mid:
            half, sub_lo, sub_hi = "0", tile_lo.copy(), tile_hi.copy()
            sub_hi[axis] = mid
        elif lo[axis] >= mid:
            half, sub_lo, sub_hi = "1", tile_lo.copy(), tile_hi.copy()
            sub_lo[axis] = mid
        else:
            break  # the region straddles the cut: this tile is the smallest that holds it
        key = (geo.digest, path + half)
        sub = _TILES.get(key)
        if sub is None:
            cut = crop(tile, sub_lo, sub_hi)
            if cut is None:
                break
            sub = _TILES.put(key, (cut, _face_total(cut)))
        tile_lo, tile_hi, path = sub_lo, sub_hi, path + half
        tile, faces = sub
        if faces < TRIM_FACES or region >= TRIM_FRACTION * float(np.prod(tile_hi - tile_lo)):
            return tile
    return crop(tile, lo, hi)


def _face_total(shape: Any) -> int:
    from .. import kernel
    return len(kernel.faces(shape))


def _first_line(exc: BaseException) -> str:
    return (str(exc).strip().splitlines() or [type(exc).__name__])[0][:200]


def _unverified(ga: PartGeometry, gb: PartGeometry, reason: str) -> Common:
    log.info("common %s & %s not verified: %s", ga.name, gb.name, reason)
    return Common([], False, reason)


def crop(shape: Any, lo: np.ndarray, hi: np.ndarray) -> Any | None:
    """``shape`` cut to the box ``lo..hi`` (world mm); None when OCCT reports it not done."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt

    box = BRepPrimAPI_MakeBox(gp_Pnt(*map(float, lo)), gp_Pnt(*map(float, hi))).Shape()
    op = BRepAlgoAPI_Common(shape, box)
    return op.Shape() if op.IsDone() else None


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


def clear() -> None:
    """Forget cached commons, face boxes, tiles and region counts."""
    _COMMON.clear()
    _FACES.clear()
    _TILES.clear()
    _REGIONS.clear()
