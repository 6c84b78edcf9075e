"""Coupling gate: the geometry of every ``couple(...)`` matches its ratio and meshes.

For each :class:`~procedura_brep.program.model.CompiledCoupling` (the compiler has already
checked the mate kinds, the params, and that the axes are parallel or square within
``TOL.coupling_axis_deg``):

* **gear**: the meshing pair is found among the parts that turn with each joint (its child and
  every part joined to it by static mates) whose boxes meet; each one's teeth are **measured**
  from the solid, never read from anything the program recorded: the part's exact edges that
  lie in a plane across its axis (a gear's end-face outline; the plane nearest the middle of the
  pair's axial overlap) are cut at a radius just inside the tip circle (just outside it for a
  ring gear), and the tooth count is half the number of crossings. (An exact boolean section
  of a 34-tooth gear took 5 s here; its edges take milliseconds.)
  The module is read from the tip circle (ISO 53 addendum of one module:
  ``m = 2 r_tip / (z + 2)``, a ring gear ``2 r_tip / (z - 2)``). Errors: a tooth count other
  than the coupling's param (``coupling-teeth``: the ratio is typed against the teeth), two
  modules that differ by more than ``TOL.coupling_module_rel`` (``coupling-module``), and a
  distance between the two axes other than ``(z1 + z2) m / 2`` (a ring gear: ``(z2 - z1) m /
  2``) by more than ``TOL.coupling_centre_mm`` (``coupling-centre``).
* **rack_pinion**: the pinion's teeth and module are measured as above and compared with the
  params; its axis must lie at its pitch radius ``m z / 2`` from the rack's pitch line (the line
  through the rack part's origin along the slide: :func:`~procedura_brep.program.gearing.rack`
  puts its origin there) within ``TOL.coupling_centre_mm`` (``coupling-rack``).
* **screw**: the nut's slide axis (the prismatic mate's frame Z line) is the screw's axis within
  ``TOL.coupling_centre_mm`` (``coupling-screw``). The thread of the screw (the coupling's
  ``mesh[0]``) is measured from its helical edges (:func:`~.drive_shapes.thread`), and the
  nut's (``mesh[1]``, about its slide axis) when it has one: a lead off ``lead`` by more than
  ``TOL.coupling_lead_rel``, or a hand other than ``hand``, is ``coupling-lead``; a screw with
  no thread (a plain rod) is a ``coupling-unmeasured`` warning.
* **belt**: each joint's pulley is found by :func:`find_pulley` (the pulleys are far apart: no
  box test); with ``driver_teeth``/``driven_teeth`` its teeth are counted on its belt seat's
  outline as a gear's (``coupling-teeth``); with ``driver_diameter``/``driven_diameter`` its
  pitch diameter (a smooth pulley: the seat's diameter; a timing pulley: from its tips and
  grooves, see :attr:`Pulley.pitch_diameter`) must be the param within twice
  ``TOL.coupling_centre_mm`` (``coupling-pulley``); the two seats must overlap along the axes,
  one plane for the belt (``coupling-belt``).

A meshing pair whose checks pass is then **swept over one tooth pitch** of the driver in
``TOL.coupling_samples`` poses (rest first): the driver's part turns (or slides) by the sample,
the driven part by the coupling's ratio, and their exact OCCT common is computed; a common
thicker than ``TOL.penetration_slack_mm`` (boolean noise) is a ``coupling-interference`` error
naming the pair, the depth and the driver's position. The sweep of the whole model stops after
``TOL.coupling_time_s``; a pair it did not finish is a ``coupling-not-verified`` warning, never
a pass. A gear coupling with no toothed pair (plain discs), a belt without its pulleys, a screw
without a thread is a ``coupling-unmeasured`` warning: the ratio is then not checked against
that geometry.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL
from ..findings import Severity
from ..program.couplings import rigid_groups
from ..program.model import CompiledCoupling, CompiledMate, CompiledModel, CompiledPart, Finding
from .drive_shapes import Seat, belt_seat, thread
from .policy import GateResult, result

#: Points sampled on each edge of a section (tooth flanks are monotonic in radius between
#: their ends; the tip lands and root arcs are read at their vertices).
EDGE_SAMPLES: int = 24
#: Parts whose boxes come within this of each other (mm) may mesh.
MESH_GAP_MM: float = 1.0


@dataclass(frozen=True)
class Line:
    """A joint axis in the world: a point and a unit direction (the mate frame's Z)."""

    origin: np.ndarray
    direction: np.ndarray

    @classmethod
    def of(cls, frame: np.ndarray) -> Line:
        d = np.asarray(frame[:3, 2], float)
        return cls(np.asarray(frame[:3, 3], float), d / np.linalg.norm(d))

    def distance(self, point: np.ndarray) -> float:
        """Distance (mm) of ``point`` from the line."""
        return float(np.linalg.norm(np.cross(point - self.origin, self.direction)))

    def turn(self, angle: float) -> np.ndarray:
        """The 4x4 rigid motion turning by ``angle`` rad about this line (right-hand)."""
        x, y, z = self.direction
        c, s = math.cos(angle), math.sin(angle)
        k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
        r = np.eye(3) + s * k + (1 - c) * (k @ k)
        out = np.eye(4)
        out[:3, :3] = r
        out[:3, 3] = self.origin - r @ self.origin
        return out

    def slide(self, distance: float) -> np.ndarray:
        """The 4x4 translation by ``distance`` mm along this line."""
        out = np.eye(4)
        out[:3, 3] = distance * self.direction
        return out


@dataclass(frozen=True)
class Teeth:
    """Teeth measured on a part's section: count, tip radius (mm), inside (a ring gear)."""

    count: int
    tip_r: float
    internal: bool

    @property
    def module(self) -> float:
        """Module from the tip circle (ISO 53 addendum: one module)."""
        return 2.0 * self.tip_r / (self.count + (-2 if self.internal else 2))


def _moving(model: CompiledModel, group: dict[str, str], part: str) -> list[CompiledPart]:
    """The parts (not colour blocks) of ``part``'s link, plan order."""
    g = group.get(part)
    return [p for p in model.parts if not p.block_of and group.get(p.name) == g]


def _box(part: CompiledPart) -> tuple[np.ndarray, np.ndarray]:
    from .. import kernel

    lo, hi = kernel.bbox(part.shape(), optimal=False)
    return np.asarray(lo, float), np.asarray(hi, float)


def _span(lo: np.ndarray, hi: np.ndarray, line: Line) -> tuple[float, float]:
    """The box's extent along ``line`` (params from the line's origin)."""
    c, h = (lo + hi) / 2 - line.origin, (hi - lo) / 2
    t, r = float(c @ line.direction), float(np.abs(line.direction) @ h)
    return t - r, t + r


def _boxes_meet(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]) -> bool:
    return bool(np.all(a[0] <= b[1] + MESH_GAP_MM) and np.all(b[0] <= a[1] + MESH_GAP_MM))


