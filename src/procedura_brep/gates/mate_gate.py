"""Mate gate: every static mate must be seated (registration area) and must not gouge (penetration).

For a static mate ``c`` with nominal ``d`` (paper eq. 3)::

    a(c) >= TOL.registration_tau * d**2      and      delta(c) <= delta_max(fit)
    delta_max(fit) = max(0, -fit["offset"]) + TOL.penetration_slack_mm

**Registration area** ``a(c)`` (mm^2) is the *bearing* area of the seat: the area of the child's
surface that faces its parent along the mate axis (outward normal within
``BEARING_ANGLE_DEG`` of ``-Z`` of the mate frame, which points from parent into child) and lies
within ``TOL.registration_band_mm`` of a parent surface facing back (normal within the same cone
of ``+Z``), measured as the gap along the mate axis. It is computed on the fixed tessellation
(planar seats, the common case, are exact there), after bounding-box prefilters; the child's
bearing triangles are subdivided to ``sample_size(d)`` so partial overlaps count by area. Fit walls
(peg sides, bores) do not count: a peg lifted off its seat keeps its walls inside the socket, and
must still fail. A hovering part therefore measures ``a = 0``.

**Penetration depth** ``delta(c)`` (mm) comes from the exact B-rep common ``child & parent``
(bounding boxes are checked first: disjoint boxes give 0). For each solid ``s`` of the common,
expressed in the mate frame: if it fills at least ``FILL_BOX`` of its bounding box (a slab or a
block: a gouge), its depth is its smallest bbox side; otherwise (a thin tube or shell: a press or
snap fit's interference ring) its depth is its wall thickness ``2 V / A``. ``delta`` is the max
over solids. A fit's own interference (press, snap, tight location fits) is allowed through
``delta_max(fit)``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledMate, CompiledModel, Finding
from .geometry import LRU, PartGeometry, boxes_near, part_geometry
from .policy import GateResult, result

log = logging.getLogger(__name__)

#: Child faces within this angle of -Z (mate frame) are bearing faces; parent faces likewise of +Z.
BEARING_ANGLE_DEG: float = TOL.bearing_angle_deg
#: A common solid filling at least this fraction of its mate-frame bbox is block-like (a gouge).
FILL_BOX: float = TOL.penetration_fill_box
#: At most this many area samples per mate (the sample size grows to respect it).
MAX_SAMPLES: int = 40000
#: Common solids smaller than this (mm^3) are boolean noise, not penetration.
MIN_COMMON_MM3: float = 1e-9

_MEASURED: LRU = LRU()


@dataclass
class MateMeasure:
    """The measured values of one static mate (mm, mm^2) and their limits."""

    mate: str
    area_mm2: float
    area_limit_mm2: float
    penetration_mm: float
    penetration_limit_mm: float

    @property
    def seated(self) -> bool:
        return self.area_mm2 >= self.area_limit_mm2

    @property
    def clean(self) -> bool:
        return self.penetration_mm <= self.penetration_limit_mm

    def as_dict(self) -> dict[str, Any]:
        return {"area_mm2": round(self.area_mm2, 6), "area_limit_mm2": round(self.area_limit_mm2, 6),
                "penetration_mm": round(self.penetration_mm, 6),
                "penetration_limit_mm": round(self.penetration_limit_mm, 6),
                "seated": self.seated, "clean": self.clean,
                "passed": self.seated and self.clean}


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


def registration_area(child: PartGeometry, parent: PartGeometry, frame: np.ndarray,
                      nominal: float, *, band: float = TOL.registration_band_mm) -> float:
    """Bearing area (mm^2) of ``child`` seated on ``parent`` across the mate ``frame`` (world 4x4)."""
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
    if not csel.any():
        return 0.0
    ct, ca = ct[csel], ca[csel]
    clo, chi = ct.min(axis=(0, 1)) - band, ct.max(axis=(0, 1)) + band
    psel = (pn[:, 2] >= cos) & np.all(pt.max(axis=1) >= clo, 1) & np.all(pt.min(axis=1) <= chi, 1)
    if not psel.any():
        return 0.0
    pts, wts = _samples(ct, ca, sample_size(nominal))
    return float(wts[_registered(pts, pt[psel], band)].sum())


def _common_solids(a: Any, b: Any) -> list[Any]:
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer

    op = BRepAlgoAPI_Common(a, b)
    if not op.IsDone():
        log.warning("boolean common failed; penetration taken as 0")
        return []
    out = []
    exp = TopExp_Explorer(op.Shape(), TopAbs_SOLID)
    while exp.More():
        out.append(exp.Current())
        exp.Next()
    return out


def penetration_depth(child_shape: Any, parent_shape: Any, frame: np.ndarray) -> float:
    """Depth (mm) of the exact common ``child & parent``, measured as described in the module doc."""
    from .. import kernel

    inv = np.linalg.inv(frame)
    depth = 0.0
    for s in _common_solids(child_shape, parent_shape):
        vol = kernel.volume(s)
        if vol <= MIN_COMMON_MM3:
            continue
        lo, hi = kernel.bbox(kernel.located(s, inv))
        sides = np.maximum(np.subtract(hi, lo), 1e-12)
        if vol / float(np.prod(sides)) >= FILL_BOX:
            d = float(sides.min())
        else:
            d = 2.0 * vol / max(kernel.area(s), 1e-300)
        depth = max(depth, d)
    return depth


def measure(model: CompiledModel, mate: CompiledMate) -> MateMeasure:
    """Registration area and penetration of one mate, cached by both parts' digests and the frame."""
    child, parent = model.part(mate.child), model.part(mate.parent)
    key = (child.digest, parent.digest, np.round(mate.world_frame, 9).tobytes(), mate.nominal,
           repr(sorted(mate.fit.items())) if mate.fit else "")
    hit = _MEASURED.get(key)
    if hit is not None:
        return MateMeasure(mate.name, *hit)
    cg, pg = part_geometry(child), part_geometry(parent)
    area = registration_area(cg, pg, mate.world_frame, mate.nominal)
    depth = 0.0
    if boxes_near((cg.lo, cg.hi), (pg.lo, pg.hi), 0.0):
        depth = penetration_depth(child.shape(), parent.shape(), mate.world_frame)
    vals = (area, area_limit(mate.nominal), depth, penetration_limit(mate.fit or {}))
    _MEASURED.put(key, vals)
    return MateMeasure(mate.name, *vals)


