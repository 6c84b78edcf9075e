"""What a belt pulley and a lead screw show about an axis, read from the exact edges and faces
(milliseconds; no booleans), for the coupling gate (``gates/coupling.py``).

* :func:`belt_seat`: the cylinder a belt runs on. The part's faces that are cylinders coaxial
  with the axis (within ``TOL.coupling_centre_mm``) give its outer radius along the axis, a
  run of constant radius per stretch; the seat is the largest run lower than both its
  neighbours (the rim between two flanges, as :func:`~procedura_brep.program.gearing.pulley`
  builds it), else the run of the largest radius (a plain disc or drum).
* :func:`thread`: the lead of a helical thread. Every curved edge that keeps its radius about
  the axis and turns at least a quarter turn is a helix (a thread's crest, root and flank
  corners, as :func:`~procedura_brep.program.gearing.lead_screw` and ``lead_nut`` sweep
  them); its lead is the axial advance per turn of a straight-line fit of the axial position
  against the unwrapped angle, positive for a right hand. The part's lead is the median of its
  helices.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..config import TOL
from ..mates.placement import plane_basis

if TYPE_CHECKING:
    from .coupling import Line

#: Points first sampled on a curved edge; an edge whose samples turn more than
#: ``MAX_STEP_RAD`` apart is sampled again, densely enough to unwrap its angle.
HELIX_SAMPLES: int = 33
MAX_STEP_RAD: float = math.pi / 4
#: A helix keeps its radius within this fraction and turns at least this many turns; its
#: points leave the fitted line (axial position against angle) by at most this fraction of
#: its lead.
HELIX_RADIUS_REL: float = 1e-3
HELIX_MIN_TURNS: float = 0.25
HELIX_FIT_REL: float = 1e-3


@dataclass(frozen=True)
class Seat:
    """A belt seat: its radius (mm), its axial span (params along the line, mm), and whether
    higher runs (flanges) stand on both sides of it."""

    radius: float
    lo: float
    hi: float
    flanged: bool = False

    @property
    def diameter(self) -> float:
        return 2.0 * self.radius


@dataclass(frozen=True)
class Thread:
    """A thread read from a part's helices: lead (mm per turn), hand, how many helices."""

    lead: float
    hand: Literal["right", "left"]
    helices: int


def _cast(kind: str) -> Any:
    from OCP.TopoDS import TopoDS
    return getattr(TopoDS, f"{kind}_s", None) or getattr(TopoDS, kind)


