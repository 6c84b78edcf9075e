"""Exact-solid sweeps for battery B2: every joint's range sampled densely enough to hit a fin.

MuJoCo only sees convex hulls and stops only where they meet, so a part can pass *through*
another between the two extremes a sweep reaches. Here every (moved, fixed) part pair of a
joint is sampled along the joint's whole range (a continuous joint over a full turn) with a
spacing chosen from the geometry, by conservative advancement: no point of the moved part that
is within reach of the fixed part travels more than ``TOL.sweep_step_mm`` between two samples,
and points further away move at most their gap plus that step (see
:meth:`SweepScene._sweep_pair`). A fin thicker than the step cannot lie between two samples.
A cylindrical joint is swept on each DOF at the other's compiled value.
Each spherical joint is tilted to :data:`SPHERE_FRACTIONS` of its cone in
:data:`SPHERE_DIRECTIONS` directions (coarse: see docs/battery.md). At each sample the moved
part is posed with the mate-frame closed form (``F @ delta @ F^-1``, see
:mod:`procedura_brep.mates.placement`) and the exact OCCT common of the pair is measured
(thickness ``2 V / S``, as :mod:`.contact`); the finding is the increase over the pair's
thickness at rest.

Cost is kept down by prefilters, all conservative for the thickness measure:

* a pair is skipped when the moved part's swept envelope (its box corners' cylinder about a
  revolute axis, their sphere about a ball centre, its box stretched by a prismatic travel) misses
  the fixed part's box;
* a pair whose exact extents along a direction the motion preserves (the axis of a revolute
  joint; the two cross-axis directions of a prismatic one) overlap by less than
  ``TOL.sim_penetration_mm`` is skipped for the whole sweep: any common solid then lies in a slab
  thinner than the tolerance, and a solid inside a slab of thickness t has ``2 V / S <= t``;
* only the moved part's surface cells (:mod:`.cells`) whose orbit (radius and height about a
  revolute axis, cross-axis position for a prismatic one) passes near the fixed part's cells
  count, and they alone set the sample spacing;
* per pose, the surface-cell covers must meet and the parts' oriented local bounding boxes
  intersect (separating-axis test) before the exact boolean runs, on both parts cut once per
  pair to the region an interference along the sweep can lie in;
* **sliding contact** (a bearing block on its rail, a carriage on its ways, a piston in its bore,
  a tube in its sleeve): for a slide, a pair that does not overlap at the range's start is swept
  with the moved part's *leading* faces against the fixed part's *opposing* faces only
  (:func:`.cells.faces_along`: faces parallel to the motion slide within themselves and cannot
  start an overlap), so faces that touch along the motion cost nothing, whatever their length,
  while a stop in the path is found at the pose where the moved part meets it;
* **turning contact** likewise: for a turn, a pair clear at the range's start leaves out the
  faces of *both* parts that the rotation moves within themselves (planes normal to the axis,
  surfaces of revolution about it, :func:`.cells.invariant_under_rotation`): a moved point can
  enter the fixed part only where the fixed part's outward normal opposes its velocity, never
  on such a face, so a tilting head between the cheeks of its yoke costs no boolean there.

A sweep that still spends ``TOL.sweep_max_booleans`` stops and is **not verified** (it names
the pair and the pose it reached), never a pass and never a failure of parts that merely touch.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .. import kernel
from ..articulation.tree import Articulation, Joint
from ..config import TOL
from ..gates.geometry import box_pairs
from ..mates.kinds import CONTINUOUS, PRISMATIC, REVOLUTE, Motion
from ..mates.placement import motion_delta, rigid_inverse, rot_x, rot_z, trans
from ..program.model import CompiledModel
from .cells import Cover, Face, cell_side, cover_of, cover_radius, faces, faces_along, surface
from .contact import Overlap, exact_overlap

log = logging.getLogger(__name__)

#: At most this many poses per part pair: a spacing finer than this allows is widened (and
#: the widened step is reported). Keeps a pathological part (a 10 m boom) from stalling B2.
MAX_PAIR_SAMPLES = 20000
#: Conservative advancement looks this far (mm) for the fixed part's surface: a cell further
#: away counts as this far (a shorter advance, never a missed contact), which keeps the
#: nearest-neighbour queries cheap.
ADVANCE_HORIZON_MM = 25.0
#: Spherical joints: tilt directions (about axes in the frame's XY plane, evenly spaced).
SPHERE_DIRECTIONS = 8
#: Spherical joints: tilts as fractions of the cone half-angle.
SPHERE_FRACTIONS = (0.5, 1.0)
#: A reached joint value (MuJoCo) is sampled too when it overshoots the commanded range by more
#: than this (rad or m): below it, it is the range end itself.
OVERSHOOT_EPS = 1e-6


@dataclass
class Sample:
    """One pose of a joint: ``label`` says where (e.g. ``-85 deg``), ``motion`` is the world
    4x4 motion of the child subtree (mm), ``value`` the joint value (rad, m, or for a spherical
    joint the (direction deg, tilt rad) pair)."""

    label: str
    motion: np.ndarray
    value: float | tuple[float, float]


@dataclass
class SweepHit:
    """The deepest new interference a joint's sweep found."""

    joint: str
    depth: float = 0.0
    volume: float = 0.0
    pair: tuple[str, str] | None = None
    at: str = ""
    value: float | tuple[float, float] | None = None
    samples: int = 0
    booleans: int = 0
    step_mm: float = 0.0
    skipped_rest: list[tuple[str, str]] = field(default_factory=list)
    #: Where the sweep stopped because it spent ``TOL.sweep_max_booleans`` ("" if it did not):
    #: "<moved> against <fixed> at <pose>". A stopped sweep is unfinished: the poses after it
    #: are **not verified** (B2 says so; it neither passes nor fails them).
    stopped: str = ""
    #: The first pose (label) at which the worst pair's new interference exceeded
    #: ``TOL.sim_penetration_mm``: where the moved part meets the fixed one ("" if none).
    first_at: str = ""
    #: Pairs clear at the range's start, swept on the faces that can start an overlap only
    #: (sliding and turning contact, see the module).
    contact: list[tuple[str, str]] = field(default_factory=list)
    #: World point (mm) inside the worst common, at the pose ``at``.
    point: list[float] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"new_penetration_mm": self.depth, "volume_mm3": self.volume,
                "pair": list(self.pair) if self.pair else None, "at": self.at,
                "first_at": self.first_at or None, "point_mm": self.point or None,
                "samples": self.samples, "booleans": self.booleans,
                "max_step_mm": self.step_mm,
                "rest_interfering_pairs": [list(p) for p in self.skipped_rest],
                "contact_pairs": [list(p) for p in self.contact],
                "not_verified": self.stopped or None}