def mate_findings(mate: CompiledMate, m: MateMeasure) -> list[Finding]:
    """The findings for one measured mate (empty when it passes)."""
    out = []
    if not m.seated:
        out.append(Finding(
            "mate-registration",
            f"{mate.child} is not seated on {mate.parent}: bearing area {m.area_mm2:.3g} mm^2 < "
            f"tau_a*d^2 = {m.area_limit_mm2:.3g} mm^2 (d = {mate.nominal:g} mm); the part hovers: "
            f"make its face at frame {mate.child_frame} touch {mate.parent}.{mate.parent_frame}",
            part=mate.child, mate=mate.name, line=mate.line, value=m.area_mm2,
            limit=m.area_limit_mm2))
    if not m.clean:
        out.append(Finding(
            "mate-penetration",
            f"{mate.child} gouges into {mate.parent}: penetration {m.penetration_mm:.3g} mm > "
            f"{m.penetration_limit_mm:.3g} mm allowed by fit {mate.fit.get('fit', '?')}; move the "
            f"geometry out of {mate.parent} or fix frame {mate.child_frame}",
            part=mate.child, mate=mate.name, line=mate.line, value=m.penetration_mm,
            limit=m.penetration_limit_mm))
    return out


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
        findings.extend(mate_findings(mate, m))
    return findings, result("mate", findings, measured)
