"""Exact-solid sweeps for battery B2: every joint's range sampled in closed form.

MuJoCo only sees convex hulls and stops only where they meet, so a part can pass *through*
another between the two extremes a sweep reaches. Here each joint's commanded range is sampled
(every :data:`REVOLUTE_STEP_DEG` for revolute joints, :data:`PRISMATIC_STEPS` steps for
prismatic ones, at most :data:`MAX_SAMPLES`), and each spherical joint is tilted to
:data:`SPHERE_FRACTIONS` of its cone in :data:`SPHERE_DIRECTIONS` directions. At each sample the
moved subtree is posed with the mate-frame closed form (``F @ delta @ F^-1``, see
:mod:`procedura_brep.mates.placement`) and the exact OCCT common of every (moved, fixed) part
pair is measured (thickness ``2 V / S``, as :mod:`.contact`).

Cost is kept down by four prefilters, all conservative for the thickness measure:

* a pair is skipped when the moved part's swept envelope (its box corners' cylinder about a
  revolute axis, their sphere about a ball centre, its box stretched by a prismatic travel) misses
  the fixed part's box;
* a pair whose exact extents along a direction the motion preserves (the axis of a revolute
  joint; the two cross-axis directions of a prismatic one) overlap by less than
  ``TOL.sim_penetration_mm`` is skipped for the whole sweep: any common solid then lies in a slab
  thinner than the tolerance, and a solid inside a slab of thickness t has ``2 V / S <= t``;
* per sample, the parts' oriented local bounding boxes must intersect (separating-axis test);
* a pair already interfering at rest (thicker than :data:`TOL.sweep_rest_interference_mm`) is skipped:
  rest interference is B3's and the mate gate's business.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from .. import kernel
from ..articulation.tree import Articulation, Joint
from ..config import TOL
from ..mates.placement import delta, rigid_inverse, rot_x, rot_z
from ..program.model import CompiledModel
from .contact import Overlap, exact_overlap

log = logging.getLogger(__name__)

#: Revolute sample spacing along the commanded range, degrees.
REVOLUTE_STEP_DEG = 5.0
#: Prismatic joints are sampled at this many equal steps of their travel.
PRISMATIC_STEPS = 16
#: At most this many samples per revolute/prismatic joint: the step widens beyond 180 deg of
#: range (a 340 deg yaw is sampled every 9.4 deg), which keeps the rover battery near 5 s.
MAX_SAMPLES = 37
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
    skipped_rest: list[tuple[str, str]] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"new_penetration_mm": self.depth, "pair": list(self.pair) if self.pair else None,
                "at": self.at, "samples": self.samples, "booleans": self.booleans,
                "skipped_rest_pairs": [list(p) for p in self.skipped_rest]}


def samples(joint: Joint, extra: tuple[float, ...] = ()) -> list[Sample]:
    """The poses at which ``joint``'s sweep is checked (plus those values in ``extra`` that lie
    outside the commanded range, e.g. a MuJoCo overshoot).

    Continuous joints have no range and give no samples.
    """
    f, f_inv = joint.frame, rigid_inverse(joint.frame)
    out: list[Sample] = []
    if joint.type == "spherical":
        cone = float(joint.upper or 0.0)
        for frac in SPHERE_FRACTIONS:
            for k in range(SPHERE_DIRECTIONS):
                phi = 360.0 * k / SPHERE_DIRECTIONS
                tilt = math.degrees(frac * cone)
                d = rot_z(phi) @ rot_x(tilt) @ rot_z(-phi)  # tilt about (cos phi, sin phi, 0)
                out.append(Sample(f"tilt {tilt:.3g} deg about direction {phi:.0f} deg",
                                  f @ d @ f_inv, (phi, frac * cone)))
        return out
    if joint.type not in ("revolute", "prismatic"):
        return out
    lo, hi = float(joint.lower), float(joint.upper)  # type: ignore[arg-type]
    if joint.type == "revolute":
        n = math.ceil(math.degrees(hi - lo) / REVOLUTE_STEP_DEG) + 1
    else:
        n = PRISMATIC_STEPS + 1
    values = np.linspace(lo, hi, max(2, min(MAX_SAMPLES, n))).tolist()
    # reached values (MuJoCo) only count where they overshoot the commanded range
    values = sorted(values + [q for q in extra if q < lo - OVERSHOOT_EPS or q > hi + OVERSHOOT_EPS])
    for q in values:
        if joint.type == "revolute":
            label, d = f"{math.degrees(q):.4g} deg", delta("revolute", math.degrees(q))
        else:
            label, d = f"{q * 1000:.4g} mm", delta("prismatic", q * 1000.0)
        out.append(Sample(label, f @ d @ f_inv, q))
    return out


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
        self.booleans = 0

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

    def _overlap(self, a: str, ma: np.ndarray, b: str) -> Overlap:
        pa, pb = self.model.part(a), self.model.part(b)
        self.booleans += 1
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
        if joint.type == "revolute":
            return [joint.frame[:3, 2]]
        if joint.type == "prismatic":
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
        if joint.type == "prismatic":
            lo, hi = ca.min(axis=0), ca.max(axis=0)
            lo[2] += 1000.0 * min(0.0, float(joint.lower))  # type: ignore[arg-type]
            hi[2] += 1000.0 * max(0.0, float(joint.upper))  # type: ignore[arg-type]
            return bool(np.all(lo <= bhi) and np.all(blo <= hi))
        # the box point nearest the joint origin (spherical) or axis (revolute)
        near = np.clip(0.0, blo, bhi)
        if joint.type == "spherical":
            return float(np.linalg.norm(near)) <= float(np.linalg.norm(ca, axis=1).max())
        r_a = float(np.linalg.norm(ca[:, :2], axis=1).max())
        z_ok = ca[:, 2].min() <= bhi[2] and blo[2] <= ca[:, 2].max()
        return bool(z_ok and float(np.linalg.norm(near[:2])) <= r_a)

    def pairs(self, joint: Joint) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
        """(pairs to sweep, pairs skipped as interfering at rest) as (moved, fixed) part names."""
        moving = [p for lk in self.art.subtree(joint.child) for p in self.art.link(lk).parts]
        fixed = [p.name for p in self.model.parts if p.name not in set(moving)]
        dirs = [d / np.linalg.norm(d) for d in self._invariant_dirs(joint)]
        frame_inv = rigid_inverse(joint.frame)
        keep, skipped = [], []
        for a in moving:
            for b in fixed:
                if not self._may_meet(joint, a, b, frame_inv):
                    continue
                if any(_slab_gap(self.extent(a, d), self.extent(b, d)) for d in dirs):
                    continue
                if self.rest(a, b).depth > TOL.sweep_rest_interference_mm:
                    skipped.append((a, b))
                    continue
                keep.append((a, b))
        return keep, skipped

    def sweep(self, joint: Joint, extra: tuple[float, ...] = ()) -> SweepHit:
        """The deepest new exact interference over the joint's samples."""
        hit = SweepHit(joint.name)
        todo, hit.skipped_rest = self.pairs(joint)
        start = self.booleans
        for s in samples(joint, extra):
            hit.samples += 1
            for a, b in todo:
                if not _obb_overlap(self.obb(a, s.motion), self.obb(b, np.eye(4)), TOL.sweep_box_slack_mm):
                    continue
                o = self._overlap(a, s.motion, b)
                new = o.depth - self.rest(a, b).depth
                if new > hit.depth:
                    hit.depth, hit.volume, hit.pair, hit.at, hit.value = new, o.volume, (a, b), s.label, s.value
        hit.booleans = self.booleans - start
        log.debug("sweep %s: %d samples, %d pairs, %d booleans, worst %.3g mm", joint.name,
                  hit.samples, len(todo), hit.booleans, hit.depth)
        return hit


def _slab_gap(a: tuple[float, float], b: tuple[float, float]) -> bool:
    """True if the two extents overlap by less than the penetration tolerance."""
    return min(a[1], b[1]) - max(a[0], b[0]) < TOL.sim_penetration_mm


def tilt_quat(direction_deg: float, tilt_rad: float) -> np.ndarray:
    """MuJoCo ball-joint quaternion (w, x, y, z) of a tilt about (cos d, sin d, 0) in the joint
    frame."""
    phi = math.radians(direction_deg)
    h = tilt_rad / 2
    return np.array([math.cos(h), math.sin(h) * math.cos(phi), math.sin(h) * math.sin(phi), 0.0])