class _BudgetSpent(Exception):
    """A joint's sweep reached ``TOL.sweep_max_booleans`` (internal: :meth:`SweepScene.sweep`
    turns it into :attr:`SweepHit.stopped`)."""

    def __init__(self, where: str) -> None:
        super().__init__(where)
        self.where = where


def joint_values(joint: Joint, radius_mm: float, extra: tuple[float, ...] = ()) -> list[float]:
    """Joint values (rad or m) along ``joint``'s range, spaced so that a point ``radius_mm`` from
    a revolute axis (any point, for a prismatic joint) moves at most ``TOL.sweep_step_mm``
    between two; a continuous joint covers one full turn. Values in ``extra`` (a MuJoCo
    overshoot) are added where they lie outside the commanded range."""
    step_mm = TOL.sweep_step_mm
    if joint.kind.endless:
        n = max(4, math.ceil(2 * math.pi * max(radius_mm, 0.0) / step_mm))
        n = min(n, MAX_PAIR_SAMPLES)
        return (np.arange(n) * (2 * math.pi / n)).tolist()
    lo, hi = float(joint.lower), float(joint.upper)  # type: ignore[arg-type]  # a swept joint has limits
    if joint.kind.turns:
        n = math.ceil((hi - lo) * max(radius_mm, 0.0) / step_mm) + 1
    else:
        n = math.ceil((hi - lo) * 1000.0 / step_mm) + 1
    values = np.linspace(lo, hi, max(2, min(MAX_PAIR_SAMPLES, n))).tolist()
    return sorted(values + [q for q in extra if q < lo - OVERSHOOT_EPS or q > hi + OVERSHOOT_EPS])


def motion(joint: Joint, q: float) -> np.ndarray:
    """World 4x4 motion (mm) of ``joint``'s child subtree at value ``q`` (rad or m)."""
    if joint.kind.slides:
        d = motion_delta(Motion.SLIDE, q * 1000.0)
    else:
        d = motion_delta(Motion.TURN, math.degrees(q))
    return joint.frame @ d @ rigid_inverse(joint.frame)


def label(joint: Joint, q: float) -> str:
    return joint.kind.label(q)


def samples(joint: Joint, extra: tuple[float, ...] = (), *, radius_mm: float = 0.0) -> list[Sample]:
    """The poses at which ``joint``'s sweep is checked for a moved point ``radius_mm`` from its
    axis (see :func:`joint_values`); a spherical joint's tilts do not depend on the radius."""
    f, f_inv = joint.frame, rigid_inverse(joint.frame)
    out: list[Sample] = []
    if joint.kind.ball:
        cone = float(joint.upper or 0.0)
        for frac in SPHERE_FRACTIONS:
            for k in range(SPHERE_DIRECTIONS):
                phi = 360.0 * k / SPHERE_DIRECTIONS
                tilt = math.degrees(frac * cone)
                d = rot_z(phi) @ rot_x(tilt) @ rot_z(-phi)  # tilt about (cos phi, sin phi, 0)
                out.append(Sample(f"tilt {tilt:.3g} deg about direction {phi:.0f} deg",
                                  f @ d @ f_inv, (phi, frac * cone)))
        return out
    if not (joint.kind.turns or joint.kind.slides):
        return out
    return [Sample(label(joint, q), motion(joint, q), q) for q in joint_values(joint, radius_mm, extra)]


