"""Mate gate: every static mate must be seated (registration area) and must not gouge (penetration).

For a static mate ``c`` with nominal ``d`` (paper eq. 3)::

    a(c) >= TOL.registration_tau * d**2      and      delta(c) <= delta_max(fit)
    delta_max(fit) = max(0, -fit["offset"]) + TOL.penetration_slack_mm

**Registration area** ``a(c)`` (mm^2) is the *bearing* area of the seat: the area of the child's
surface that faces its parent along the mate axis (outward normal within
``BEARING_ANGLE_DEG`` of ``-Z`` of the mate frame, which points from parent into child), lies
within ``TOL.registration_band_mm`` of a parent surface facing back (normal within the same cone
of ``+Z``), measured as the gap along the mate axis, and lies *around the mate*: within
:func:`bearing_radius` (``TOL.bearing_radius_factor * d + pcd / 2``) of the mate axis, so a part
slid along a large parent face does not register. Only the child's body counts: a detached piece
of the child (:mod:`.pieces`, e.g. a seat pad left in its counterbore) bears nothing. It is
computed on the fixed tessellation (planar seats, the common case, are exact there), after
bounding-box prefilters; the child's bearing triangles are subdivided to ``sample_size(d)`` so
partial overlaps count by area. Fit walls (peg sides, bores) do not count: a peg lifted off its
seat keeps its walls inside the socket, and must still fail. A hovering part measures ``a = 0``.

**Penetration depth** ``delta(c)`` (mm) is the largest depth (:mod:`.common`: minimum width, or
the radial wall of a ring about the mate axis) of the solids of the exact B-rep common
``child & parent`` that reach into the mate's feature region (:func:`region`); solids elsewhere
are the interference gate's. A fit's own interference (press, snap, tight location fits) is
allowed through ``delta_max(fit)``. The boolean is bounded by ``TOL.boolean_pair_budget`` (on
crops over it); a mate whose common is still over it has its penetration **not verified** (a
warning, not a pass of the penetration and not a blocking error).

When a mate both hovers and gouges, its frames are usually flipped: the finding says on which
side of the mate plane each part's body lies (world directions of each frame's +Z) and which
frame is wrong: the parent's body must lie on the -Z side of its frame, the child's on the +Z
side, so the two bodies oppose across the plane.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL
from ..mates.kinds import Motion
from ..mates.placement import rigid_inverse
from ..mates.vocabulary import TYPES
from ..program.model import CompiledMate, CompiledModel, Finding
from .common import common
from .geometry import LRU, PartGeometry, boxes_near, part_geometry
from .locate import describe, direction_name
from .pieces import body_faces
from .policy import GateResult, result

log = logging.getLogger(__name__)

#: Child faces within this angle of -Z (mate frame) are bearing faces; parent faces likewise of +Z.
BEARING_ANGLE_DEG: float = TOL.bearing_angle_deg
#: At most this many area samples per mate (the sample size grows to respect it).
MAX_SAMPLES: int = 40000

_MEASURED: LRU = LRU()
_BEARING: LRU = LRU()


@dataclass
class MateMeasure:
    """The measured values of one static mate (mm, mm^2) and their limits."""

    mate: str
    area_mm2: float
    area_limit_mm2: float
    penetration_mm: float
    penetration_limit_mm: float
    exact: bool = True
    reason: str = ""
    point: tuple[float, float, float] | None = None  # world mm, in the deepest overlap

    @property
    def seated(self) -> bool:
        return self.area_mm2 >= self.area_limit_mm2

    @property
    def clean(self) -> bool:
        """No penetration beyond the fit (True when not verified: that is reported apart)."""
        return not self.exact or self.penetration_mm <= self.penetration_limit_mm

    def as_dict(self) -> dict[str, Any]:
        return {"area_mm2": round(self.area_mm2, 6), "area_limit_mm2": round(self.area_limit_mm2, 6),
                "penetration_mm": round(self.penetration_mm, 6),
                "penetration_limit_mm": round(self.penetration_limit_mm, 6),
                "seated": self.seated, "clean": self.clean,
                "passed": self.seated and self.clean, "exact": self.exact,
                **({} if self.exact else {"not_verified": self.reason})}


def penetration_limit(fit: dict[str, Any]) -> float:
    """delta_max(fit): the fit's per-side interference plus ``TOL.penetration_slack_mm``."""
    return max(0.0, -float(fit.get("offset", 0.0) or 0.0)) + TOL.penetration_slack_mm


