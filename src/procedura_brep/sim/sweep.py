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
* a pair is skipped when one part lies wholly inside a cylinder about the joint's line (a
  slide's: the line through its frame along its travel) that the other lies wholly outside
  (:meth:`SweepScene.radially_apart`: tessellation radii widened by their deviation): every
  motion about or along that line keeps each point's distance from it (a thread inside a
  clearance bore, whose every boolean costs seconds, costs none);
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
  on such a face, so a tilting head between the cheeks of its yoke costs no boolean there;
* a pair clear at the start is dropped when the faces that can start an overlap meet only in
  thin slabs along a direction the motion preserves (:meth:`SweepScene._moving_faces_apart`):
  a moved point enters the fixed part through a fixed face it crosses at its own height, so
  the common lies where some near pair of such triangles (their heights widened by their
  deviation, then kept within their exact face's extent) overlaps in height; a head whose
  fillets cross its cheek's end faces in the plane where its side touches the cheek meets the
  cheek in a sheet, never a solid.

A sweep that still spends ``TOL.sweep_max_booleans``, or runs longer than ``TOL.sweep_time_s``
(checked between booleans and between poses: one OCCT boolean cannot be interrupted from Python,
OCP binds ``Message_ProgressIndicator`` without a way to subclass it), stops and is **not
verified** (it names the pair and the pose it reached), never a pass and never a failure of parts
that merely touch.

**Couplings** (gear, rack and pinion, screw, belt): a joint that another drives
(:meth:`Articulation.root_driver`) is not swept on its own; the head of its chain is swept, and
at every head value ``q`` each joint it drives, directly or through a chain, stands at
``ratio * q`` (positions from the compiled pose, where every coupled pair meshes). The head's
range keeps every driven joint inside its limits; a continuous head with no limited joint in its
chain turns until each continuous joint of the chain has turned once (relative phases of two
turning parts that repeat only after more turns are not all sampled). Parts then fall into groups
that move alike (the moving joints on their path from the root); every two parts of different
groups are a pair, except the two parts a coupling meshes (``source.mesh``: the coupling gate
checks them). A pair whose relative motion is one joint's (a part on the driven carriage against
a fixed stop; a part on the driven link against one on the driver's link when the driven joint
hangs below the driver) is swept as that joint over its coupled values, with every prefilter
above. Any other pair (a part on the turning screw against one on the sliding carriage) is swept
*compound* (:meth:`SweepScene._sweep_compound`): both parts posed relative to each other at each
head value, whole surface covers, conservative advancement with each point's speed bounded by
the sum over the joints that move it of ``|ratio|`` times its lever about that joint (a slide's
1000 mm/m), so the 1 mm guarantee holds for every moved part; when the pair's relative motion is
about one line (a screw turning in a nut's carriage) and the pair is clear at the start, the faces
that motion maps onto themselves are left out as for a turn. Linkages (type ``linkage``, ratio
0: a closed loop) are not followed: a joint a linkage moves is swept on its own range, as before.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .. import kernel
from ..articulation.tree import Articulation, Joint
from ..config import TOL
from ..gates.geometry import box_pairs
from ..mates.kinds import CONTINUOUS, PRISMATIC, REVOLUTE, Motion
from ..mates.placement import motion_delta, plane_basis, rigid_inverse, rot_x, rot_z, trans
from ..program.model import CompiledModel
from .cells import (
    Cover,
    Face,
    cell_side,
    cover_of,
    cover_radius,
    faces,
    faces_along,
    nearest_to_origin,
    radial_apart,
    radial_range,
    surface,
)
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
    #: Where the sweep stopped because it spent ``TOL.sweep_max_booleans`` or ran past
    #: ``TOL.sweep_time_s`` ("" if it did not): "<moved> against <fixed> at <pose>". A stopped
    #: sweep is unfinished: the poses after it are **not verified** (B2 says so; it neither
    #: passes nor fails them).
    stopped: str = ""
    #: The first pose (label) at which the worst pair's new interference exceeded
    #: ``TOL.sim_penetration_mm``: where the moved part meets the fixed one ("" if none).
    first_at: str = ""
    #: Pairs clear at the range's start, swept on the faces that can start an overlap only
    #: (sliding and turning contact, see the module).
    contact: list[tuple[str, str]] = field(default_factory=list)
    #: World point (mm) inside the worst common, at the pose ``at``.
    point: list[float] = field(default_factory=list)
    #: What stopped the sweep: "booleans" (``TOL.sweep_max_booleans``), "time"
    #: (``TOL.sweep_time_s``) or "" (it finished).
    stopped_by: str = ""
    #: A driven joint's: the head of its chain of couplings, whose sweep moved it ("" for a
    #: joint swept itself).
    swept_with: str = ""

    def as_dict(self) -> dict:
        return {"new_penetration_mm": self.depth, "volume_mm3": self.volume,
                "pair": list(self.pair) if self.pair else None, "at": self.at,
                "first_at": self.first_at or None, "point_mm": self.point or None,
                "samples": self.samples, "booleans": self.booleans,
                "max_step_mm": self.step_mm,
                "rest_interfering_pairs": [list(p) for p in self.skipped_rest],
                "contact_pairs": [list(p) for p in self.contact],
                "not_verified": self.stopped or None, "stopped_by": self.stopped_by or None,
                "swept_with": self.swept_with or None}


class _BudgetSpent(Exception):
    """A joint's sweep reached ``TOL.sweep_max_booleans`` (``by`` "booleans") or
    ``TOL.sweep_time_s`` (``by`` "time") (internal: :meth:`SweepScene.sweep` turns it into
    :attr:`SweepHit.stopped`)."""

    def __init__(self, where: str, by: str = "booleans") -> None:
        super().__init__(where)
        self.where, self.by = where, by


def _stop(hit: SweepHit, spent: _BudgetSpent) -> None:
    hit.stopped, hit.stopped_by = spent.where, spent.by


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
        self._surface: dict[tuple[str, bytes, bytes], tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]] = {}
        self._pair_cover: dict[tuple, tuple[tuple[Cover, cKDTree | None], tuple[Cover, cKDTree | None]]] = {}
        self._faces: dict[str, list[Face]] = {}  # each part's meshed faces, read once
        self._pair_near: dict[tuple, tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]] = {}
        self._whole: dict[str, tuple[Cover, cKDTree | None]] = {}  # compound pairs' covers
        self._radii: dict[tuple[str, bytes], tuple[float, float]] = {}  # radial ranges by line
        self._near_pairs: dict[tuple, np.ndarray] = {}  # :meth:`_near`'s triangle pairs
        self._extent_face: dict[tuple[str, int, bytes], tuple[float, float]] = {}
        self.booleans = 0
        self._joint_start = 0  # self.booleans when the current joint's sweep began
        self._deadline = math.inf  # time.monotonic() past which the current joint's sweep stops

    def _spend(self, where: Callable[[], str]) -> None:
        """Count one exact boolean of the current joint's sweep; past the budget or the time
        bound, stop the sweep (``where`` is called for the message only then)."""
        if self.booleans - self._joint_start >= TOL.sweep_max_booleans:
            raise _BudgetSpent(where())
        self._tick(where)
        self.booleans += 1

    def _tick(self, where: Callable[[], str]) -> None:
        """Stop the current joint's sweep once it has run ``TOL.sweep_time_s``."""
        if time.monotonic() > self._deadline:
            raise _BudgetSpent(where(), "time")

    def surface(self, name: str, joint: Joint | None = None,
                side: int = 0) -> tuple[np.ndarray, np.ndarray, float, np.ndarray, np.ndarray]:
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
            tris, devs, axes, ids = surface(None, axis=axis, keep=keep, meshed=self._faces[name])
            self._surface[key] = (tris, devs, cell_side(tris), axes, ids)
        return self._surface[key]

    def _local_box(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        if name not in self._box:
            self._box[name] = self.model.part(name).local_box()
        return self._box[name]

    def obb(self, name: str, motion: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The part's local box as an oriented box in the world after ``motion``."""
        lo, hi = self._local_box(name)
        t = motion @ self.model.part(name).placement
        return t[:3, :3] @ ((lo + hi) / 2) + t[:3, 3], t[:3, :3], (hi - lo) / 2

    def extent(self, name: str, direction: np.ndarray) -> tuple[float, float]:
        """Exact (min, max) of the placed part along a world unit ``direction`` (cached by the
        part's local geometry: :meth:`procedura_brep.program.model.CompiledPart.extent`)."""
        return self.model.part(name).extent(direction)

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

    def _boxes_in(self, names: list[str], frame_inv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(corners, lo, hi)`` of the parts' local boxes in the coordinates of a joint frame:
        their corners (n, 8, 3) and the axis-aligned boxes (n, 3) around them, grown by
        ``TOL.sweep_box_slack_mm``."""
        if not names:
            empty = np.zeros((0, 3))
            return np.zeros((0, 8, 3)), empty, empty
        local = np.stack([_corners(*self._local_box(n)) for n in names])  # (n, 8, 3)
        t = frame_inv @ np.stack([self.model.part(n).placement for n in names])  # (n, 4, 4)
        pts = np.einsum("nkj,nij->nki", local, t[:, :3, :3]) + t[:, None, :3, 3]
        slack = TOL.sweep_box_slack_mm
        return pts, pts.min(axis=1) - slack, pts.max(axis=1) + slack

    @staticmethod
    def _envelope_meets(joint: Joint, ca: np.ndarray, blo: np.ndarray, bhi: np.ndarray) -> np.ndarray:
        """Per box (``blo``, ``bhi``: (n, 3) in the joint frame's coordinates), whether the swept
        envelope over the whole joint range of a part whose box corners there are ``ca`` (8, 3)
        can reach it."""
        if joint.kind.slides:
            lo, hi = ca.min(axis=0), ca.max(axis=0)
            lo[2] += 1000.0 * min(0.0, float(joint.lower))  # type: ignore[arg-type]  # a swept joint has limits
            hi[2] += 1000.0 * max(0.0, float(joint.upper))  # type: ignore[arg-type]  # a swept joint has limits
            out: np.ndarray = np.all(lo <= bhi, axis=1) & np.all(blo <= hi, axis=1)
            return out
        # each box's point nearest the joint origin (spherical) or axis (revolute)
        near = np.clip(0.0, blo, bhi)
        if joint.kind.ball:
            out = np.linalg.norm(near, axis=1) <= float(np.linalg.norm(ca, axis=1).max())
            return out
        r_a = float(np.linalg.norm(ca[:, :2], axis=1).max())
        z_ok = (ca[:, 2].min() <= bhi[:, 2]) & (blo[:, 2] <= ca[:, 2].max())
        out = z_ok & (np.linalg.norm(near[:, :2], axis=1) <= r_a)
        return out

    def _may_meet(self, joint: Joint, a: str, b: str, frame_inv: np.ndarray) -> bool:
        """False if ``a``'s swept envelope over the whole joint range cannot reach ``b``'s box."""
        (ca,), _, _ = self._boxes_in([a], frame_inv)
        _, blo, bhi = self._boxes_in([b], frame_inv)
        return bool(self._envelope_meets(joint, ca, blo, bhi)[0])

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
        moved = set(moving)
        fixed = [p.name for p in self.model.parts if p.name not in moved]
        meshed = self._meshed({joint.name})
        keep, at_rest = [], []
        # the envelope test for every pair at once (a loop of pairs was quadratic in Python)
        frame_inv = rigid_inverse(joint.frame)
        corners, _, _ = self._boxes_in(moving, frame_inv)
        _, blo, bhi = self._boxes_in(fixed, frame_inv)
        for a, ca in zip(moving, corners):
            meets = self._envelope_meets(joint, ca, blo, bhi)
            for b in (b for b, ok in zip(fixed, meets) if ok):
                if frozenset((a, b)) in meshed or not self._may_collide(joint, a, b, envelope=False):
                    continue
                if self.rest(a, b).depth > TOL.sweep_rest_interference_mm:
                    at_rest.append((a, b))
                keep.append((a, b))
        return keep, at_rest

    def _meshed(self, joints: set[str]) -> set[frozenset[str]]:
        """The part pairs the couplings of ``joints`` mesh: a coupled pair's engaging parts
        (teeth on teeth, a nut on its screw) move together; swept one past the other they would
        collide: the coupling gate checks that pair."""
        return {frozenset(c.source.mesh) for c in self.art.couplings
                if {c.driven, c.driver} & joints and all(c.source.mesh)}

    def _may_collide(self, joint: Joint, a: str, b: str, *, envelope: bool = True) -> bool:
        """False when moving ``a`` by ``joint`` over its range cannot bring it into ``b``: its
        swept envelope misses ``b``'s box (not tested again with ``envelope=False``: the
        caller has), or their exact extents along a direction the motion preserves overlap by
        less than ``TOL.sim_penetration_mm``."""
        if envelope and not self._may_meet(joint, a, b, rigid_inverse(joint.frame)):
            return False
        dirs = [d / np.linalg.norm(d) for d in self._invariant_dirs(joint)]
        if any(_slab_gap(self.extent(a, d), self.extent(b, d)) for d in dirs):
            return False
        # last: it reads every triangle of both parts
        return joint.kind.ball or not self.radially_apart(a, b, joint.frame[:3, 3], joint.axis)

    def radially_apart(self, a: str, b: str, point: np.ndarray, axis: np.ndarray) -> bool:
        """Whether one of the parts lies wholly inside a cylinder about the line (``point``,
        ``axis``) that the other lies wholly outside (:func:`.cells.radial_range`, conservative):
        a turn about that line, a slide along it, or both keep every point's distance from it,
        so such a pair never meets (a screw in a carriage's clearance bore, a shaft in the bore
        of a hub it does not touch: threads make each of their booleans cost seconds)."""
        u = np.asarray(axis, float) / float(np.linalg.norm(axis))
        p = np.asarray(point, float) - float(np.asarray(point, float) @ u) * u  # canonical point
        key = np.round(np.concatenate([p, u]), 9).tobytes()
        return radial_apart(self._radial(a, key, p, u), self._radial(b, key, p, u))

    def _radial(self, name: str, key: bytes, p: np.ndarray, u: np.ndarray) -> tuple[float, float]:
        if (name, key) not in self._radii:
            if name not in self._faces:
                self._faces[name] = faces(self.model.part(name).shape())
            tris, devs, _, _ = surface(None, meshed=self._faces[name])
            self._radii[(name, key)] = radial_range(tris, devs, p, u)
        return self._radii[(name, key)]

    def _near(self, joint: Joint, a: str, b: str, side: int) -> tuple[tuple[np.ndarray, ...],
                                                                       tuple[np.ndarray, ...]]:
        """Per part of the pair, (triangles, their deviations, cell side, their cylinder axes)
        of the faces it is swept with (``b``'s faces, ``a``'s without its invariant ones; with ``side`` 1, a pair
        clear at the start, only those that can start an overlap, :meth:`surface`), kept only
        where their orbit can come within reach of the other part's (:func:`_orbit_boxes`): the
        cells of a large part far from the joint's reach are never laid."""
        key = (a, b, joint.name, joint.type, side)
        if key not in self._pair_near:
            ta, da, ca, xa, fa = self.surface(a, joint, side)
            tb, db, cb, xb, fb = self.surface(b, joint if side else None, -side)
            la, lb = float(da.max(initial=0.0)), float(db.max(initial=0.0))
            inv = rigid_inverse(joint.frame)
            reach = cover_radius(ca, la) + cover_radius(cb, lb) + TOL.sweep_box_slack_mm
            lo_a, hi_a = _orbit_boxes(ta, inv, joint.kind.slides)
            lo_b, hi_b = _orbit_boxes(tb, inv, joint.kind.slides)
            # each side against the other's whole orbit box first (linear), then pair by pair
            ia = _in_box(lo_a, hi_a, lo_b.min(axis=0, initial=np.inf), hi_b.max(axis=0, initial=-np.inf), reach)
            ib = _in_box(lo_b, hi_b, lo_a.min(axis=0, initial=np.inf), hi_a.max(axis=0, initial=-np.inf), reach)
            near = box_pairs(lo_a[ia], hi_a[ia], reach, lo_b[ib], hi_b[ib])
            ua, ra = np.unique(near[:, 0], return_inverse=True)
            ub, rb = np.unique(near[:, 1], return_inverse=True)
            keep_a, keep_b = ia[ua], ib[ub]
            self._pair_near[key] = ((ta[keep_a], da[keep_a], ca, xa[keep_a], fa[keep_a]),
                                    (tb[keep_b], db[keep_b], cb, xb[keep_b], fb[keep_b]))
            # the near triangle pairs, as indices into the kept triangles
            self._near_pairs[key] = np.column_stack([ra.ravel(), rb.ravel()]).astype(np.int64)
        return self._pair_near[key]

    def _covers(self, joint: Joint, a: str, b: str, side: int) -> tuple[tuple[Cover, cKDTree | None],
                                                                         tuple[Cover, cKDTree | None]]:
        """The covers a pair is swept with: of the triangles :meth:`_near` keeps."""
        key = (a, b, joint.name, joint.type, side)
        if key not in self._pair_cover:
            (ta, da, ca, _, _), (tb, db, cb, _, _) = self._near(joint, a, b, side)
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
        triangles' vertices (on the exact faces) widened by the faces' deviation from them,
        within each part's exact extent.

        Then pair by pair: a point of the common got there when a kept face of ``a`` carried
        it across a kept face of ``b`` (the invariant faces of either move within themselves),
        at its own height along the direction, where the two faces' triangles are a near pair
        of :meth:`_near` whose heights overlap. So the common lies in the union of those
        overlaps; when every piece of the union is thinner than the tolerance, so is the common
        (:func:`_thin_union`). The heights of a curved face's triangles are kept within that
        face's exact extent (:meth:`_face_heights`) when the deviation alone leaves a piece
        too thick."""
        (ta, da, _, xa, fa), (tb, db, _, xb, fb) = self._near(joint, a, b, side)
        if not len(ta) or not len(tb):
            return True  # nothing of one side can start an overlap
        pairs = self._near_pairs[(a, b, joint.name, joint.type, side)]
        for d in self._invariant_dirs(joint):
            d = d / np.linalg.norm(d)
            lo_a, hi_a = _heights(ta, da, xa, d, self.extent(a, d))
            lo_b, hi_b = _heights(tb, db, xb, d, self.extent(b, d))
            overlap = min(float(hi_a.max()), float(hi_b.max())) - max(float(lo_a.min()), float(lo_b.min()))
            if overlap < TOL.sim_penetration_mm:
                return True
            # pair by pair: the common lies where some near pair's heights overlap
            if _thin_union(*_overlaps(pairs, (lo_a, hi_a), (lo_b, hi_b)), TOL.sim_penetration_mm):
                return True
            # the curved faces' triangles widened by their deviation: their faces' exact heights
            if _thin_union(*_overlaps(pairs, self._face_heights(a, fa, da, d, lo_a, hi_a),
                                      self._face_heights(b, fb, db, d, lo_b, hi_b)),
                           TOL.sim_penetration_mm):
                return True
        return False

    def _face_heights(self, name: str, ids: np.ndarray, devs: np.ndarray, d: np.ndarray,
                      lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``lo``, ``hi`` (per triangle of ``name``, from :func:`_heights`) kept within the
        exact extent along unit ``d`` of the face each triangle is laid on (``ids``: indices into
        :func:`.cells.faces` of the part), for the triangles that deviate (curved faces)."""
        lo, hi = lo.copy(), hi.copy()
        for k in np.unique(ids[devs > 0]):
            f_lo, f_hi = self._face_extent(name, int(k), d)
            on = ids == k
            lo[on], hi[on] = np.maximum(lo[on], f_lo), np.minimum(hi[on], f_hi)
        return lo, hi

    def _face_extent(self, name: str, k: int, d: np.ndarray) -> tuple[float, float]:
        """Exact (min, max) along a world unit ``d`` of face ``k`` of the placed part."""
        key = (name, k, np.round(d, 12).tobytes())
        if key not in self._extent_face:
            self._extent_face[key] = _height_range(self._faces[name][k].face, d)
        return self._extent_face[key]

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
        """The deepest new exact interference over the joint's samples, with every joint it
        drives through couplings moved with it (see the module); a sweep that spends
        ``TOL.sweep_max_booleans`` or runs ``TOL.sweep_time_s`` stops there
        (:attr:`SweepHit.stopped`). A joint that another drives is swept here on its own range,
        alone (:func:`sweep_all` sweeps it with the head of its chain instead)."""
        self._deadline = time.monotonic() + TOL.sweep_time_s
        try:
            return self._sweep(joint, extra)
        finally:
            self._deadline = math.inf

    def _sweep(self, joint: Joint, extra: tuple[float, ...] = ()) -> SweepHit:
        if joint.kind.ball:
            return self._sweep_ball(joint)
        if joint.kind.compound:
            return self._sweep_cylindrical(joint)
        chain = coupled_chain(self.art, joint)
        if chain:
            return self._sweep_coupled(joint, chain, extra)
        hit = SweepHit(joint.name)
        start = self._joint_start = self.booleans
        todo: list[tuple[str, str]] = []
        try:
            todo, hit.skipped_rest = self.pairs(joint)
            for a, b in todo:
                self._sweep_single(joint, a, b, extra, hit)
        except _BudgetSpent as spent:
            _stop(hit, spent)
        hit.booleans = self.booleans - start
        log.debug("sweep %s: %d samples max, %d pairs, %d booleans, worst %.3g mm", joint.name,
                  hit.samples, len(todo), hit.booleans, hit.depth)
        return hit

    def _sweep_single(self, joint: Joint, a: str, b: str, extra: tuple[float, ...], hit: SweepHit,
                      head: tuple[Joint, float] | None = None) -> None:
        """One (moved, fixed) pair along ``joint``'s range (moving contact, orbit cells,
        conservative advancement). With ``head`` = (the head joint, this joint's ratio to it),
        the joint is one its head drives: poses are labelled and valued by the head too."""
        side = self.clear_start(joint, a, b)
        if side:
            hit.contact.append((a, b))
            if self._moving_faces_apart(joint, a, b, side):
                return
        cells, radius = self.orbit_cells(joint, a, b, side)
        if not len(cells):
            return
        n = self._sweep_pair(joint, a, b, cells, extra, hit, side, head)
        hit.samples = max(hit.samples, n)
        hit.step_mm = TOL.sweep_step_mm

    def _sweep_pair(self, joint: Joint, a: str, b: str, cells: np.ndarray,
                    extra: tuple[float, ...], hit: SweepHit, side: int = 0,
                    head: tuple[Joint, float] | None = None) -> int:
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

        def name(q: float) -> str:
            if head is None or head[0].name == joint.name:
                return label(joint, q)
            return f"{joint.name} {label(joint, q)} ({head[0].name} {label(head[0], q / head[1])})"

        def check(q: float) -> np.ndarray:
            """Check the pose at ``q``; return every cell's gap to the fixed part (mm)."""
            nonlocal crops, first
            self._tick(lambda: f"{a!r} against {b!r} at {name(q)}")
            m = motion(joint, q)
            dist, _ = tb.query(cells @ m[:3, :3].T + m[:3, 3],
                               distance_upper_bound=reach + ADVANCE_HORIZON_MM)
            gap = np.minimum(dist, reach + ADVANCE_HORIZON_MM) - reach
            if (gap <= 0).any() and _obb_overlap(self.obb(a, m), box_b, TOL.sweep_box_slack_mm):
                if crops is None:
                    crops = self._crops(joint, a, b, local, rest,
                                        (min([lo, *outside]), max([hi, *outside])), ca.radius, side)
                self._spend(lambda: f"{a!r} against {b!r} at {name(q)}")
                o = exact_overlap(a, kernel.located(crops[0], m), b, crops[1])
                new = o.depth - rest
                if new > TOL.sim_penetration_mm and not first:
                    first = name(q)
                if new > hit.depth:
                    hit.depth, hit.volume, hit.first_at = new, o.volume, first
                    hit.pair, hit.at = (a, b), name(q)
                    hit.value = q if head is None else q / head[1]
                    p = o.point()  # read off the common only for the deepest pose
                    hit.point = [round(float(x), 4) for x in p] if p is not None else []
            return gap

        return _advance(check, outside, lo, hi, step, lever, min_adv, endless=joint.kind.endless)

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
        hits = [self._sweep(slide), self._sweep(turn)]
        worst = max(range(2), key=lambda k: hits[k].depth)
        out = dataclasses.replace(hits[worst], joint=joint.name, samples=sum(h.samples for h in hits),
                                  booleans=sum(h.booleans for h in hits),
                                  step_mm=max(h.step_mm for h in hits),
                                  stopped="; ".join(f"{dof}: {h.stopped}" for dof, h in
                                                    zip(("slide", "turn"), hits) if h.stopped),
                                  stopped_by=next((h.stopped_by for h in hits if h.stopped_by), ""))
        if out.pair is not None:
            out.at = f"{('slide', 'turn')[worst]} {out.at}"
        return out

    def _sweep_ball(self, joint: Joint) -> SweepHit:
        hit = SweepHit(joint.name)
        start = self._joint_start = self.booleans
        try:
            todo, hit.skipped_rest = self.pairs(joint)
            for s in samples(joint):
                self._tick(lambda s=s: f"{joint.name!r} at {s.label}")  # type: ignore[misc]  # s bound now
                hit.samples += 1
                for a, b in todo:
                    if not _obb_overlap(self.obb(a, s.motion), self.obb(b, np.eye(4)), TOL.sweep_box_slack_mm):
                        continue
                    o = self._overlap(a, s.motion, b, s.label)
                    new = o.depth - self.rest(a, b).depth
                    if new > hit.depth:
                        hit.depth, hit.volume, hit.pair, hit.at, hit.value = new, o.volume, (a, b), s.label, s.value
        except _BudgetSpent as spent:
            _stop(hit, spent)
        hit.booleans = self.booleans - start
        return hit

    # --- couplings: a head joint and every joint it drives ---------------------------------

    def _path_joints(self, part: str, moving: dict[str, float]) -> tuple[str, ...]:
        """The joints of ``moving`` on the path from the root to ``part``'s link, root first."""
        out: list[str] = []
        lk = self.art.part_link[part]
        while (pj := self.art.link(lk).parent_joint) is not None:
            if pj in moving:
                out.append(pj)
            lk = self.art.joint(pj).parent
        return tuple(reversed(out))

    def _sweep_coupled(self, head: Joint, chain: list[tuple[Joint, float]],
                       extra: tuple[float, ...]) -> SweepHit:
        """``head`` swept with every joint of ``chain`` (joint, ratio) at ``ratio * q``: each
        pair of parts that move differently, as one joint's sweep where their relative motion
        is one joint's, else :meth:`_sweep_compound` (see the module)."""
        hit = SweepHit(head.name)
        start = self._joint_start = self.booleans
        lo, hi = chain_range(head, chain)
        ratios = {head.name: 1.0, **{j.name: r for j, r in chain}}
        meshed = self._meshed(set(ratios))
        path = {p.name: self._path_joints(p.name, ratios) for p in self.model.parts}
        names = [p.name for p in self.model.parts]
        pairs = 0
        try:
            for i, a0 in enumerate(names):
                for b0 in names[i + 1:]:
                    a, b, pa, pb = a0, b0, path[a0], path[b0]
                    if pa == pb or frozenset((a, b)) in meshed:
                        continue
                    k = 0
                    while k < min(len(pa), len(pb)) and pa[k] == pb[k]:
                        k += 1
                    ra, rb = pa[k:], pb[k:]  # the common part moves both alike
                    if not ra:
                        a, b, ra, rb = b, a, rb, ra
                    if len(ra) == 1 and not rb:  # one joint moves a against b
                        j = self.art.joint(ra[0])
                        v = _virtual(j, ratios[j.name], lo, hi)
                        if not self._may_collide(v, a, b):
                            continue
                        pairs += 1
                        if self.rest(a, b).depth > TOL.sweep_rest_interference_mm:
                            hit.skipped_rest.append((a, b))
                        scaled = tuple(ratios[j.name] * e for e in extra)
                        self._sweep_single(v, a, b, scaled, hit, (head, ratios[j.name]))
                        continue
                    moves_a = [(self.art.joint(n), ratios[n]) for n in ra]
                    moves_b = [(self.art.joint(n), ratios[n]) for n in rb]
                    if self._sweep_compound(head, (lo, hi), a, moves_a, b, moves_b, extra, hit):
                        pairs += 1
        except _BudgetSpent as spent:
            _stop(hit, spent)
        hit.booleans = self.booleans - start
        log.debug("coupled sweep %s (%s) over %.4g..%.4g: %d pairs, %d booleans, worst %.3g mm",
                  head.name, ", ".join(j.name for j, _ in chain), lo, hi, pairs, hit.booleans,
                  hit.depth)
        return hit

    def _whole_cover(self, name: str, drop=None) -> tuple[Cover, cKDTree | None]:
        """The sphere cover of all of the placed part's faces (without those ``drop`` =
        (key, filter) leaves out), cached."""
        key = name if drop is None else f"{name}\0{drop[0]}"
        if key not in self._whole:
            if name not in self._faces:
                self._faces[name] = faces(self.model.part(name).shape())
            tris, devs, _, _ = surface(None, meshed=self._faces[name],
                                       keep=None if drop is None else drop[1])
            self._whole[key] = _with_tree(cover_of(tris, float(devs.max(initial=0.0)), cell_side(tris)))
        return self._whole[key]

    def _sweep_compound(self, head: Joint, span: tuple[float, float], a: str,
                        moves_a: list[tuple[Joint, float]], b: str,
                        moves_b: list[tuple[Joint, float]], extra: tuple[float, ...],
                        hit: SweepHit) -> bool:
        """A pair whose relative motion is more than one joint's (``moves_a``, ``moves_b``:
        (joint, ratio) from the pair's common ancestor down, root first): at each head value
        ``q`` in ``span`` ``a`` is posed relative to ``b`` (``M_b(q)^-1 M_a(q)``) and checked
        like a single joint's pair (covers, oriented boxes, the exact common), advancing by
        conservative advancement with each cell's speed bounded by :func:`_chain_lever` of both
        chains. The pair's sweep ends at its first pose whose new interference passes
        ``TOL.sim_penetration_mm`` (B2 fails there): the deepest pose is not sought, since every
        pose past it would be an exact boolean one step of the fastest part apart (a collar
        turning with the screw, against the carriage that creeps along it, 0.04 mm of travel per
        pose, spent the whole boolean budget). False when the pair cannot meet (their envelopes,
        :func:`_envelope`, are apart)."""
        lo, hi = span
        outside = [q for q in extra if q < lo - OVERSHOOT_EPS or q > hi + OVERSHOOT_EPS]
        qlo, qhi = min([lo, *outside]), max([hi, *outside])
        ca_, ra_ = _envelope(self._corners_world(a), moves_a, (qlo, qhi))
        cb_, rb_ = _envelope(self._corners_world(b), moves_b, (qlo, qhi))
        if float(np.linalg.norm(ca_ - cb_)) > ra_ + rb_ + TOL.sweep_box_slack_mm:
            return False
        line = _one_line(moves_a + moves_b)
        if line is not None and self.radially_apart(a, b, *line):
            return False

        def rel(q: float) -> np.ndarray:
            ma, mb = np.eye(4), np.eye(4)
            for j, r in moves_a:
                ma = ma @ motion(j, r * q)
            for j, r in moves_b:
                mb = mb @ motion(j, r * q)
            return rigid_inverse(mb) @ ma

        def name(q: float) -> str:
            return f"{head.name} {label(head, q)}"

        rest = self.rest(a, b).depth
        if rest > TOL.sweep_rest_interference_mm:
            hit.skipped_rest.append((a, b))
        drop = _common_line(moves_a + moves_b)
        side = 0
        if drop is not None and rest <= TOL.sweep_rest_interference_mm:
            m0 = rel(qlo)
            if not _obb_overlap(self.obb(a, m0), self.obb(b, np.eye(4)), TOL.sweep_box_slack_mm):
                side = 1
            else:
                self._spend(lambda: f"{a!r} against {b!r} at {name(qlo)}")
                pa = self.model.part(a)
                o = exact_overlap(a, kernel.located(pa.local_shape(), m0 @ pa.placement), b,
                                  self.model.part(b).shape())
                side = 1 if o.depth <= TOL.sweep_rest_interference_mm else 0
        if side:
            hit.contact.append((a, b))
        ca, _ = self._whole_cover(a, drop if side else None)
        cb, tb = self._whole_cover(b, drop if side else None)
        if not len(ca.centres) or tb is None:
            return True
        cells = ca.centres
        width = max(qhi - qlo, abs(qlo), abs(qhi))
        lever = _chain_lever(cells, ca.radius, moves_a, width)
        reach = ca.radius + cb.radius
        lo_b, hi_b = self._world_box(b)
        grow = reach + ADVANCE_HORIZON_MM
        corners_b = _corners(lo_b - grow, hi_b + grow)
        lever = lever + float(_chain_lever(corners_b, 0.0, moves_b, width).max(initial=0.0))
        if float(lever.max(initial=0.0)) <= 0.0:
            return True
        step = TOL.sweep_step_mm
        min_adv = max(step / float(lever.max()), (qhi - qlo) / MAX_PAIR_SAMPLES)
        box_b = self.obb(b, np.eye(4))
        pa, pb = self.model.part(a), self.model.part(b)
        first = ""

        def check(q: float) -> np.ndarray:
            nonlocal first
            self._tick(lambda: f"{a!r} against {b!r} at {name(q)}")
            m = rel(q)
            dist, _ = tb.query(cells @ m[:3, :3].T + m[:3, 3], distance_upper_bound=grow)
            gap = np.minimum(dist, grow) - reach
            if (gap <= 0).any() and _obb_overlap(self.obb(a, m), box_b, TOL.sweep_box_slack_mm):
                self._spend(lambda: f"{a!r} against {b!r} at {name(q)}")
                o = exact_overlap(a, kernel.located(pa.local_shape(), m @ pa.placement), b, pb.shape())
                new = o.depth - rest
                if new > TOL.sim_penetration_mm and not first:
                    first = name(q)
                if new > hit.depth:
                    hit.depth, hit.volume, hit.first_at = new, o.volume, first
                    hit.pair, hit.at, hit.value = (a, b), name(q), q
                    p = o.point()
                    hit.point = [round(float(x), 4) for x in p] if p is not None else []
            return gap

        # the first pose past the tolerance ends the pair (see above)
        poses = _advance(check, outside, lo, hi, step, lever, min_adv, until=lambda: bool(first))
        hit.samples = max(hit.samples, poses)
        hit.step_mm = step
        return True

    def _corners_world(self, name: str) -> np.ndarray:
        lo, hi = self._world_box(name)
        return _corners(lo, hi)

    def _world_box(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """The placed part's world box at rest (the corners of its local box, placed)."""
        lo, hi = self._local_box(name)
        t = self.model.part(name).placement
        c = _corners(lo, hi) @ t[:3, :3].T + t[:3, 3]
        return c.min(axis=0), c.max(axis=0)


def coupled_chain(art: Articulation, head: Joint) -> list[tuple[Joint, float]]:
    """Every joint ``head`` drives through couplings (directly or down a chain, not through a
    linkage) with its ratio: ``q_joint = ratio * q_head`` (SI; offsets are 0, positions count
    from the compiled pose). Empty for a joint that drives none, or one that is itself driven."""
    if driven_head(art, head.name) != head.name or not art.couplings:
        return []
    out = []
    for j in art.joints:
        if j.name == head.name or j.coupling is None or j.coupling.type == "linkage":
            continue
        h, ratio, _ = art.root_driver(j.name)
        if h == head.name and ratio != 0.0:
            out.append((j, ratio))
    return out


def driven_head(art: Articulation, joint: str) -> str:
    """The joint whose sweep moves ``joint``: the head of its chain of couplings (itself when
    no gear, rack, screw or belt coupling drives it)."""
    return art.root_driver(joint)[0] if art.couplings else joint


def chain_range(head: Joint, chain: list[tuple[Joint, float]]) -> tuple[float, float]:
    """The head's values (SI, from the compiled pose) the coupled sweep covers: its own limits
    cut to those that keep every driven joint inside its limits; a continuous head without a
    limited joint in its chain turns until each continuous joint of it has turned once."""
    lo, hi = (-math.inf, math.inf) if head.kind.endless else (float(head.lower), float(head.upper))  # type: ignore[arg-type]  # a limited joint has limits
    for j, r in chain:
        if j.kind.endless or j.lower is None or j.upper is None:
            continue
        x, y = float(j.lower) / r, float(j.upper) / r
        lo, hi = max(lo, min(x, y)), min(hi, max(x, y))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        turns = [2 * math.pi] + [2 * math.pi / abs(r) for j, r in chain if j.kind.endless]
        return 0.0, max(turns)
    return (lo, hi) if hi >= lo else (0.0, 0.0)


def _virtual(joint: Joint, ratio: float, lo: float, hi: float) -> Joint:
    """``joint`` limited to the values it takes while its head runs over ``lo..hi`` (a
    continuous joint that turns a full turn or more stays continuous)."""
    a, b = sorted((ratio * lo, ratio * hi))
    if joint.kind.endless:
        if b - a >= 2 * math.pi - 1e-9:
            return joint
        return dataclasses.replace(joint, type=REVOLUTE.name, lower=a, upper=b)
    return dataclasses.replace(joint, lower=a, upper=b)


def _chain_lever(points: np.ndarray, pad: float, moves: list[tuple[Joint, float]],
                 width: float) -> np.ndarray:
    """Per point (world mm at rest, each standing for a ball of radius ``pad``), a bound of how
    far it moves (mm) per unit of the head's value under the chain ``moves`` ((joint, ratio),
    root first), for head values at most ``width`` from 0: the sum over the joints of
    ``|ratio|`` times its lever (1000 mm/m for a slide; for a turn its distance from the axis,
    grown by how far the joints below may carry it off its rest position)."""
    lever = np.zeros(len(points))
    carried = np.full(len(points), float(pad))  # how far the joints below may move each point
    for j, r in reversed(moves):
        if j.kind.slides:
            lever += 1000.0 * abs(r)
            carried = carried + 1000.0 * abs(r) * width
        else:
            q = points - j.frame[:3, 3]
            u = j.axis
            dist = np.linalg.norm(q - np.outer(q @ u, u), axis=1) + carried
            lever += abs(r) * dist
            carried = carried + np.minimum(2.0 * dist, abs(r) * width * dist)
    return lever


def _envelope(corners: np.ndarray, moves: list[tuple[Joint, float]],
              span: tuple[float, float]) -> tuple[np.ndarray, float]:
    """A ball (centre, radius, mm) holding every position of a part with box ``corners`` (world
    mm at rest) under the chain ``moves`` ((joint, ratio), root first) over the head values in
    ``span``: from the lowest joint up, the ball's orbit about a turn's axis is held by the ball
    about the foot of its centre on the axis; a slide stretches it along its axis."""
    c = corners.mean(axis=0)
    radius = float(np.linalg.norm(corners - c, axis=1).max())
    for j, r in reversed(moves):
        if j.kind.slides:
            t = sorted((1000.0 * r * span[0], 1000.0 * r * span[1]))
            c = c + j.axis * (t[0] + t[1]) / 2
            radius += (t[1] - t[0]) / 2
        else:
            o, u = j.frame[:3, 3], j.axis
            foot = o + float((c - o) @ u) * u
            radius += float(np.linalg.norm(c - foot))
            c = foot
    return c, radius


def _advance(check: Callable[[float], np.ndarray], outside: list[float], lo: float, hi: float,
             step: float, lever: np.ndarray, min_adv: float, *, endless: bool = False,
             until: Callable[[], bool] = lambda: False) -> int:
    """Conservative advancement from ``lo`` to ``hi``: ``check`` each pose (first the MuJoCo
    overshoots ``outside`` the range, one pose each) and step to the nearest value at which some
    cell has moved its gap plus ``step`` (its ``lever``: mm per unit of the value), never less
    than ``min_adv``; an ``endless`` turn stops before 2 pi (the first pose again), and
    ``until()`` ends the march early. Returns the poses checked."""
    for q in outside:
        check(q)
    poses, q = len(outside), lo
    while not until():
        gap = check(q)
        poses += 1
        if q >= hi - 1e-12:
            break
        q = min(q + max(float(np.min((np.maximum(gap, 0.0) + step) / lever)), min_adv), hi)
        if endless and q >= hi - 1e-12:
            break
    return poses


def _one_line(moves: list[tuple[Joint, float]]) -> tuple[np.ndarray, np.ndarray] | None:
    """(a point, the unit direction) of the line every joint of ``moves`` turns about or slides
    along (a slide along any parallel line keeps distances from it), else None."""
    j0 = moves[0][0]
    o, u = j0.frame[:3, 3], j0.axis / float(np.linalg.norm(j0.axis))
    turning = [j for j, _ in moves if j.kind.turns]
    if turning:
        o = turning[0].frame[:3, 3]
        u = turning[0].axis / float(np.linalg.norm(turning[0].axis))
    for j, _ in moves:
        if j.kind.ball or abs(abs(float(j.axis @ u)) / float(np.linalg.norm(j.axis)) - 1.0) > 1e-9:
            return None
        d = j.frame[:3, 3] - o
        if j.kind.turns and float(np.linalg.norm(d - (d @ u) * u)) > 1e-6:
            return None
    return o, u


def _common_line(moves: list[tuple[Joint, float]]):
    """(key, face filter) when every joint of ``moves`` turns about or slides along one line:
    the faces their motion maps onto themselves are left out (a turn's invariant faces; with a
    slide too, only those that also lie along it: cylinders about the line); else None."""
    j0 = moves[0][0]
    o, u = j0.frame[:3, 3], j0.axis
    for j, _ in moves:
        d = j.frame[:3, 3] - o
        if abs(abs(float(j.axis @ u)) - 1.0) > 1e-9:
            return None
        if j.kind.turns and float(np.linalg.norm(d - (d @ u) * u)) > 1e-6:
            return None
    slides = any(j.kind.slides for j, _ in moves)
    turns = any(j.kind.turns for j, _ in moves)
    if not turns:
        return None  # slides along parallel lines: a slide, handled as one joint
    from .cells import invariant_under_rotation, side_of_motion

    def keep(face, ocp) -> bool:
        if not invariant_under_rotation(face, o, u, ocp):
            return True
        return slides and side_of_motion(face, u, ocp) != (False, False)
    key = np.round(np.concatenate([o, u, [float(slides)]]), 9).tobytes().hex()
    return key, keep


def _with_tree(c: Cover) -> tuple[Cover, cKDTree | None]:
    return c, (cKDTree(c.centres) if len(c.centres) else None)


def _in_box(lo: np.ndarray, hi: np.ndarray, blo: np.ndarray, bhi: np.ndarray,
            gap: float) -> np.ndarray:
    """Indices of the boxes ``lo..hi`` (n, 3) that meet the box ``blo..bhi`` grown by ``gap``."""
    return np.nonzero(np.all(lo <= bhi + gap, axis=1) & np.all(hi >= blo - gap, axis=1))[0]


def _orbit_boxes(tris: np.ndarray, frame_inv: np.ndarray, slides: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle (world mm), a box holding its orbit's coordinates in a joint frame: its
    (x, y) under a slide along Z (every point keeps them), its (distance from the axis, z)
    under a turn about Z (the distance: the triangle's least, :func:`.cells.nearest_to_origin`
    of its projection across the axis, to its vertices' greatest). The third coordinate is 0,
    for :func:`box_pairs`."""
    if not len(tris):
        return np.zeros((0, 3)), np.zeros((0, 3))
    p = tris @ frame_inv[:3, :3].T + frame_inv[:3, 3]
    lo, hi = np.zeros((len(p), 3)), np.zeros((len(p), 3))
    if slides:
        lo[:, :2], hi[:, :2] = p[:, :, :2].min(axis=1), p[:, :, :2].max(axis=1)
        return lo, hi
    lo[:, 0], hi[:, 0] = nearest_to_origin(p[:, :, :2]), np.linalg.norm(p[:, :, :2], axis=2).max(axis=1)
    lo[:, 1], hi[:, 1] = p[:, :, 2].min(axis=1), p[:, :, 2].max(axis=1)
    return lo, hi


def trans_z(z: float) -> np.ndarray:
    return trans(z=z)


def _height_range(shape, direction: np.ndarray) -> tuple[float, float]:
    """Exact (min, max) of the located ``shape`` along the world unit ``direction`` (its
    optimal box in a frame whose Z is ``direction``)."""
    z = np.asarray(direction, float)
    rot = np.eye(4)
    rot[:3, :3] = np.vstack([plane_basis(z), z])  # rows: world -> frame with z = direction
    lo, hi = kernel.bbox(kernel.located(shape, rot), optimal=True)
    return lo[2], hi[2]


def _heights(tris: np.ndarray, devs: np.ndarray, axes: np.ndarray, d: np.ndarray,
             extent: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle (n, 3, 3), the (least, greatest) height along unit ``d`` of its exact face's
    points it stands for: its vertices' widened by its deviation ``devs`` (a cylinder's chords
    deviate across its axis ``axes`` only: along d by sin(axis, d)), kept within the part's
    exact ``extent`` along d (every point of the part lies in it)."""
    h = tris @ d
    e = devs * np.sqrt(np.clip(1.0 - (axes @ d) ** 2, 0.0, 1.0))
    return (np.maximum(h.min(axis=1) - e, extent[0]), np.minimum(h.max(axis=1) + e, extent[1]))


def _overlaps(pairs: np.ndarray, a: tuple[np.ndarray, np.ndarray],
              b: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of the overlap of the height ranges ``a`` = (lo, hi) and ``b`` for each index
    pair (i, j) in ``pairs`` (``hi < lo``: they do not overlap)."""
    return (np.maximum(a[0][pairs[:, 0]], b[0][pairs[:, 1]]),
            np.minimum(a[1][pairs[:, 0]], b[1][pairs[:, 1]]))


def _thin_union(lo: np.ndarray, hi: np.ndarray, thick: float) -> bool:
    """Whether the union of the intervals ``lo..hi`` (empty ones, ``hi < lo``, left out) has
    no piece ``thick`` or thicker (an empty union has none). A solid that lies in such a union
    of slabs has each connected piece inside one slab, so ``2 V / S`` below ``thick`` (a solid
    in a slab of thickness t has S >= 2 V / t, and the ratio of sums is at most the largest)."""
    ok = hi >= lo
    lo, hi = lo[ok], hi[ok]
    if not len(lo):
        return True
    order = np.argsort(lo, kind="stable")
    lo, hi = lo[order], hi[order]
    reach = np.maximum.accumulate(hi)
    start = np.concatenate([[True], lo[1:] > reach[:-1]])  # a new piece: past all before it
    first = np.flatnonzero(start)
    last = np.concatenate([first[1:], [len(lo)]]) - 1
    return bool(np.all(reach[last] - lo[first] < thick))


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
    (:meth:`SweepScene.sweep`, with ``extra[name]`` as its MuJoCo overshoot). A joint that a
    coupling drives is not swept itself: the head of its chain's sweep moves it, and its entry
    is an empty :class:`SweepHit` whose ``swept_with`` names that head.

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
    followers = {j.name: SweepHit(j.name, swept_with=driven_head(art, j.name)) for j in joints
                 if driven_head(art, j.name) != j.name}
    everything = joints
    joints = [j for j in joints if j.name not in followers]
    if not parallel or len(joints) < 2 or _cores() < 2:
        own = {j.name: scene.sweep(j, extra=extra.get(j.name, ())) for j in joints}
        return {j.name: own.get(j.name) or followers[j.name] for j in everything}, scene.booleans
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
    hits.update(followers)
    return {j.name: hits[j.name] for j in everything}, booleans + scene.booleans


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