def _corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def _obb_overlap(a: tuple[np.ndarray, np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray, np.ndarray],
                 slack: float) -> bool:
    """Separating-axis test of two oriented boxes (centre, rotation 3x3 with box axes as columns,
    half extents)."""
    ca, ra, ha = a
    cb, rb, hb = b
    t = cb - ca
    axes = [ra[:, i] for i in range(3)] + [rb[:, i] for i in range(3)]
    for i in range(3):
        for k in range(3):
            c = np.cross(ra[:, i], rb[:, k])
            n = float(np.linalg.norm(c))
            if n > 1e-9:
                axes.append(c / n)
    for ax in axes:
        pa = float(np.sum(ha * np.abs(ra.T @ ax)))
        pb = float(np.sum(hb * np.abs(rb.T @ ax)))
        if abs(float(t @ ax)) > pa + pb + slack:
            return False
    return True


class SweepScene:
    """The model's parts with their shapes and local boxes cached, for many posed queries."""

    def __init__(self, model: CompiledModel, art: Articulation) -> None:
        self.model, self.art = model, art
        self._box: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._rest: dict[tuple[str, str], Overlap] = {}
        self._extent: dict[tuple[str, bytes], tuple[float, float]] = {}
        self._surface: dict[tuple[str, bytes, bytes], tuple[np.ndarray, np.ndarray, float, np.ndarray]] = {}
        self._pair_cover: dict[tuple, tuple[tuple[Cover, cKDTree | None], tuple[Cover, cKDTree | None]]] = {}
        self._faces: dict[str, list[Face]] = {}  # each part's meshed faces, read once
        self._pair_near: dict[tuple, tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]] = {}
        self.booleans = 0
        self._joint_start = 0  # self.booleans when the current joint's sweep began

    def _spend(self, where) -> None:
        """Count one exact boolean of the current joint's sweep; past the budget, stop the sweep
        (``where`` is called for the message only then)."""
        if self.booleans - self._joint_start >= TOL.sweep_max_booleans:
            raise _BudgetSpent(where())
        self.booleans += 1

    def surface(self, name: str, joint: Joint | None = None,
                side: int = 0) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """(triangles (n, 3, 3) world mm at rest, each one's deviation from its exact face, the
        cell side, each one's cylinder axis or zeros, :func:`.cells.surface`) of the
        part's faces a sweep covers: with a revolute or continuous ``joint``, without the faces
        its rotation leaves in place (with ``side`` -1 too: a fixed part of a pair clear at the
        start); with a sliding ``joint`` and ``side`` +1 (-1), only the
        faces that may lead (oppose) its motion (:mod:`.cells`). The cell side is the whole
        surface's (:func:`.cells.cell_side`), so every cover of the part agrees on it."""
        axis = None
        keep = None
        if joint is not None and joint.kind.turns:
            axis = (joint.frame[:3, 3].copy(), joint.axis)
        tag = b""
        if joint is not None and side and joint.kind.slides:
            u = joint.frame[:3, 2]
            keep = faces_along(u, side)
            tag = np.round(u * side, 9).tobytes()
        key = (name, b"" if axis is None else np.round(np.concatenate(axis), 9).tobytes(), tag)
        if key not in self._surface:
            if name not in self._faces:
                self._faces[name] = faces(self.model.part(name).shape())
            tris, devs, axes = surface(None, axis=axis, keep=keep, meshed=self._faces[name])
            self._surface[key] = (tris, devs, cell_side(tris), axes)
        return self._surface[key]

    def _local_box(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        if name not in self._box:
            lo, hi = kernel.bbox(self.model.part(name).local_shape(), optimal=True)
            self._box[name] = (np.array(lo), np.array(hi))
        return self._box[name]

    def obb(self, name: str, motion: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The part's local box as an oriented box in the world after ``motion``."""
        lo, hi = self._local_box(name)
        t = motion @ self.model.part(name).placement
        return t[:3, :3] @ ((lo + hi) / 2) + t[:3, 3], t[:3, :3], (hi - lo) / 2

    def extent(self, name: str, direction: np.ndarray) -> tuple[float, float]:
        """Exact (min, max) of the placed part along a world unit ``direction``."""
        key = (name, np.round(direction, 12).tobytes())
        if key not in self._extent:
            p = self.model.part(name)
            z = np.asarray(direction, float)
            x = np.cross(z, [1.0, 0, 0] if abs(z[0]) < 0.9 else [0, 1.0, 0])
            x /= np.linalg.norm(x)
            rot = np.eye(4)
            rot[:3, :3] = np.array([x, np.cross(z, x), z])  # rows: world -> frame with z = direction
            lo, hi = kernel.bbox(kernel.located(p.local_shape(), rot @ p.placement), optimal=True)
            self._extent[key] = (lo[2], hi[2])
        return self._extent[key]

    def _overlap(self, a: str, ma: np.ndarray, b: str, where: str = "rest") -> Overlap:
        pa, pb = self.model.part(a), self.model.part(b)
        self._spend(lambda: f"{a!r} against {b!r} at {where}")
        return exact_overlap(a, kernel.located(pa.local_shape(), ma @ pa.placement), b, pb.shape())

    def rest(self, a: str, b: str) -> Overlap:
        """Exact interference of two parts at rest (cached)."""
        key = (a, b) if a < b else (b, a)
        if key not in self._rest:
            eye = np.eye(4)
            if _obb_overlap(self.obb(a, eye), self.obb(b, eye), TOL.sweep_box_slack_mm):
                self._rest[key] = self._overlap(key[0], eye, key[1])
            else:
                self._rest[key] = Overlap(key[0], key[1], 0.0, 0.0)
        return self._rest[key]

    def _invariant_dirs(self, joint: Joint) -> list[np.ndarray]:
        if joint.kind.turns:
            return [joint.frame[:3, 2]]
        if joint.kind.slides:
            return [joint.frame[:3, 0], joint.frame[:3, 1]]
        return []

    def _corners_in(self, name: str, frame_inv: np.ndarray) -> np.ndarray:
        """The part's local box corners in the coordinates of a joint frame."""
        lo, hi = self._local_box(name)
        t = frame_inv @ self.model.part(name).placement
        return _corners(lo, hi) @ t[:3, :3].T + t[:3, 3]

    def _may_meet(self, joint: Joint, a: str, b: str, frame_inv: np.ndarray) -> bool:
        """False if ``a``'s swept envelope over the whole joint range cannot reach ``b``'s box."""
        ca, cb = self._corners_in(a, frame_inv), self._corners_in(b, frame_inv)
        blo, bhi = cb.min(axis=0) - TOL.sweep_box_slack_mm, cb.max(axis=0) + TOL.sweep_box_slack_mm
        if joint.kind.slides:
            lo, hi = ca.min(axis=0), ca.max(axis=0)
            lo[2] += 1000.0 * min(0.0, float(joint.lower))  # type: ignore[arg-type]  # a swept joint has limits
            hi[2] += 1000.0 * max(0.0, float(joint.upper))  # type: ignore[arg-type]  # a swept joint has limits
            return bool(np.all(lo <= bhi) and np.all(blo <= hi))
        # the box point nearest the joint origin (spherical) or axis (revolute)
        near = np.clip(0.0, blo, bhi)
        if joint.kind.ball:
            return float(np.linalg.norm(near)) <= float(np.linalg.norm(ca, axis=1).max())
        r_a = float(np.linalg.norm(ca[:, :2], axis=1).max())
        z_ok = ca[:, 2].min() <= bhi[2] and blo[2] <= ca[:, 2].max()
        return bool(z_ok and float(np.linalg.norm(near[:2])) <= r_a)

    def pairs(self, joint: Joint) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
        """(pairs to sweep, pairs that interfere at rest) as (moved, fixed) part names.

        Moved parts are those of the joint's child subtree (rigid with each other: never
        paired); fixed parts are every other part, the parent link's included; only the two
        PARTS a coupling of this joint meshes (``source.mesh``: gear on gear, rack on pinion,
        nut on screw move together; the coupling gate checks them) are not paired: the rest of
        their links is swept against them like any part (the teeth turn within their tip
        circle and a thread within its crest, so a part that enters that envelope collides in
        the machine too). A pair that
        already interferes at rest (thicker than ``TOL.sweep_rest_interference_mm``) is swept
        too (its finding is the increase over the rest thickness) and also listed.
        """
        moving = [p for lk in self.art.subtree(joint.child) for p in self.art.link(lk).parts]
        fixed = [p.name for p in self.model.parts if p.name not in set(moving)]
        # a coupled pair's engaging parts (teeth on teeth, a nut on its screw) move together;
        # swept one past the other they would collide: the coupling gate checks that pair
        meshed = {frozenset(c.source.mesh) for c in self.art.couplings
                  if joint.name in (c.driven, c.driver) and all(c.source.mesh)}
        dirs = [d / np.linalg.norm(d) for d in self._invariant_dirs(joint)]
        frame_inv = rigid_inverse(joint.frame)
        keep, at_rest = [], []
        for a in moving:
            for b in fixed:
                if frozenset((a, b)) in meshed:
                    continue
                if not self._may_meet(joint, a, b, frame_inv):
                    continue
                if any(_slab_gap(self.extent(a, d), self.extent(b, d)) for d in dirs):
                    continue
                if self.rest(a, b).depth > TOL.sweep_rest_interference_mm:
                    at_rest.append((a, b))
                keep.append((a, b))
        return keep, at_rest

    def _near(self, joint: Joint, a: str, b: str, side: int) -> tuple[tuple[np.ndarray, ...],
                                                                       tuple[np.ndarray, ...]]:
        """Per part of the pair, (triangles, their deviations, cell side, their cylinder axes)
        of the faces it is swept with (``b``'s faces, ``a``'s without its invariant ones; with ``side`` 1, a pair
        clear at the start, only those that can start an overlap, :meth:`surface`), kept only
        where their orbit can come within reach of the other part's (:func:`_orbit_boxes`): the
        cells of a large part far from the joint's reach are never laid."""
        key = (a, b, joint.name, joint.type, side)
        if key not in self._pair_near:
            ta, da, ca, xa = self.surface(a, joint, side)
            tb, db, cb, xb = self.surface(b, joint if side else None, -side)
            la, lb = float(da.max(initial=0.0)), float(db.max(initial=0.0))
            inv = rigid_inverse(joint.frame)
            reach = cover_radius(ca, la) + cover_radius(cb, lb) + TOL.sweep_box_slack_mm
            lo_a, hi_a = _orbit_boxes(ta, inv, joint.kind.slides)
            lo_b, hi_b = _orbit_boxes(tb, inv, joint.kind.slides)
            # each side against the other's whole orbit box first (linear), then pair by pair
            ia = _in_box(lo_a, hi_a, lo_b.min(axis=0, initial=np.inf), hi_b.max(axis=0, initial=-np.inf), reach)
            ib = _in_box(lo_b, hi_b, lo_a.min(axis=0, initial=np.inf), hi_a.max(axis=0, initial=-np.inf), reach)
            near = box_pairs(lo_a[ia], hi_a[ia], reach, lo_b[ib], hi_b[ib])
            keep_a, keep_b = ia[np.unique(near[:, 0])], ib[np.unique(near[:, 1])]
            self._pair_near[key] = ((ta[keep_a], da[keep_a], ca, xa[keep_a]),
                                    (tb[keep_b], db[keep_b], cb, xb[keep_b]))
        return self._pair_near[key]

    def _covers(self, joint: Joint, a: str, b: str, side: int) -> tuple[tuple[Cover, cKDTree | None],
                                                                         tuple[Cover, cKDTree | None]]:
        """The covers a pair is swept with: of the triangles :meth:`_near` keeps."""
        key = (a, b, joint.name, joint.type, side)
        if key not in self._pair_cover:
            (ta, da, ca, _), (tb, db, cb, _) = self._near(joint, a, b, side)
            self._pair_cover[key] = (_with_tree(cover_of(ta, float(da.max(initial=0.0)), ca)),
                                     _with_tree(cover_of(tb, float(db.max(initial=0.0)), cb)))
        return self._pair_cover[key]

    def clear_start(self, joint: Joint, a: str, b: str) -> int:
        """1 when the pair is swept on the faces that can start an overlap only (a slide's
        leading and opposing faces; a turn's faces that are not invariant under it, on both
        parts): the parts do not overlap where the sweep starts (exactly: no common thicker
        than ``TOL.sweep_rest_interference_mm``); else 0."""
        if joint.kind.endless:
            q = 0.0
        elif (joint.kind.slides or joint.kind.turns) and joint.lower is not None:
            q = float(joint.lower)
        else:
            return 0
        m = motion(joint, q)
        if np.allclose(m, np.eye(4), atol=1e-12):
            depth = self.rest(a, b).depth
        elif _obb_overlap(self.obb(a, m), self.obb(b, np.eye(4)), TOL.sweep_box_slack_mm):
            depth = self._overlap(a, m, b, label(joint, q)).depth
        else:
            depth = 0.0
        return 1 if depth <= TOL.sweep_rest_interference_mm else 0

    def _moving_faces_apart(self, joint: Joint, a: str, b: str, side: int) -> bool:
        """True when, for a pair clear at the start, the faces that can start an overlap (``a``'s
        and ``b``'s kept faces where their orbits can meet, :meth:`_near`) overlap by less than
        ``TOL.sim_penetration_mm`` along a direction the motion preserves (a turn's axis; a
        slide's two cross directions):
        an overlap can only begin where two such faces meet, and one that begins there stays
        within that slab, as :func:`_slab_gap` argues for whole parts. The extents are the
        triangles' vertices (on the exact faces) widened by the faces' deviation from them."""
        (ta, da, _, xa), (tb, db, _, xb) = self._near(joint, a, b, side)
        if not len(ta) or not len(tb):
            return True  # nothing of one side can start an overlap
        for d in self._invariant_dirs(joint):
            d = d / np.linalg.norm(d)
            pa, pb = ta @ d, tb @ d  # (n, 3) vertex heights along d
            # a cylinder's chords deviate across its axis only: along d by sin(axis, d)
            ea = da * np.sqrt(np.clip(1.0 - (xa @ d) ** 2, 0.0, 1.0))
            eb = db * np.sqrt(np.clip(1.0 - (xb @ d) ** 2, 0.0, 1.0))
            overlap = (min(float((pa.max(axis=1) + ea).max()), float((pb.max(axis=1) + eb).max()))
                       - max(float((pa.min(axis=1) - ea).min()), float((pb.min(axis=1) - eb).min())))
            if overlap < TOL.sim_penetration_mm:
                return True
        return False

    def orbit_cells(self, joint: Joint, a: str, b: str, side: int = 0) -> tuple[np.ndarray, float]:
        """(centres of ``a``'s surface cells whose orbit under the joint passes near ``b``'s
        cells, the largest distance from the axis of any point in them, mm; 0 for a prismatic
        joint, whose points all move alike); ``side`` as :meth:`clear_start`."""
        (ca, _), (cb, _) = self._covers(joint, a, b, side)
        if not len(ca.centres) or not len(cb.centres):
            return ca.centres[:0], 0.0
        inv = rigid_inverse(joint.frame)
        pa = ca.centres @ inv[:3, :3].T + inv[:3, 3]
        pb = cb.centres @ inv[:3, :3].T + inv[:3, 3]
        reach = ca.radius + cb.radius
        if joint.kind.slides:  # the orbit of a point is a line along the axis
            qa, qb = pa[:, :2], pb[:, :2]
        else:  # a circle about the axis: radius and height
            qa = np.column_stack([np.linalg.norm(pa[:, :2], axis=1), pa[:, 2]])
            qb = np.column_stack([np.linalg.norm(pb[:, :2], axis=1), pb[:, 2]])
        dist, _ = cKDTree(qb).query(qa, distance_upper_bound=reach)
        near = np.isfinite(dist)
        if not near.any():
            return ca.centres[:0], 0.0
        radius = 0.0 if joint.kind.slides else float(qa[near, 0].max()) + ca.radius
        return ca.centres[near], radius

    def sweep(self, joint: Joint, extra: tuple[float, ...] = ()) -> SweepHit:
        """The deepest new exact interference over the joint's samples; a sweep that spends
        ``TOL.sweep_max_booleans`` stops there (:attr:`SweepHit.stopped`)."""
        if joint.kind.ball:
            return self._sweep_ball(joint)
        if joint.kind.compound:
            return self._sweep_cylindrical(joint)
        hit = SweepHit(joint.name)
        start = self._joint_start = self.booleans
        todo: list[tuple[str, str]] = []
        try:
            todo, hit.skipped_rest = self.pairs(joint)
            for a, b in todo:
                side = self.clear_start(joint, a, b)
                if side:
                    hit.contact.append((a, b))
                    if self._moving_faces_apart(joint, a, b, side):
                        continue
                cells, radius = self.orbit_cells(joint, a, b, side)
                if not len(cells):
                    continue
                n = self._sweep_pair(joint, a, b, cells, extra, hit, side)
                hit.samples = max(hit.samples, n)
                hit.step_mm = TOL.sweep_step_mm
        except _BudgetSpent as spent:
            hit.stopped = spent.where
        hit.booleans = self.booleans - start
        log.debug("sweep %s: %d samples max, %d pairs, %d booleans, worst %.3g mm", joint.name,
                  hit.samples, len(todo), hit.booleans, hit.depth)
        return hit

    def _sweep_pair(self, joint: Joint, a: str, b: str, cells: np.ndarray,
                    extra: tuple[float, ...], hit: SweepHit, side: int = 0) -> int:
        """Conservative advancement along the range: at each pose every cell's gap to the fixed
        part's cover bounds how far its points may move before they can touch, so the next pose
        is the nearest at which some cell has moved its gap plus ``TOL.sweep_step_mm``, and never
        closer than ``sweep_step_mm`` at the largest lever arm. No point of a cell within reach of
        the fixed part moves more than ``sweep_step_mm`` between two poses. Returns the number of
        poses; the deepest new interference is recorded in ``hit`` as it is found, so a sweep
        stopped at its budget keeps it. With ``side`` (:meth:`clear_start`) the cells are the
        leading and opposing faces' only."""
        (ca, _), (cb, tb) = self._covers(joint, a, b, side)
        inv = rigid_inverse(joint.frame)
        local = cells @ inv[:3, :3].T + inv[:3, 3]
        if joint.kind.slides:  # mm of travel per metre of joint value
            lever = np.full(len(cells), 1000.0)
        else:  # mm per radian
            lever = np.linalg.norm(local[:, :2], axis=1) + ca.radius
        if joint.kind.endless:
            lo, hi = 0.0, 2 * math.pi
        else:
            lo, hi = float(joint.lower), float(joint.upper)  # type: ignore[arg-type]  # a swept joint has limits
        step = TOL.sweep_step_mm
        min_adv = max(step / float(lever.max()), (hi - lo) / MAX_PAIR_SAMPLES)
        reach = ca.radius + cb.radius
        box_b = self.obb(b, np.eye(4))
        rest = self.rest(a, b).depth
        crops = None
        first = ""  # this pair's first pose whose new depth passes TOL.sim_penetration_mm
        outside = [q for q in extra if q < lo - OVERSHOOT_EPS or q > hi + OVERSHOOT_EPS]

        def check(q: float) -> np.ndarray:
            """Check the pose at ``q``; return every cell's gap to the fixed part (mm)."""
            nonlocal crops, first
            m = motion(joint, q)
            dist, _ = tb.query(cells @ m[:3, :3].T + m[:3, 3],
                               distance_upper_bound=reach + ADVANCE_HORIZON_MM)
            gap = np.minimum(dist, reach + ADVANCE_HORIZON_MM) - reach
            if (gap <= 0).any() and _obb_overlap(self.obb(a, m), box_b, TOL.sweep_box_slack_mm):
                if crops is None:
                    crops = self._crops(joint, a, b, local, rest,
                                        (min([lo, *outside]), max([hi, *outside])), ca.radius, side)
                self._spend(lambda: f"{a!r} against {b!r} at {label(joint, q)}")
                o = exact_overlap(a, kernel.located(crops[0], m), b, crops[1])
                new = o.depth - rest
                if new > TOL.sim_penetration_mm and not first:
                    first = label(joint, q)
                if new > hit.depth:
                    hit.depth, hit.volume, hit.first_at = new, o.volume, first
                    hit.pair, hit.at, hit.value = (a, b), label(joint, q), q
                    p = o.point()  # read off the common only for the deepest pose
                    hit.point = [round(float(x), 4) for x in p] if p is not None else []
            return gap

        for q in outside:  # MuJoCo overshoots beyond the commanded range: one pose each
            check(q)
        poses, q = len(outside), lo
        while True:
            gap = check(q)
            poses += 1
            if q >= hi - 1e-12:
                break
            adv = max(float(np.min((np.maximum(gap, 0.0) + step) / lever)), min_adv)
            q = min(q + adv, hi)
            if joint.kind.endless and q >= hi - 1e-12:
                break  # a full turn: 2 pi is the first pose again
        return poses

    def _crops(self, joint: Joint, a: str, b: str, local: np.ndarray, rest: float,
               span: tuple[float, float], radius: float, side: int = 0) -> tuple[object, object]:
        """(``a`` at rest, ``b``) both cut to the region any interference along the sweep lies
        in. For a pair clear at rest every boundary point of a common solid is a moved surface
        point of ``a`` from the relevant cells (``local``, in the joint frame) or a point of
        ``b`` on the orbit of one, and the common lies in the convex hull of its boundary: so it
        lies in the solid cylinder about a revolute axis holding those cells (a box stretched by
        the travel along a prismatic axis), grown by a cell radius and a step. A pair that
        interferes at rest is not cut. ``span`` is the joint values checked (m or rad);
        ``radius`` the cells' radius. With ``side`` (leading and opposing faces only) the cells
        still cover the cross-section both parts share (a solid's faces that oppose a direction
        project onto its whole cross-section), but not the moved part's length along the axis:
        the region then spans the part's whole extent along it (and, for a turn, its whole
        radius about the axis)."""
        pa, pb = self.model.part(a), self.model.part(b)
        if rest > 0.0:
            return pa.shape(), pb.shape()
        from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
        from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
        from OCP.gp import gp_Pnt
        grow = radius + TOL.sweep_step_mm + TOL.sweep_box_slack_mm
        zlo, zhi = float(local[:, 2].min()) - grow, float(local[:, 2].max()) + grow
        if side:
            along = self._corners_in(a, rigid_inverse(joint.frame))[:, 2]
            zlo, zhi = min(zlo, float(along.min()) - grow), max(zhi, float(along.max()) + grow)
        if joint.kind.slides:  # stretched by the travel (``span``, m)
            zlo += 1000.0 * min(0.0, span[0])
            zhi += 1000.0 * max(0.0, span[1])
            xlo, ylo = local[:, :2].min(axis=0) - grow
            xhi, yhi = local[:, :2].max(axis=0) + grow
            region = BRepPrimAPI_MakeBox(gp_Pnt(float(xlo), float(ylo), zlo),
                                         gp_Pnt(float(xhi), float(yhi), zhi)).Shape()
        else:
            r = float(np.linalg.norm(local[:, :2], axis=1).max()) + grow
            if side:  # the invariant faces left out may bound the part farther out
                corners = self._corners_in(a, rigid_inverse(joint.frame))
                r = max(r, float(np.linalg.norm(corners[:, :2], axis=1).max()) + grow)
            region = kernel.located(BRepPrimAPI_MakeCylinder(r, zhi - zlo).Shape(), trans_z(zlo))
        region = kernel.located(region, joint.frame)

        def cut(shape):
            op = BRepAlgoAPI_Common(shape, region)
            return op.Shape() if op.IsDone() else shape
        return cut(pa.shape()), cut(pb.shape())

    def _sweep_cylindrical(self, joint: Joint) -> SweepHit:
        """Both DOF of a cylindrical joint, each over its whole range at the other's compiled
        value (the slide at the home angle, the turn at the home position), each spaced as a
        prismatic or revolute joint's; the worst of the two."""
        import dataclasses
        slide = dataclasses.replace(joint, type=PRISMATIC.name)
        turn = dataclasses.replace(joint, type=(CONTINUOUS if joint.turn_lower is None else REVOLUTE).name,
                                   lower=joint.turn_lower, upper=joint.turn_upper)
        hits = [self.sweep(slide), self.sweep(turn)]
        worst = max(range(2), key=lambda k: hits[k].depth)
        out = dataclasses.replace(hits[worst], joint=joint.name, samples=sum(h.samples for h in hits),
                                  booleans=sum(h.booleans for h in hits),
                                  step_mm=max(h.step_mm for h in hits),
                                  stopped="; ".join(f"{dof}: {h.stopped}" for dof, h in
                                                    zip(("slide", "turn"), hits) if h.stopped))
        if out.pair is not None:
            out.at = f"{('slide', 'turn')[worst]} {out.at}"
        return out

    def _sweep_ball(self, joint: Joint) -> SweepHit:
        hit = SweepHit(joint.name)
        start = self._joint_start = self.booleans
        try:
            todo, hit.skipped_rest = self.pairs(joint)
            for s in samples(joint):
                hit.samples += 1
                for a, b in todo:
                    if not _obb_overlap(self.obb(a, s.motion), self.obb(b, np.eye(4)), TOL.sweep_box_slack_mm):
                        continue
                    o = self._overlap(a, s.motion, b, s.label)
                    new = o.depth - self.rest(a, b).depth
                    if new > hit.depth:
                        hit.depth, hit.volume, hit.pair, hit.at, hit.value = new, o.volume, (a, b), s.label, s.value
        except _BudgetSpent as spent:
            hit.stopped = spent.where
        hit.booleans = self.booleans - start
        return hit


def _with_tree(c: Cover) -> tuple[Cover, cKDTree | None]:
    return c, (cKDTree(c.centres) if len(c.centres) else None)


def _in_box(lo: np.ndarray, hi: np.ndarray, blo: np.ndarray, bhi: np.ndarray,
            gap: float) -> np.ndarray:
    """Indices of the boxes ``lo..hi`` (n, 3) that meet the box ``blo..bhi`` grown by ``gap``."""
    return np.nonzero(np.all(lo <= bhi + gap, axis=1) & np.all(hi >= blo - gap, axis=1))[0]


def _orbit_boxes(tris: np.ndarray, frame_inv: np.ndarray, slides: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle (world mm), a box holding its orbit's coordinates in a joint frame: its
    (x, y) under a slide along Z (every point keeps them), its (distance from the axis, z)
    under a turn about Z (the distance conservatively: its vertices' least less its longest
    edge, to their greatest). The third coordinate is 0, for :func:`box_pairs`."""
    if not len(tris):
        return np.zeros((0, 3)), np.zeros((0, 3))
    p = tris @ frame_inv[:3, :3].T + frame_inv[:3, 3]
    lo, hi = np.zeros((len(p), 3)), np.zeros((len(p), 3))
    if slides:
        lo[:, :2], hi[:, :2] = p[:, :, :2].min(axis=1), p[:, :, :2].max(axis=1)
        return lo, hi
    r = np.linalg.norm(p[:, :, :2], axis=2)
    edge = np.linalg.norm(p[:, :, :2] - np.roll(p[:, :, :2], 1, axis=1), axis=2).max(axis=1)
    lo[:, 0], hi[:, 0] = np.maximum(r.min(axis=1) - edge, 0.0), r.max(axis=1)
    lo[:, 1], hi[:, 1] = p[:, :, 2].min(axis=1), p[:, :, 2].max(axis=1)
    return lo, hi


def trans_z(z: float) -> np.ndarray:
    return trans(z=z)


def _slab_gap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """True if the two extents overlap by less than the penetration tolerance."""
    return min(a[1], b[1]) - max(a[0], b[0]) < TOL.sim_penetration_mm


def tilt_quat(direction_deg: float, tilt_rad: float) -> np.ndarray:
    """MuJoCo ball-joint quaternion (w, x, y, z) of a tilt about (cos d, sin d, 0) in the joint
    frame."""
    phi = math.radians(direction_deg)
    h = tilt_rad / 2
    return np.array([math.cos(h), math.sin(h) * math.cos(phi), math.sin(h) * math.sin(phi), 0.0])


def sweep_all(model: CompiledModel, art: Articulation, joints: list[Joint],
              extra: dict[str, tuple[float, ...]] | None = None, *,
              parallel: bool = True) -> tuple[dict[str, SweepHit], int]:
    """``({joint name: its sweep}, exact booleans run)`` of every joint in ``joints``
    (:meth:`SweepScene.sweep`, with ``extra[name]`` as its MuJoCo overshoot).

    With ``parallel`` and a second core, a forked child (:class:`procedura_brep.limited.
    Limited`) shares the work: both processes take the next joint off one queue (a pipe
    holding the joints' indices) until it is empty, each with its own scene, and the child
    sends its sweeps back. Every sweep is the same whichever process runs it (a joint's sweep
    depends on the joint and the model only). A child that fails is not trusted: every joint
    it took is swept again here."""
    import os
    import struct
    extra = extra or {}
    scene = SweepScene(model, art)
    if not parallel or len(joints) < 2 or _cores() < 2:
        return {j.name: scene.sweep(j, extra=extra.get(j.name, ())) for j in joints}, scene.booleans
    from ..limited import ChildFailure, Limited
    r, w = os.pipe()
    try:
        os.write(w, b"".join(struct.pack("<i", k) for k in range(len(joints))))
    finally:
        os.close(w)

    def take() -> Joint | None:
        data = os.read(r, 4)
        return joints[struct.unpack("<i", data)[0]] if len(data) == 4 else None

    def work(send) -> dict:
        mine, out = SweepScene(model, art), {}
        while (j := take()) is not None:
            out[j.name] = dataclasses.asdict(mine.sweep(j, extra=extra.get(j.name, ())))
        return {"hits": out, "booleans": mine.booleans}

    hits: dict[str, SweepHit] = {}
    booleans = 0
    try:
        child = Limited(work, stage="battery sweeps")
        try:
            while (j := take()) is not None:
                hits[j.name] = scene.sweep(j, extra=extra.get(j.name, ()))
            try:
                got = child.collect()
                hits.update({n: _hit_from(h) for n, h in got["hits"].items()})
                booleans = int(got["booleans"])
            except ChildFailure as exc:
                log.warning("the sweeps' second process failed (%s); sweeping its joints here", exc)
        finally:
            child.close()
    finally:
        os.close(r)
    for j in joints:
        if j.name not in hits:
            hits[j.name] = scene.sweep(j, extra=extra.get(j.name, ()))
    return {j.name: hits[j.name] for j in joints}, booleans + scene.booleans


def _hit_from(d: dict) -> SweepHit:
    """A :class:`SweepHit` from its ``dataclasses.asdict`` sent as JSON (tuples came back as
    lists)."""
    d = dict(d)
    for k in ("pair", "value"):
        if isinstance(d.get(k), list):
            d[k] = tuple(d[k])
    for k in ("skipped_rest", "contact"):
        d[k] = [tuple(p) for p in d.get(k) or []]
    return SweepHit(**d)


def _cores() -> int:
    import os
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1