def coaxial_cylinders(shape: Any, line: Line) -> list[tuple[float, float, float]]:
    """(radius, lo, hi) of every cylindrical face of ``shape`` whose axis is ``line`` within
    ``TOL.coupling_centre_mm`` (lo, hi: its span along the line)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepTools import BRepTools
    from OCP.GeomAbs import GeomAbs_Cylinder

    from .. import kernel

    out = []
    for f in kernel.faces(shape):
        surf = BRepAdaptor_Surface(f)
        if surf.GetType() != GeomAbs_Cylinder:
            continue
        cyl = surf.Cylinder()
        ax = cyl.Axis()
        d = np.array([ax.Direction().X(), ax.Direction().Y(), ax.Direction().Z()])
        p = np.array([ax.Location().X(), ax.Location().Y(), ax.Location().Z()])
        off = float(np.linalg.norm(np.cross(d, line.direction)))
        if off * max(cyl.Radius(), 1.0) > TOL.coupling_centre_mm or \
                line.distance(p) > TOL.coupling_centre_mm:
            continue
        u0, u1, v0, v1 = BRepTools.UVBounds_s(f)
        ends = [surf.Value((u0 + u1) / 2, v) for v in (v0, v1)]
        t = sorted(float((np.array([q.X(), q.Y(), q.Z()]) - line.origin) @ line.direction)
                   for q in ends)
        if t[1] - t[0] > 1e-6:
            out.append((float(cyl.Radius()), t[0], t[1]))
    return out


def outer_runs(cylinders: list[tuple[float, float, float]]) -> list[Seat]:
    """The outer radius along the axis as runs of constant radius, in axial order (stretches
    with no coaxial cylinder, a cone or a fillet, are left out)."""
    cuts = sorted({round(x, 6) for _, lo, hi in cylinders for x in (lo, hi)})
    runs: list[Seat] = []
    for a, b in zip(cuts, cuts[1:]):
        mid = (a + b) / 2
        over = [r for r, lo, hi in cylinders if lo - 1e-6 <= mid <= hi + 1e-6]
        if not over:
            continue
        r = max(over)
        last = runs[-1] if runs else None
        if last is not None and abs(last.hi - a) <= 1e-6 and abs(last.radius - r) <= 1e-6 * max(r, 1):
            runs[-1] = Seat(last.radius, last.lo, b)
        else:
            runs.append(Seat(r, a, b))
    return runs


def belt_seat(shape: Any, line: Line) -> Seat | None:
    """The seat a belt runs on about ``line`` (see the module docstring), or None when the part
    has no cylinder coaxial with the line (it is not round about it)."""
    runs = outer_runs(coaxial_cylinders(shape, line))
    if not runs:
        return None
    valleys = [s for i, s in enumerate(runs[1:-1], 1)
               if runs[i - 1].radius > s.radius and runs[i + 1].radius > s.radius]
    if valleys:
        best = max(valleys, key=lambda s: (s.radius, s.hi - s.lo))
        return Seat(best.radius, best.lo, best.hi, flanged=True)
    return max(runs, key=lambda s: (s.radius, s.hi - s.lo))


def _samples(curve: Any, n: int) -> np.ndarray:
    u = np.linspace(curve.FirstParameter(), curve.LastParameter(), n)
    return np.array([[q.X(), q.Y(), q.Z()] for q in (curve.Value(x) for x in u)])


def helix_leads(shape: Any, line: Line) -> list[tuple[float, float]]:
    """(signed lead mm, turns) of every helical edge of ``shape`` about ``line``: positive when
    the edge advances along the line's direction as it turns right-handed about it."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GeomAbs import GeomAbs_Circle, GeomAbs_Line
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer

    edge = _cast("Edge")
    d = line.direction
    u, v = plane_basis(d)
    out = []
    seen: set[bytes] = set()  # the explorer meets an edge once per face
    exp = TopExp_Explorer(shape, TopAbs_EDGE)
    while exp.More():
        curve = BRepAdaptor_Curve(edge(exp.Current()))
        exp.Next()
        if curve.GetType() in (GeomAbs_Line, GeomAbs_Circle):
            continue
        pts = _samples(curve, HELIX_SAMPLES)
        key = np.round(np.sort(pts[[0, HELIX_SAMPLES // 2, -1]], axis=0), 5).tobytes()
        if key in seen:
            continue
        seen.add(key)
        rel = pts - line.origin
        radial = rel - np.outer(rel @ d, d)
        r = np.linalg.norm(radial, axis=1)
        if r.min() <= 1e-6 or r.max() - r.min() > HELIX_RADIUS_REL * r.mean():
            continue
        theta = np.unwrap(np.arctan2(radial @ v, radial @ u))
        if np.abs(np.diff(theta)).max() > MAX_STEP_RAD:  # too coarse to unwrap: densify
            length = GCPnts_AbscissaPoint.Length_s(curve)
            pts = _samples(curve, int(length / (r.min() * MAX_STEP_RAD / 2)) + 2)
            rel = pts - line.origin
            radial = rel - np.outer(rel @ d, d)
            theta = np.unwrap(np.arctan2(radial @ v, radial @ u))
        turns = float(theta[-1] - theta[0]) / (2 * math.pi)
        if abs(turns) < HELIX_MIN_TURNS:
            continue
        t = rel @ d
        slope, icpt = np.polyfit(theta, t, 1)
        lead = 2 * math.pi * float(slope)
        if abs(lead) <= 1e-9 or np.abs(t - (slope * theta + icpt)).max() > HELIX_FIT_REL * abs(lead):
            continue
        out.append((lead, abs(turns)))
    return out


def thread(shape: Any, line: Line) -> Thread | None:
    """The thread of ``shape`` about ``line`` (see the module docstring), or None when no edge
    is a helix about it (a plain rod or bore)."""
    leads = helix_leads(shape, line)
    if not leads:
        return None
    lead = float(np.median([abs(x) for x, _ in leads]))
    right = sum(1 for x, _ in leads if x > 0)
    return Thread(lead, "right" if 2 * right >= len(leads) else "left", len(leads))