def level_edges(shape: Any, line: Line) -> dict[float, list[np.ndarray]]:
    """Points on the edges of ``shape`` that lie in planes across ``line`` (a gear's end-face
    outlines), grouped by the plane's param along the line (mm, rounded to 1e-4)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    cast = getattr(TopoDS, "Edge_s", None) or TopoDS.Edge
    out: dict[float, list[np.ndarray]] = {}
    seen: set[bytes] = set()  # the explorer meets an edge once per face
    exp = TopExp_Explorer(shape, TopAbs_EDGE)
    while exp.More():
        curve = BRepAdaptor_Curve(cast(exp.Current()))
        exp.Next()
        pts = np.array([[q.X(), q.Y(), q.Z()] for q in (
            curve.Value(u) for u in np.linspace(curve.FirstParameter(), curve.LastParameter(),
                                                EDGE_SAMPLES))])
        key = np.round(np.sort(pts[[0, EDGE_SAMPLES // 2, -1]], axis=0), 5).tobytes()
        if key in seen:
            continue
        seen.add(key)
        t = (pts - line.origin) @ line.direction
        if float(t.max() - t.min()) <= 1e-6:
            out.setdefault(round(float(t.mean()), 4), []).append(pts)
    return out


def teeth_levels(shape: Any, line: Line, *, internal: bool,
                 tip: float | None = None) -> list[tuple[float, Teeth]]:
    """Every plane across ``line`` whose outline shows teeth (at least three): its param along
    the line and the teeth read there.

    The outline's radius is cut just inside its largest radius (a ring gear: just outside its
    smallest), or just inside ``tip`` when given (a flanged pulley: the flange's rim lies in
    the plane of the grooved outline); every crossing is a tooth flank, so the count is half
    the crossings."""
    out = []
    for level, edges in level_edges(shape, line).items():
        radii = [np.linalg.norm(np.cross(e - line.origin, line.direction), axis=1) for e in edges]
        allr = np.concatenate(radii)
        if tip is not None:
            levels_tip = tip
        else:
            levels_tip = float(allr.min() if internal else allr.max())
        eps = max(1e-4, 1e-5 * levels_tip)
        cut = levels_tip + eps if internal else levels_tip - eps
        crossings = sum(int(np.count_nonzero(np.diff(np.sign(r - cut)) != 0)) for r in radii)
        if crossings >= 6:
            out.append((level, Teeth(crossings // 2, levels_tip, internal)))
    return out


def measure_teeth(shape: Any, line: Line, t: float, *, internal: bool) -> Teeth | None:
    """The teeth of ``shape`` about ``line`` on its toothed outline nearest ``t`` (see
    :func:`teeth_levels`); None when no outline shows teeth (a smooth disc)."""
    levels = teeth_levels(shape, line, internal=internal)
    return min(levels, key=lambda lv: abs(lv[0] - t))[1] if levels else None


@dataclass
class Mesh:
    """A meshing pair found for a coupling: the two parts, the section param, their teeth."""

    a: CompiledPart
    b: CompiledPart
    t: float
    teeth_a: Teeth | None
    teeth_b: Teeth | None


def _facing(pa: CompiledPart, line_a: Line, pb: CompiledPart, line_b: Line | None, t: float,
            internal_b: bool) -> tuple[Teeth | None, Teeth | None]:
    """The teeth of ``pa`` and ``pb`` on the outlines that face each other: of every toothed
    plane of each, the two nearest along the axis (a cluster gear has two toothed bands; the
    band its partner meets is the one whose end face lies level with the partner's). Without
    ``line_b``, ``pa``'s outline nearest ``t``."""
    levels_a = teeth_levels(pa.shape(), line_a, internal=False)
    if line_b is None or not levels_a:
        return (min(levels_a, key=lambda lv: abs(lv[0] - t))[1] if levels_a else None), None
    levels_b = teeth_levels(pb.shape(), line_b, internal=internal_b)
    if not levels_b:
        return min(levels_a, key=lambda lv: abs(lv[0] - t))[1], None
    # b's params along a's axis (the axes are parallel or opposed: the compile checked them)
    sense = 1.0 if float(line_a.direction @ line_b.direction) >= 0 else -1.0
    shift = float((line_b.origin - line_a.origin) @ line_a.direction)
    best = min(((abs(la - (shift + sense * lb)), ta, tb) for la, ta in levels_a
                for lb, tb in levels_b), key=lambda r: r[0])
    return best[1], best[2]


def find_pair(model: CompiledModel, group: dict[str, str], mate_a: CompiledMate,
              mate_b: CompiledMate | None, *, internal_b: bool = False,
              only_b: CompiledPart | None = None) -> Mesh | None:
    """The first pair (a part turning with ``mate_a``, a part moving with ``mate_b`` or
    ``only_b``) whose boxes meet, with teeth measured about ``mate_a``'s axis for a and
    ``mate_b``'s for b (None for b when ``only_b``); the first pair with teeth on both wins,
    else the first pair with teeth on a, else None."""
    line_a = Line.of(mate_a.world_frame)
    line_b = Line.of(mate_b.world_frame) if mate_b is not None else None
    side_a = _moving(model, group, mate_a.child)
    side_b = [only_b] if only_b is not None else (
        _moving(model, group, mate_b.child) if mate_b is not None else [])
    best: Mesh | None = None
    for pa in side_a:
        box_a = _box(pa)
        for pb in side_b:
            if pb.name == pa.name:
                continue
            box_b = _box(pb)
            if not _boxes_meet(box_a, box_b):
                continue
            lo_a, hi_a = _span(*box_a, line_a)
            lo_b, hi_b = _span(*box_b, line_a)
            lo, hi = max(lo_a, lo_b), min(hi_a, hi_b)
            if hi <= lo:
                continue
            t = (lo + hi) / 2
            ta, tb = _facing(pa, line_a, pb, line_b, t, internal_b)
            row = Mesh(pa, pb, t, ta, tb)
            if ta is not None and (tb is not None or line_b is None):
                return row
            if ta is not None and best is None:
                best = row
    return best


#: A timing pulley's tips lie this many belt pitches inside its pitch diameter (the belt's
#: pitch line): :func:`~procedura_brep.program.gearing.pulley` builds ``od = pd - 0.254 p``
#: (GT2 at p = 2 mm: 0.254 mm a side). tests/gates/test_coupling_belt_screw.py holds the two
#: together.
TIMING_TIP_PER_PITCH: float = 0.254


@dataclass(frozen=True)
class Pulley:
    """A pulley found for a belt: the part, its joint's axis, its belt seat, its teeth (None:
    a smooth pulley)."""

    part: CompiledPart
    line: Line
    seat: Seat
    teeth: Teeth | None

    @property
    def pitch_diameter(self) -> float:
        """The diameter the belt's pitch line runs on: a smooth seat's own; a timing pulley's
        from its tips and grooves (``od = pd - k p`` with ``p = pi pd / z``, so
        ``pd = od / (1 - k pi / z)``, k = :data:`TIMING_TIP_PER_PITCH`)."""
        if self.teeth is None:
            return self.seat.diameter
        return self.seat.diameter / (1 - TIMING_TIP_PER_PITCH * math.pi / self.teeth.count)


def find_pulley(model: CompiledModel, group: dict[str, str], mate: CompiledMate, *,
                toothed: bool) -> Pulley | None:
    """The pulley turning with ``mate``'s joint. A belt's pulleys are far apart, so their boxes
    are not asked to meet (as :func:`find_pair` asks of gears); the rule, among the parts that
    move with the joint (its child and its rigid link): a part is a candidate when its solid is
    round about the joint's axis (it has a cylindrical face coaxial with it: its belt seat is
    :func:`~procedura_brep.gates.drive_shapes.belt_seat`); when the belt is typed by teeth
    (``toothed``) a candidate whose seat outline shows teeth (counted as a gear's, cut just
    inside the seat radius) wins; then the largest seat radius. None when no part is round
    about the axis."""
    line = Line.of(mate.world_frame)
    best: tuple[tuple[bool, float], Pulley] | None = None
    for part in _moving(model, group, mate.child):
        shape = part.shape()
        seat = belt_seat(shape, line)
        if seat is None:
            continue
        mid = (seat.lo + seat.hi) / 2
        levels = [lv for lv in teeth_levels(shape, line, internal=False, tip=seat.radius)
                  if seat.lo - 1e-4 <= lv[0] <= seat.hi + 1e-4]
        teeth = min(levels, key=lambda lv: abs(lv[0] - mid))[1] if levels else None
        key = (toothed and teeth is not None, seat.radius)
        if best is None or key > best[0]:
            best = (key, Pulley(part, line, seat, teeth))
    return best[1] if best else None


def _sweep(a: CompiledPart, pose_a: Callable[[float], np.ndarray], b: CompiledPart,
           pose_b: Callable[[float], np.ndarray], pitch: float, deadline: float
           ) -> tuple[list[dict[str, float]], int]:
    """Exact commons of ``a`` and ``b`` at ``TOL.coupling_samples`` driver positions over one
    ``pitch`` (rest first): the rows with an overlap, and how many samples ran before the
    deadline."""
    from .. import kernel
    from .common import exact_common

    n = max(int(TOL.coupling_samples), 1)
    rows: list[dict[str, float]] = []
    done = 0
    for k in range(n):
        if time.monotonic() > deadline:
            break
        q = pitch * k / n
        sa = kernel.located(a.local_shape(), pose_a(q) @ a.placement)
        sb = kernel.located(b.local_shape(), pose_b(q) @ b.placement)
        solids = exact_common(sa, sb)
        done += 1
        if solids is None:
            rows.append({"sample": k, "driver": q, "depth_mm": math.nan, "volume_mm3": math.nan})
            continue
        if solids:
            rows.append({"sample": k, "driver": q,
                         "depth_mm": max(s.depth(None) for s in solids),
                         "volume_mm3": sum(s.volume for s in solids)})
    return rows, done


class _Check:
    """One coupling's checks: its findings and its measured row."""

    def __init__(self, model: CompiledModel, c: CompiledCoupling, group: dict[str, str],
                 deadline: float) -> None:
        self.model, self.c, self.group, self.deadline = model, c, group, deadline
        self.mates = {m.name: m for m in model.mates}
        self.findings: list[Finding] = []
        self.row: dict[str, Any] = {"type": c.type, "driver": c.driver, "driven": c.driven,
                                    "ratio": c.ratio}
        self.head = f"couple({c.driven!r}, {c.driver!r})"

    def fail(self, code: str, text: str, *, part: str | None = None, other: str | None = None,
             value: float | None = None, limit: float | None = None,
             severity: Severity = "error") -> None:
        self.findings.append(Finding(code, f"{self.head}: {text}", part=part, mate=self.c.driven,
                                     line=self.c.line, value=value, limit=limit,
                                     severity=severity, other=other))

    def run(self) -> None:
        drv, dvn = self.mates.get(self.c.driver), self.mates.get(self.c.driven)
        if drv is None or dvn is None:
            return  # the compile reported it
        getattr(self, f"_{self.c.type}", lambda *_: None)(drv, dvn)

    # -- gear --------------------------------------------------------------------------------
    def _gear(self, drv: CompiledMate, dvn: CompiledMate) -> None:
        c = self.c
        internal = str(c.inputs.get("internal", "false")).lower() == "true"
        mesh = find_pair(self.model, self.group, drv, dvn, internal_b=internal)
        if mesh is None or mesh.teeth_a is None or mesh.teeth_b is None:
            self._unmeasured(drv, dvn, "gears")
            return
        z_drv, z_dvn = c.values.get("driver_teeth"), c.values.get("driven_teeth")
        ta, tb = mesh.teeth_a, mesh.teeth_b
        self.row.update(pair=[mesh.a.name, mesh.b.name],
                        teeth={mesh.a.name: ta.count, mesh.b.name: tb.count},
                        module_mm={mesh.a.name: round(ta.module, 6), mesh.b.name: round(tb.module, 6)})
        ok = self._teeth(mesh.a.name, ta, "driver_teeth", z_drv, mesh.b.name)
        ok &= self._teeth(mesh.b.name, tb, "driven_teeth", z_dvn, mesh.a.name)
        if abs(ta.module - tb.module) > TOL.coupling_module_rel * max(ta.module, tb.module):
            ok = False
            self.fail("coupling-module", f"{mesh.a.name} has module {ta.module:.4g} mm and "
                      f"{mesh.b.name} {tb.module:.4g} mm (from their tip circles): gears of two "
                      f"modules do not mesh", part=mesh.b.name, other=mesh.a.name,
                      value=tb.module, limit=ta.module)
        if not ok or z_drv is None or z_dvn is None:
            return
        m = (ta.module + tb.module) / 2
        expect = m * (z_dvn - z_drv if internal else z_dvn + z_drv) / 2
        la, lb = Line.of(drv.world_frame), Line.of(dvn.world_frame)
        got = lb.distance(la.origin)
        self.row["centre_mm"] = {"expected": round(expect, 6), "measured": round(got, 6)}
        if abs(got - expect) > TOL.coupling_centre_mm:
            kind = "(z2 - z1) m / 2 (internal)" if internal else "(z1 + z2) m / 2"
            self.fail("coupling-centre", f"the axes of {c.driver} and {c.driven} are "
                      f"{got:.4g} mm apart, but {kind} = ({z_dvn:g} {'-' if internal else '+'} "
                      f"{z_drv:g}) x {m:.4g} / 2 = {expect:.4g} mm (allowed "
                      f"+-{TOL.coupling_centre_mm:g} mm); move the frames of the two mates",
                      part=mesh.b.name, other=mesh.a.name, value=got, limit=expect)
            return
        self._interference(mesh.a, lambda q: la.turn(q), mesh.b, lambda q: lb.turn(c.ratio * q),
                           2 * math.pi / z_drv, "deg", drv.name)

    def _teeth(self, name: str, teeth: Teeth, key: str, declared: float | None, other: str,
               *, where: str = "") -> bool:
        if declared is None or teeth.count == round(declared):
            return True
        param = self.c.inputs.get(key, key)
        where = where or f"on its section where it meets {other}"
        noun = "pulley" if self.c.type == "belt" else "gear"
        self.fail("coupling-teeth", f"{name} has {teeth.count} teeth (measured {where}), but "
                  f"{key} = {param} = {declared:g}: the ratio {self.c.ratio:.4g} is typed "
                  f"against the teeth; make the param and the {noun} agree", part=name,
                  other=other, value=teeth.count, limit=declared)
        return False

    def _unmeasured(self, drv: CompiledMate, dvn: CompiledMate, what: str,
                    helper: str = "spur_gear / ring_gear / rack") -> None:
        if self.row.get("measured") is False:
            return  # said once per coupling
        sides = ", ".join(f"{m.name}: {' '.join(p.name for p in _moving(self.model, self.group, m.child))}"
                          for m in (drv, dvn))
        self.row["measured"] = False
        noun = "teeth" if helper != "pulley" else "pulleys"
        pair = "toothed pair of " if helper != "pulley" else ""
        self.fail("coupling-unmeasured", f"no {pair}{what} found among the parts that "
                  f"move with the two joints ({sides}); the ratio is not checked against any "
                  f"{noun} (model them with {helper})", severity="warning")

    # -- rack and pinion -----------------------------------------------------------------------
    def _rack_pinion(self, drv: CompiledMate, dvn: CompiledMate) -> None:
        c = self.c
        from ..mates import TYPES, Motion
        turns = drv.type in TYPES and TYPES[drv.type].motion is Motion.TURN
        rev, pri = (drv, dvn) if turns else (dvn, drv)
        rack_name = c.inputs.get("rack") or pri.child
        try:
            rack_part = self.model.part(rack_name)
        except KeyError:
            return
        a, s = Line.of(rev.world_frame), Line.of(pri.world_frame)
        n = np.cross(a.direction, s.direction)
        if np.linalg.norm(n) < 1e-9:
            return  # not square: the compile reported it
        n /= np.linalg.norm(n)
        z, m = c.values.get("pinion_teeth"), c.values.get("module")
        if z is None or m is None:
            return
        r = m * z / 2
        got = abs(float((rack_part.placement[:3, 3] - a.origin) @ n))
        self.row["pitch_line_mm"] = {"expected": round(r, 6), "measured": round(got, 6),
                                     "rack": rack_name}
        ok = True
        if abs(got - r) > TOL.coupling_centre_mm:
            ok = False
            self.fail("coupling-rack", f"the axis of {rev.name} is {got:.4g} mm from the pitch "
                      f"line of {rack_name} (through its origin, along {pri.name}), but the "
                      f"pitch radius m z / 2 = {m:g} x {z:g} / 2 = {r:.4g} mm (allowed "
                      f"+-{TOL.coupling_centre_mm:g} mm)", part=rack_name, value=got, limit=r)
        mesh = find_pair(self.model, self.group, rev, None, only_b=rack_part)
        if mesh is None or mesh.teeth_a is None:
            self._unmeasured(rev, pri, "pinion and rack")
            return
        ta = mesh.teeth_a
        self.row.update(pair=[mesh.a.name, rack_name], teeth={mesh.a.name: ta.count},
                        module_mm={mesh.a.name: round(ta.module, 6)})
        ok &= self._teeth(mesh.a.name, ta, "pinion_teeth", z, rack_name)
        if abs(ta.module - m) > TOL.coupling_module_rel * m:
            ok = False
            self.fail("coupling-module", f"{mesh.a.name} has module {ta.module:.4g} mm (from its "
                      f"tip circle), but module = {c.inputs.get('module')} = {m:g}",
                      part=mesh.a.name, other=rack_name, value=ta.module, limit=m)
        if not ok:
            return
        # the rack moves relative to the pinion: with the slide when it is the slide's child,
        # against it when the pinion rides on the slide
        sign = 1.0 if self.group.get(rack_name) == self.group.get(pri.child) else -1.0
        if drv is rev:
            pose_pinion, pose_rack = (lambda q: a.turn(q)), (lambda q: s.slide(sign * c.ratio * q))
            pitch, unit = 2 * math.pi / z, "deg"
        else:
            pose_pinion, pose_rack = (lambda q: a.turn(c.ratio * q)), (lambda q: s.slide(sign * q))
            pitch, unit = math.pi * m, "mm"
        self._interference(mesh.a, pose_pinion, rack_part, pose_rack, pitch, unit, drv.name)

    # -- screw -------------------------------------------------------------------------------
    def _screw(self, drv: CompiledMate, dvn: CompiledMate) -> None:
        a, s = Line.of(drv.world_frame), Line.of(dvn.world_frame)
        got = a.distance(s.origin)
        self.row["axis_offset_mm"] = round(got, 6)
        if got > TOL.coupling_centre_mm:
            self.fail("coupling-screw", f"the slide axis of {dvn.name} is {got:.4g} mm off the "
                      f"screw axis of {drv.name} (allowed {TOL.coupling_centre_mm:g} mm): put the "
                      f"nut's slide frame on the screw axis", part=dvn.child, other=drv.child,
                      value=got, limit=TOL.coupling_centre_mm)
        self._lead(a, s)

    def _lead(self, a: Line, s: Line) -> None:
        """The lead (and hand) of the screw's thread, and of its nut's when it has one, against
        ``lead`` and ``hand``; a screw with no thread is unmeasured."""
        c = self.c
        lead, hand = c.values.get("lead"), str(c.inputs.get("hand") or "right")
        screw, nut = (c.mesh + ("", ""))[:2]
        if lead is None or not screw:
            return
        leads: dict[str, float] = {}
        for name, line, role in ((screw, a, "screw"), (nut, s, "nut")):
            try:
                part = self.model.part(name)
            except KeyError:
                continue
            th = thread(part.shape(), line)
            if th is None:
                if role == "screw":
                    self.row["measured"] = False
                    self.fail("coupling-unmeasured", f"no helical thread found on {name} (the "
                              f"screw); its lead {lead:g} mm is not checked against any thread "
                              f"(model it with lead_screw)", part=name, severity="warning")
                continue
            leads[name] = round(th.lead, 6)
            other = nut if role == "screw" else screw
            param = c.inputs.get("lead", "lead")
            if abs(th.lead - lead) > TOL.coupling_lead_rel * lead:
                self.fail("coupling-lead", f"the thread of {name} (the {role}) advances "
                          f"{th.lead:.4g} mm per turn (measured on its {th.helices} helical "
                          f"edges), but lead = {param} = {lead:g} mm (allowed "
                          f"+-{100 * TOL.coupling_lead_rel:g} %): the ratio {c.ratio:.4g} mm/rad "
                          f"is typed against the lead; make the param and the thread agree",
                          part=name, other=other, value=th.lead, limit=lead)
            elif th.hand != hand:
                self.fail("coupling-lead", f"the thread of {name} (the {role}) is {th.hand}-"
                          f"handed, but the coupling says hand={hand!r}: the nut would move the "
                          f"other way; make hand= and the thread agree", part=name, other=other)
        if leads:
            self.row["lead_mm"] = leads

    # -- belt --------------------------------------------------------------------------------
    def _belt(self, drv: CompiledMate, dvn: CompiledMate) -> None:
        c = self.c
        by_teeth = "driver_teeth" in c.values
        kind = "teeth" if by_teeth else "diameter"
        found = [find_pulley(self.model, self.group, m, toothed=by_teeth) for m in (drv, dvn)]
        pa, pb = found
        if pa is None or pb is None:
            self._unmeasured(drv, dvn, "pulleys round about the joint axes", "pulley")
            return
        if pa.part.name == pb.part.name:
            return  # one part on both joints: the compile's rigid links say so
        self.row["pair"] = [pa.part.name, pb.part.name]
        for p, key in ((pa, f"driver_{kind}"), (pb, f"driven_{kind}")):
            other = (pb if p is pa else pa).part.name
            declared = c.values.get(key)
            if by_teeth:
                if p.teeth is None:
                    self._unmeasured(drv, dvn, "timing pulleys (toothed)", "pulley")
                    continue
                self.row.setdefault("teeth", {})[p.part.name] = p.teeth.count
                self._teeth(p.part.name, p.teeth, key, declared, other, where="on the outline of its belt seat")
            elif declared is not None:
                self._diameter(p, key, declared, other)
        self._plane(pa, pb)

    def _diameter(self, p: Pulley, key: str, declared: float, other: str) -> None:
        name, param = p.part.name, self.c.inputs.get(key, key)
        got = p.pitch_diameter
        if p.teeth is None:
            what = (f"a belt seat {got:.4g} mm across (the cylinder its belt runs on"
                    f"{', between its flanges' if p.seat.flanged else ''})")
        else:
            what = (f"{p.teeth.count} grooves and tips {p.seat.diameter:.4g} mm across, so a "
                    f"pitch diameter of {got:.4g} mm (a timing pulley's tips lie "
                    f"{TIMING_TIP_PER_PITCH:g} belt pitches inside it, as pulley() builds)")
        self.row.setdefault("diameter_mm", {})[name] = {"expected": round(declared, 6),
                                                        "measured": round(got, 6)}
        allowed = 2 * TOL.coupling_centre_mm
        if abs(got - declared) > allowed:
            self.fail("coupling-pulley", f"{name} has {what}, but {key} = {param} = "
                      f"{declared:g} mm (allowed +-{allowed:g} mm): the ratio {self.c.ratio:.4g} "
                      f"is typed against the diameters; make the param and the pulley agree",
                      part=name, other=other, value=got, limit=declared)

    def _plane(self, pa: Pulley, pb: Pulley) -> None:
        """Both belt seats must overlap along the (parallel) axes: else the belt runs off."""
        la, lb = pa.line, pb.line
        sense = 1.0 if float(la.direction @ lb.direction) >= 0 else -1.0
        shift = float((lb.origin - la.origin) @ la.direction)
        b_lo, b_hi = sorted((shift + sense * pb.seat.lo, shift + sense * pb.seat.hi))
        a_lo, a_hi = pa.seat.lo, pa.seat.hi
        overlap = min(a_hi, b_hi) - max(a_lo, b_lo)
        self.row["seat_mm"] = {pa.part.name: [round(a_lo, 6), round(a_hi, 6)],
                               pb.part.name: [round(b_lo, 6), round(b_hi, 6)]}
        self.row["overlap_mm"] = round(overlap, 6)
        if overlap <= 1e-6:
            self.fail("coupling-belt", f"the belt seats of {pa.part.name} ({a_lo:.4g} .. "
                      f"{a_hi:.4g} mm along the axis of {self.c.driver}) and {pb.part.name} "
                      f"({b_lo:.4g} .. {b_hi:.4g} mm) do not overlap ({-overlap:.4g} mm apart): "
                      f"a belt between them would run off; move one pulley along its axis so "
                      f"both lie in one plane across the axes", part=pb.part.name,
                      other=pa.part.name, value=overlap, limit=0.0)

    # -- the sweep over one pitch ------------------------------------------------------------
    def _interference(self, a: CompiledPart, pose_a: Callable[[float], np.ndarray],
                      b: CompiledPart, pose_b: Callable[[float], np.ndarray], pitch: float,
                      unit: str, driver: str) -> None:
        t0 = time.perf_counter()
        rows, done = _sweep(a, pose_a, b, pose_b, pitch, self.deadline)
        n = max(int(TOL.coupling_samples), 1)
        show = (lambda q: math.degrees(q)) if unit == "deg" else (lambda q: q)
        worst = max((r for r in rows if not math.isnan(r["depth_mm"])),
                    key=lambda r: r["depth_mm"], default=None)
        self.row["sweep"] = {"samples": done, "of": n, "pitch": round(show(pitch), 6), "unit": unit,
                             "max_depth_mm": round(worst["depth_mm"], 6) if worst else 0.0,
                             "seconds": round(time.perf_counter() - t0, 3)}
        failed = [r for r in rows if math.isnan(r["depth_mm"])]
        if done < n or failed:
            why = (f"the time bound (TOL.coupling_time_s = {TOL.coupling_time_s:g} s) ran out "
                   f"after {done} of {n} poses" if done < n else
                   f"OCCT could not compute their common at {len(failed)} pose(s)")
            self.fail("coupling-not-verified", f"the mesh of {a.name} and {b.name} over one "
                      f"pitch is not verified: {why}", part=b.name, other=a.name,
                      severity="warning")
        rest = next((r for r in rows if r["sample"] == 0 and not math.isnan(r["depth_mm"])), None)
        if rest is not None and rest["depth_mm"] > TOL.penetration_slack_mm:
            worst = rest  # a pair that clashes at rest: say so first
        if worst is not None and worst["depth_mm"] > TOL.penetration_slack_mm:
            at = ("at rest" if worst["sample"] == 0 else
                  f"with {driver} at {show(worst['driver']):.3g} {unit} (pose {worst['sample']} of "
                  f"{n} over one pitch, {show(pitch):.3g} {unit})")
            self.fail("coupling-interference", f"the teeth of {a.name} and {b.name} "
                      f"interpenetrate {worst['depth_mm']:.3g} mm deep (volume "
                      f"{worst['volume_mm3']:.3g} mm^3) {at}, > {TOL.penetration_slack_mm:g} mm "
                      f"allowed; check the tooth phase (spur_gear(..., phase=0.5) turns a gear "
                      f"half a pitch), the ratio's sign and the centre distance", part=b.name,
                      other=a.name, value=worst["depth_mm"], limit=TOL.penetration_slack_mm)


def coupling_gate(model: CompiledModel) -> tuple[list[Finding], GateResult]:
    """Run the coupling gate; ``measured["couplings"]`` has one row per coupling (its pair,
    teeth, modules, expected and measured centre distance or pitch line, and the sweep)."""
    deadline = time.monotonic() + TOL.coupling_time_s
    group = rigid_groups(model) if model.couplings else {}
    findings: list[Finding] = []
    rows: dict[str, Any] = {}
    for c in model.couplings:
        check = _Check(model, c, group, deadline)
        check.run()
        findings += check.findings
        rows[c.name] = check.row
    return findings, result("coupling", findings, {"couplings": rows})