def area_limit(nominal: float) -> float:
    """tau_a * d^2, mm^2."""
    return TOL.registration_tau * nominal * nominal


def sample_size(nominal: float) -> float:
    """Edge length (mm) the bearing triangles are subdivided to: d/10 within [0.2, 5] mm."""
    return min(5.0, max(0.2, nominal / 10.0))


def _to_frame(points: np.ndarray, inv: np.ndarray) -> np.ndarray:
    return points @ inv[:3, :3].T + inv[:3, 3]


def _normals(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(n, axis=1)
    return n / np.maximum(norm, 1e-300)[:, None], 0.5 * norm


def _samples(tris: np.ndarray, areas: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Centroids and areas of the n x n subdivision of each triangle (n from its longest edge)."""
    edges = np.stack([np.linalg.norm(tris[:, i] - tris[:, (i + 1) % 3], axis=1) for i in range(3)], 1)
    n = np.maximum(1, np.ceil(edges.max(axis=1) / h)).astype(int)
    total = int((n * n).sum())
    if total > MAX_SAMPLES:
        return _samples(tris, areas, h * math.sqrt(total / MAX_SAMPLES) * 1.05)
    pts, wts = [], []
    for k in np.unique(n):
        sel = n == k
        i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
        up = (i + j) <= k - 1
        dn = (i + j) <= k - 2
        bary = np.concatenate([np.stack([i[up] + 1 / 3, j[up] + 1 / 3], 1),
                               np.stack([i[dn] + 2 / 3, j[dn] + 2 / 3], 1)]) / k
        u, w = bary[:, 0], bary[:, 1]
        t = tris[sel]
        p = (t[:, None, 0] * (1 - u - w)[None, :, None] + t[:, None, 1] * u[None, :, None]
             + t[:, None, 2] * w[None, :, None])
        pts.append(p.reshape(-1, 3))
        wts.append(np.repeat(areas[sel] / (k * k), len(u)))
    return np.vstack(pts), np.concatenate(wts)


def _registered(samples: np.ndarray, ptris: np.ndarray, band: float) -> np.ndarray:
    """Mask of samples whose axial gap to some parent triangle (projected on XY) is <= band.

    Samples are sorted into a coarse XY grid and handled in chunks; each chunk is tested only
    against the parent triangles whose XY box overlaps the chunk's box (a bbox prefilter).
    """
    out = np.zeros(len(samples), dtype=bool)
    a, b, c = ptris[:, 0], ptris[:, 1], ptris[:, 2]
    v0, v1 = (b - a)[:, :2], (c - a)[:, :2]
    den = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    ok = np.abs(den) > 1e-12
    a, b, c, v0, v1, den = a[ok], b[ok], c[ok], v0[ok], v1[ok], den[ok]
    if not len(a):
        return out
    tlo, thi = np.minimum(np.minimum(a, b), c)[:, :2], np.maximum(np.maximum(a, b), c)[:, :2]
    lo, hi = samples[:, :2].min(0), samples[:, :2].max(0)
    cell = max(float((hi - lo).max()) / 32.0, 1e-6)
    key = np.floor((samples[:, :2] - lo) / cell).astype(np.int64)
    order = np.lexsort((key[:, 1], key[:, 0]))
    eps = 1e-9
    for s in range(0, len(order), 256):
        idx = order[s:s + 256]
        p = samples[idx]
        plo, phi = p[:, :2].min(0), p[:, :2].max(0)
        t = np.nonzero(np.all(thi >= plo - eps, 1) & np.all(tlo <= phi + eps, 1))[0]
        if not len(t):
            continue
        d = p[:, None, :2] - a[None, t, :2]
        u = (d[..., 0] * v1[None, t, 1] - d[..., 1] * v1[None, t, 0]) / den[None, t]
        w = (v0[None, t, 0] * d[..., 1] - v0[None, t, 1] * d[..., 0]) / den[None, t]
        inside = (u >= -eps) & (w >= -eps) & (u + w <= 1 + eps)
        z = a[None, t, 2] + u * (b - a)[None, t, 2] + w * (c - a)[None, t, 2]
        out[idx] = np.any(inside & (np.abs(p[:, None, 2] - z) <= band), axis=1)
    return out


def bearing_radius(mate: CompiledMate) -> float:
    """Radius (mm) about the mate axis within which bearing area counts (module doc)."""
    return TOL.bearing_radius_factor * mate.nominal + _pcd(mate) / 2.0


def _pcd(mate: CompiledMate) -> float:
    return TYPES[mate.type].pcd(mate.nominal, mate.options or {})


def region(mate: CompiledMate) -> tuple[float, float]:
    """(radius, half depth) mm of the mate's feature region about its frame (module doc)."""
    o = mate.options or {}
    k = TOL.mate_region_factor * mate.nominal
    lim = [abs(float(v)) for v in (o.get("limits") or ()) if v is not None]
    travel = max(lim, default=0.0) if TYPES[mate.type].motion is Motion.SLIDE else 0.0
    depth = float(o.get("depth") or 0.0) + float(o.get("length") or 0.0) + travel
    return k + _pcd(mate) / 2.0, k + depth


def registration_area(child: PartGeometry, parent: PartGeometry, frame: np.ndarray,
                      nominal: float, *, band: float = TOL.registration_band_mm,
                      radius: float | None = None, mask: np.ndarray | None = None) -> float:
    """Bearing area (mm^2) of ``child`` seated on ``parent`` across the mate ``frame`` (world 4x4).

    Args:
        radius: only child area within this distance of the frame's Z axis counts (None: all).
        mask: the child triangles that may bear (None: all), e.g. its body without detached
            pieces.
    """
    if not len(child.faces) or not len(parent.faces):
        return 0.0
    if not boxes_near((child.lo, child.hi), (parent.lo, parent.hi), band):
        return 0.0
    inv = np.linalg.inv(frame)
    cv, pv = _to_frame(child.vertices, inv), _to_frame(parent.vertices, inv)
    cos = math.cos(math.radians(BEARING_ANGLE_DEG))
    cn, ca = _normals(cv, child.faces)
    pn, _ = _normals(pv, parent.faces)
    ct, pt = cv[child.faces], pv[parent.faces]
    plo, phi = pv.min(axis=0) - band, pv.max(axis=0) + band
    csel = (cn[:, 2] <= -cos) & np.all(ct.max(axis=1) >= plo, 1) & np.all(ct.min(axis=1) <= phi, 1)
    if mask is not None:
        csel &= mask
    if radius is not None:  # triangles entirely outside the disc cannot contribute
        csel &= np.all(ct.min(axis=1)[:, :2] <= radius, 1) & np.all(ct.max(axis=1)[:, :2] >= -radius, 1)
    if not csel.any():
        return 0.0
    ct, ca = ct[csel], ca[csel]
    clo, chi = ct.min(axis=(0, 1)) - band, ct.max(axis=(0, 1)) + band
    psel = (pn[:, 2] >= cos) & np.all(pt.max(axis=1) >= clo, 1) & np.all(pt.min(axis=1) <= chi, 1)
    if not psel.any():
        return 0.0
    pts, wts = _samples(ct, ca, sample_size(nominal))
    if radius is not None:  # only samples on the disc are tested against the parent
        disc = np.hypot(pts[:, 0], pts[:, 1]) <= radius
        pts, wts = pts[disc], wts[disc]
    if not len(pts):
        return 0.0
    keep = _registered(pts, pt[psel], band)
    return float(wts[keep].sum())


def penetration_depth(child_shape: Any, parent_shape: Any, frame: np.ndarray) -> float:
    """Depth (mm) of the exact common ``child & parent`` in the mate ``frame`` (no region, no
    budget, no cache; see :mod:`.common`)."""
    from .common import exact_common

    return max((s.depth(frame) for s in exact_common(child_shape, parent_shape) or []), default=0.0)


def side_of(geo: PartGeometry, frame: np.ndarray) -> float:
    """Signed height (mm) of the part's volume centroid above the plane of ``frame``."""
    v, f = geo.vertices, geo.faces
    if not len(f):
        return 0.0
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    w = np.einsum("ij,ij->i", a, np.cross(b, c))
    tot = w.sum()
    cen = ((a + b + c) * w[:, None]).sum(0) / (4.0 * tot) if abs(tot) > 1e-12 else v.mean(0)
    return float((cen - frame[:3, 3]) @ frame[:3, 2])


def pair_key(model: CompiledModel, mate: CompiledMate) -> tuple[Any, ...]:
    """What a mate's measures depend on: both parts' local geometry, the child's placement and
    the mate frame in the parent's frame, the parent's world orientation (a common's width is
    also read along the world axes, so only a translated pair is the same pair), and the mate's
    type, nominal, fit and options. Twin pairs moved apart (the hub caps pressed into the three
    wheels of a side) share it, so each is measured once."""
    child, parent = model.part(mate.child), model.part(mate.parent)
    inv = rigid_inverse(parent.placement)

    def exact(m: np.ndarray) -> bytes:
        return (np.round(m, 9) + 0.0).tobytes()  # + 0.0: no -0.0

    return (child.local_digest, parent.local_digest, getattr(child, "pieces", 1),
            exact(inv @ child.placement), exact(inv @ mate.world_frame),
            exact(parent.placement[:3, :3]), mate.nominal, mate.type,
            repr(sorted((mate.options or {}).items())),
            repr(sorted(mate.fit.items())) if mate.fit else "")


def bearing_area(model: CompiledModel, mate: CompiledMate) -> float:
    """The registration (bearing) area (mm^2) of ``mate``'s child on its parent, as the gate
    measures it: the child's body only, within :func:`bearing_radius` of the mate axis. Cached
    by :func:`pair_key` (the gate and the articulation evidence both ask)."""
    return _bearing_area(model, mate, pair_key(model, mate))


def _bearing_area(model: CompiledModel, mate: CompiledMate, key: tuple[Any, ...]) -> float:
    """:func:`bearing_area` under ``key``, the mate's :func:`pair_key` already made."""
    hit = _BEARING.get(key)
    if hit is not None:
        return float(hit)
    child, parent = model.part(mate.child), model.part(mate.parent)
    cg, pg = part_geometry(child), part_geometry(parent)
    area = registration_area(cg, pg, mate.world_frame, mate.nominal,
                             radius=bearing_radius(mate), mask=body_faces(child, cg))
    _BEARING.put(key, area)
    return area


def measure(model: CompiledModel, mate: CompiledMate) -> MateMeasure:
    """Registration area and penetration of one mate, cached by :func:`pair_key` (the deepest
    point kept in the parent's frame)."""
    child, parent = model.part(mate.child), model.part(mate.parent)
    key = pair_key(model, mate)
    hit = _MEASURED.get(key)
    if hit is not None:
        *vals, local = hit
        point = None if local is None else tuple(float(x) for x in parent.placement[:3, :3] @ local
                                                 + parent.placement[:3, 3])
        return MateMeasure(mate.name, *vals, point)
    cg, pg = part_geometry(child), part_geometry(parent)
    area = _bearing_area(model, mate, key)
    com = common(cg, child.shape(), pg, parent.shape())
    rad, half = region(mate)
    near = [s for s in com.solids if s.touches(mate.world_frame, rad, half)]
    deepest = max(near, key=lambda s: s.depth(mate.world_frame), default=None)
    depth = 0.0 if deepest is None else deepest.depth(mate.world_frame)
    point = None if deepest is None else tuple(float(x) for x in deepest.inner_point())
    vals = (area, area_limit(mate.nominal), depth, penetration_limit(mate.fit or {}),
            com.exact, com.reason)
    local = None if point is None else rigid_inverse(parent.placement)[:3] @ np.append(point, 1.0)
    _MEASURED.put(key, (*vals, local))
    return MateMeasure(mate.name, *vals, point)


def flipped_hint(model: CompiledModel, mate: CompiledMate) -> str:
    """Which frame's +Z points which way (world) and which one is wrong, for a mate that both
    hovers and gouges ("" when both bodies lie on their own sides: a plain gouge)."""
    child, parent = model.part(mate.child), model.part(mate.parent)
    fz = mate.world_frame[:3, 2]
    cz = child.world_frame(mate.child_frame)[:3, 2] if mate.child_frame in child.frames else fz
    pz = parent.world_frame(mate.parent_frame)[:3, 2] if mate.parent_frame in parent.frames else fz
    hp = side_of(part_geometry(parent), mate.world_frame)
    hc = side_of(part_geometry(child), mate.world_frame)
    wrong = [f"{mate.parent}.{mate.parent_frame}"] if hp > 0 else []
    if hc < 0:
        wrong.append(f"{mate.child}.{mate.child_frame}")
    if not wrong:  # both bodies on their own sides: a plain gouge, not a flipped frame
        return ""
    blame = f"flip {' and '.join(wrong)}"
    return (f"the frames look flipped: {mate.parent}.{mate.parent_frame} +Z points world "
            f"{direction_name(pz)} and {mate.parent}'s body lies on its {'+' if hp > 0 else '-'}Z side "
            f"(must be -Z: a parent frame's +Z points out of the parent); "
            f"{mate.child}.{mate.child_frame} +Z points world {direction_name(cz)} and {mate.child}'s body "
            f"lies on its {'+' if hc > 0 else '-'}Z side (must be +Z: into the child); the two "
            f"bodies must oppose across the mate plane: {blame}")


def mate_findings(mate: CompiledMate, m: MateMeasure, hint: str = "",
                  model: CompiledModel | None = None) -> list[Finding]:
    """The findings for one measured mate (empty when it passes); ``hint`` (see
    :func:`flipped_hint`) replaces the generic advice when the mate both hovers and gouges."""
    out = []
    both = not m.seated and not m.clean
    if not m.seated:
        advice = hint if both and hint else (
            f"the part hovers: make its face at frame {mate.child_frame} touch "
            f"{mate.parent}.{mate.parent_frame} within {bearing_radius(mate):.3g} mm of the mate axis")
        out.append(Finding(
            "mate-registration",
            f"{mate.child} is not seated on {mate.parent}: bearing area {m.area_mm2:.3g} mm^2 < "
            f"tau_a*d^2 = {m.area_limit_mm2:.3g} mm^2 (d = {mate.nominal:g} mm); {advice}",
            part=mate.child, mate=mate.name, line=mate.line, value=m.area_mm2,
            limit=m.area_limit_mm2))
    if not m.clean:
        advice = hint if both and hint else (
            f"move the geometry out of {mate.parent} or fix frame {mate.child_frame}")
        where = ""
        if m.point is not None:
            p = np.asarray(m.point, float)
            where = f" at ({', '.join(f'{x:.1f}' for x in p)}) mm"
            if model is not None:
                where += "; there: " + "; ".join(describe(model.part(n), p) for n in (mate.child, mate.parent))
        out.append(Finding(
            "mate-penetration",
            f"mate {mate.name} ({mate.type}): {mate.child} gouges into {mate.parent}: penetration "
            f"{m.penetration_mm:.3g} mm > {m.penetration_limit_mm:.3g} mm allowed by fit "
            f"{mate.fit.get('fit', '?')}{where}; {advice}",
            part=mate.child, mate=mate.name, line=mate.line, value=m.penetration_mm,
            limit=m.penetration_limit_mm, other=mate.parent))
    if not m.exact:
        out.append(unverified_finding(mate.child, mate.parent, m.reason, mate=mate.name,
                                      line=mate.line))
    return out


def unverified_finding(a: str, b: str, reason: str, *, mate: str | None = None,
                       line: int | None = None) -> Finding:
    """The warning that the overlap of ``a`` and ``b`` was not verified, and what stopped it."""
    what = f"the penetration of mate {mate}" if mate else f"the interference of {a} and {b}"
    return Finding(
        "not-verified",
        f"{what} was not verified: the exact common of {a} and {b} was not computed ({reason}). "
        f"Neither pass nor fail: fewer faces where the two parts meet (fuse plates, fewer "
        f"holes or teeth there) let it be decided",
        part=a, mate=mate, line=line, severity="warning")


def mate_gate(model: CompiledModel, *, mates: list[str] | None = None) -> tuple[list[Finding], GateResult]:
    """Run the mate gate on every static mate of ``model`` (or only those named in ``mates``).

    Returns:
        (findings, result) where ``result.measured`` maps mate name to :meth:`MateMeasure.as_dict`.
    """
    findings: list[Finding] = []
    measured: dict[str, Any] = {}
    names = {p.name for p in model.parts}
    for mate in model.mates:
        if mate.kind != "static" or (mates is not None and mate.name not in mates):
            continue
        missing = [n for n in (mate.child, mate.parent) if n not in names]
        if missing:  # the part failed to compile: the compile gate already reports it
            findings.append(Finding("mate-unmeasured", f"mate not measured: part(s) "
                                    f"{', '.join(missing)} did not compile", mate=mate.name,
                                    line=mate.line, severity="warning"))
            continue
        m = measure(model, mate)
        measured[mate.name] = m.as_dict()
        hint = flipped_hint(model, mate) if not m.seated and not m.clean else ""
        findings.extend(mate_findings(mate, m, hint, model))
    return findings, result("mate", findings, measured)
