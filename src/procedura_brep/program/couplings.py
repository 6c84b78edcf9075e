"""Couplings: two kinematic mates that move together (``couple(driven, driver, type, ...)``).

A coupling ties a *driven* joint to a *driver* joint: a gear pair, a rack and pinion, a lead
screw and its nut, a belt, or a linkage that closes a loop. Every number it needs is read from a
NAMED param (tooth counts, module, lead, diameters), so one edit changes the geometry and the
ratio together.

This module holds the vocabulary (:data:`SPECS`: the keywords of each type and the mate kinds it
joins), the early keyword check :func:`check_keywords` (run by ``couple(...)`` itself) and
:func:`resolve`, which the compiler runs once the mates are placed: it checks the mates, the
params and the coupling graph (a driven joint has one driver; no cycles) and derives each
ratio and its sign from the params and the two joints' world axes. Errors are findings (code
``coupling``) whose one-line message names both mates.

Ratios are in the mates' own motion units with angles in radians: rad/rad (gear, belt), mm/rad
(a prismatic driven by a revolute), rad/mm (a revolute driven by a prismatic). The exporters turn
mm into m (:func:`si_ratio`). Joint positions count from the compiled pose, where every coupled
pair meshes, so the offset is 0.

Signs (``a``: a revolute's world axis, ``s``: a prismatic's world axis, both the mate frames'
+Z):

* gear, external mesh: ``-(z_driver / z_driven) * sign(a_driver . a_driven)``; internal mesh
  (a ring gear) and belt: ``+(... ) * sign(a_driver . a_driven)``; the axes must be parallel.
* rack and pinion: the pinion's pitch point ``P`` (on the rack part's origin side of the pinion
  axis, at pitch radius ``r = m z / 2``) rolls on the rack:
  ``dx/dtheta = r * sign((P - C) . (s x a))`` when the rack slides (the prismatic's child is the
  rack), negated when the pinion rides on the sliding carriage (the revolute's parent is at or
  below the prismatic's child); ``a`` and ``s`` must be perpendicular.
* screw: a right-hand screw turning by ``+theta`` about ``a`` moves a nut that cannot turn by
  ``-lead * theta / 2 pi`` along ``a`` (a left-hand screw: ``+``), negated when the screw rides
  on the carriage and the nut is fixed; ``a`` and ``s`` must be parallel.

A linkage (``closes="<mate>"``) has no constant ratio (0): the named mate, a revolute or
spherical mate whose child an earlier mate already placed, is the loop's cut joint; its anchors
must meet at the compiled pose (the compiler checks them, :func:`cut_gap`), and the exports close
the loop there (MJCF ``<equality><connect>``). The driver turns the loop; the driven joint and
every other joint of the loop follow passively (:mod:`procedura_brep.articulation.tree`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from ..config import TOL
from ..errors import ProgramFormatError
from ..text import did_you_mean
from .model import CompiledCoupling, Finding

if TYPE_CHECKING:
    from .model import CompiledMate, CompiledModel
    from .registry import CoupleDecl

CouplingType = Literal["gear", "rack_pinion", "screw", "belt", "linkage"]
MateKind = Literal["revolute", "prismatic"]


@dataclass(frozen=True)
class CouplingSpec:
    """One coupling type: the mate types it joins and its keywords.

    Attributes:
        name: the type.
        driven, driver: the mate types allowed for each end (``either``: the pair, in any order).
        either: the two ends may come in either order (a rack and pinion).
        params: alternative sets of keywords whose values are param NAMES (belt: teeth or
            diameters); exactly one set must be given whole.
        options: literal keywords and their allowed values (``None``: any snake_case name).
        defaults: the literal keywords' defaults.
    """

    name: CouplingType
    driven: tuple[MateKind, ...]
    driver: tuple[MateKind, ...]
    params: tuple[tuple[str, ...], ...]
    options: dict[str, tuple[Any, ...] | None]
    defaults: dict[str, Any]
    either: bool = False

    @property
    def keywords(self) -> list[str]:
        out = [k for group in self.params for k in group if k]
        return [*dict.fromkeys(out), *self.options]


SPECS: dict[str, CouplingSpec] = {s.name: s for s in (
    CouplingSpec("gear", ("revolute",), ("revolute",), (("driver_teeth", "driven_teeth"),),
                 {"internal": (False, True)}, {"internal": False}),
    CouplingSpec("rack_pinion", ("prismatic", "revolute"), ("revolute", "prismatic"),
                 (("pinion_teeth", "module"),), {"rack": None}, {"rack": ""}, either=True),
    CouplingSpec("screw", ("prismatic",), ("revolute",), (("lead",),),
                 {"hand": ("right", "left"), "nut": None}, {"hand": "right", "nut": ""}),
    CouplingSpec("belt", ("revolute",), ("revolute",),
                 (("driver_teeth", "driven_teeth"), ("driver_diameter", "driven_diameter")), {}, {}),
    CouplingSpec("linkage", ("revolute", "prismatic"), ("revolute", "prismatic"), ((),),
                 {"closes": None}, {"closes": ""}),
)}
#: Keywords whose param must hold a whole number (tooth counts).
WHOLE = frozenset({"driver_teeth", "driven_teeth", "pinion_teeth"})
#: Most couplings a program may declare.
MAX_COUPLINGS = 256


def check_keywords(driven: Any, driver: Any, ctype: Any, named: dict[str, Any],
                   line: int | None) -> dict[str, Any]:
    """The statement's own checks (no params or mates needed): the type, the keywords, param
    inputs given as names and literal options in range. Returns the keywords with the literal
    options' defaults filled in.

    Raises:
        ProgramFormatError: one line naming the statement (both mates) and what is wrong.
    """
    who = f"couple({driven!r:.40}, {driver!r:.40})"
    if not isinstance(ctype, str) or ctype not in SPECS:
        raise ProgramFormatError(f"{who}: type {ctype!r:.40} is not one of {', '.join(SPECS)}"
                                 f"{did_you_mean(ctype, SPECS)}", line=line)
    spec = SPECS[ctype]
    extra = [k for k in named if k not in spec.keywords]
    if extra:
        raise ProgramFormatError(f"{who}: {ctype} takes {', '.join(spec.keywords)}, not "
                                 f"{extra[0]}{did_you_mean(extra[0], spec.keywords)}", line=line)
    given = [g for g in spec.params if g and all(k in named for k in g)]
    if spec.params != ((),) and len(given) != 1:
        sets = " or ".join("(" + ", ".join(g) + ")" for g in spec.params)
        raise ProgramFormatError(f"{who}: {ctype} needs {sets}, each the NAME of a param", line=line)
    used = set(given[0]) if given else set()
    stray = [k for g in spec.params for k in g if k in named and k not in used]
    if stray:
        raise ProgramFormatError(f"{who}: give either tooth counts or diameters, not both "
                                 f"({stray[0]})", line=line)
    for k in used:
        v = named[k]
        if not isinstance(v, str):
            raise ProgramFormatError(f"{who}: {k} must be the NAME of a param (a string such as "
                                     f"'z_pinion'), not the literal {v!r:.40}; add a param and "
                                     f"pass its name, so the geometry and the ratio change "
                                     f"together", line=line)
    out = {k: named[k] for k in used}
    for k, allowed in spec.options.items():
        v = named.get(k, spec.defaults[k])
        if allowed is None:
            if not isinstance(v, str) or (v and not _snake(v)):
                raise ProgramFormatError(f"{who}: {k} must be a name [a-z][a-z0-9_]*, got {v!r:.40}",
                                         line=line)
        elif v not in allowed or isinstance(v, bool) != isinstance(allowed[0], bool):
            raise ProgramFormatError(f"{who}: {k}={v!r:.40} is not one of "
                                     f"{', '.join(repr(a) for a in allowed)}", line=line)
        out[k] = v
    if ctype == "linkage" and not out["closes"]:
        raise ProgramFormatError(f"{who}: linkage needs closes='<mate>', the mate that closes the "
                                 f"loop (its cut joint)", line=line)
    return out


def _snake(v: str) -> bool:
    from .registry import valid_name
    return valid_name(v)


class _Refusal(Exception):
    """One coupling is wrong: the message names it (becomes a finding)."""


def resolve(decls: list[CoupleDecl], model: CompiledModel, declared_mates: set[str]
            ) -> tuple[list[CompiledCoupling], list[Finding]]:
    """Check every coupling against the compiled mates and params; derive ratios and signs.

    Args:
        decls: the program's ``couple(...)`` statements.
        model: the compiled model (mates placed, params known).
        declared_mates: every mate the program declares (a coupling of a mate that failed to
            compile is skipped: that mate's own finding says why).

    Returns:
        (the couplings that resolved, a finding for each that did not or that breaks the
        graph: a joint driven twice, a cycle).
    """
    mates = {m.name: m for m in model.mates}
    out: list[CompiledCoupling] = []
    findings: list[Finding] = []
    if len(decls) > MAX_COUPLINGS:
        return [], [Finding("coupling", f"the program declares {len(decls)} couplings; the cap is "
                                        f"{MAX_COUPLINGS}", value=len(decls), limit=MAX_COUPLINGS)]
    for d in decls:
        who = f"couple({d.driven!r}, {d.driver!r})"
        if {d.driven, d.driver} & (declared_mates - set(mates)):
            continue
        try:
            out.append(_one(d, who, mates, model))
        except _Refusal as exc:
            findings.append(Finding("coupling", f"{who}: {exc}", mate=d.driven, line=d.line))
    return _graph(out, findings)


def _graph(cs: list[CompiledCoupling], findings: list[Finding]
           ) -> tuple[list[CompiledCoupling], list[Finding]]:
    """A driven joint has one driver; the driver -> driven graph has no cycle."""
    driver_of: dict[str, CompiledCoupling] = {}
    kept: list[CompiledCoupling] = []
    for c in cs:
        first = driver_of.get(c.driven)
        if first is not None:
            findings.append(Finding("coupling", f"couple({c.driven!r}, {c.driver!r}): joint "
                                                f"{c.driven} is already driven by {first.driver} "
                                                f"(line {first.line}); a joint has one driver",
                                    mate=c.driven, line=c.line))
            continue
        driver_of[c.driven] = c
        kept.append(c)
    cyclic: set[str] = set()
    for c in kept:
        seen = [c.driven]
        cur = c.driver
        while cur in driver_of and cur not in seen:
            seen.append(cur)
            cur = driver_of[cur].driver
        if cur == c.driven and c.name not in cyclic:
            loop = " <- ".join([*seen, cur])
            cyclic |= {driver_of[n].name for n in seen}
            findings.append(Finding("coupling", f"couple({c.driven!r}, {c.driver!r}): the "
                                                f"couplings form a cycle ({loop}); every chain "
                                                f"of couplings starts at a joint nobody drives",
                                    mate=c.driven, line=c.line))
    return [c for c in kept if c.name not in cyclic], findings


def _mate(name: str, role: str, mates: dict[str, CompiledMate]) -> CompiledMate:
    m = mates.get(name)
    if m is None:
        raise _Refusal(f"{role} mate {name!r} is not a mate of the program"
                       f"{did_you_mean(name, mates) or '; mates: ' + ', '.join(list(mates)[:12])}")
    return m


def _one(d: CoupleDecl, who: str, mates: dict[str, CompiledMate],
         model: CompiledModel) -> CompiledCoupling:
    spec = SPECS[d.type]
    if d.driven == d.driver:
        raise _Refusal("a joint cannot drive itself")
    driven, driver = _mate(d.driven, "driven", mates), _mate(d.driver, "driver", mates)
    kinds = (driven.type, driver.type)
    ok = (driven.type in spec.driven and driver.type in spec.driver
          and (not spec.either or driven.type != driver.type))
    if not ok:
        want = ("a prismatic and a revolute mate (either order)" if spec.either else
                f"driven {' or '.join(spec.driven)}, driver {' or '.join(spec.driver)}")
        raise _Refusal(f"{d.type} joins {want}; {d.driven} is {kinds[0]} and {d.driver} is "
                       f"{kinds[1]}")
    inputs: dict[str, str] = {}
    values: dict[str, float] = {}
    for k, v in d.named.items():
        if k in spec.options:
            if v != "":
                inputs[k] = str(v).lower() if isinstance(v, bool) else str(v)
            continue
        inputs[k], values[k] = v, _param(k, v, model.params)
    ratio, mesh = _RATIO[d.type](d, driven, driver, values, model)
    return CompiledCoupling(name=f"{d.driven}__{d.driver}", type=d.type, driven=d.driven,
                            driver=d.driver, ratio=ratio, inputs=inputs, values=values,
                            closes=str(d.named.get("closes", "")), line=d.line, mesh=mesh)


def _param(key: str, name: str, params: dict[str, Any]) -> float:
    if name not in params:
        raise _Refusal(f"{key}={name!r} is not a param{did_you_mean(name, params)}; params: "
                       f"{', '.join(list(params)[:12]) or 'none'}")
    v = params[name]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not v > 0:
        raise _Refusal(f"{key}: param {name} = {v!r:.40} must be a positive number")
    if key in WHOLE and float(v) != round(v):
        raise _Refusal(f"{key}: param {name} = {v:g} must be a whole number of teeth")
    return float(v)


def _axis(m: CompiledMate) -> np.ndarray:
    a = np.asarray(m.world_frame, float)[:3, 2]
    unit: np.ndarray = a / np.linalg.norm(a)
    return unit


def _parallel(a: CompiledMate, b: CompiledMate, what: str) -> float:
    """sign(a . b) of two parallel axes (refused when they are not parallel)."""
    dot = float(_axis(a) @ _axis(b))
    if abs(dot) < math.cos(math.radians(TOL.coupling_axis_deg)):
        raise _Refusal(f"{what} needs parallel axes; {a.name} and {b.name} are "
                       f"{math.degrees(math.acos(max(-1.0, min(1.0, dot)))):.3g} deg apart "
                       f"(tolerance {TOL.coupling_axis_deg:g} deg)")
    return 1.0 if dot > 0 else -1.0


def _gear(d: CoupleDecl, driven: CompiledMate, driver: CompiledMate, v: dict[str, float],
          model: CompiledModel) -> tuple[float, tuple[str, str]]:
    sense = _parallel(driver, driven, "a spur gear pair")
    mesh = 1.0 if d.named.get("internal") else -1.0
    return mesh * sense * v["driver_teeth"] / v["driven_teeth"], (driven.child, driver.child)


def _belt(d: CoupleDecl, driven: CompiledMate, driver: CompiledMate, v: dict[str, float],
          model: CompiledModel) -> tuple[float, tuple[str, str]]:
    sense = _parallel(driver, driven, "a belt")
    if "driver_teeth" in v:
        return sense * v["driver_teeth"] / v["driven_teeth"], ("", "")
    return sense * v["driver_diameter"] / v["driven_diameter"], ("", "")


def _ancestors(part: str, model: CompiledModel) -> list[str]:
    """``part`` and the parts above it along the placing (primary) mates."""
    up = {m.child: m.parent for m in model.mates if m.primary}
    out = [part]
    while out[-1] in up and len(out) <= len(up):
        out.append(up[out[-1]])
    return out


def _turns(mate_type: str) -> bool:
    """Whether a mate of this type turns about one axis (the vocabulary says, not its name)."""
    from ..mates import TYPES, Motion
    return mate_type in TYPES and TYPES[mate_type].motion is Motion.TURN


def _slides(mate_type: str) -> bool:
    """Whether a mate of this type slides along one axis."""
    from ..mates import TYPES, Motion
    return mate_type in TYPES and TYPES[mate_type].motion is Motion.SLIDE


def _rides(revolute: CompiledMate, prismatic: CompiledMate, model: CompiledModel) -> bool:
    """The revolute joint rides on the prismatic's slider (its parent is at or below it)."""
    return prismatic.child in _ancestors(revolute.parent, model)


def _rack(d: CoupleDecl, driven: CompiledMate, driver: CompiledMate, v: dict[str, float],
          model: CompiledModel) -> tuple[float, tuple[str, str]]:
    rev, pri = (driver, driven) if _turns(driver.type) else (driven, driver)
    a, s = _axis(rev), _axis(pri)
    dot = float(a @ s)
    if abs(dot) > math.sin(math.radians(TOL.coupling_axis_deg)):
        raise _Refusal(f"a rack and pinion needs the pinion axis ({rev.name}) square to the rack's "
                       f"travel ({pri.name}); they are {math.degrees(math.acos(max(-1.0, min(1.0, dot)))):.3g} "
                       f"deg apart")
    rides = _rides(rev, pri, model)
    rack = str(d.named.get("rack") or (pri.parent if rides else pri.child))
    try:
        origin = np.asarray(model.part(rack).placement, float)[:3, 3]
    except KeyError:
        names = [p.name for p in model.parts]
        raise _Refusal(f"rack={rack!r} is not a part{did_you_mean(rack, names)}") from None
    centre = np.asarray(rev.world_frame, float)[:3, 3]
    n = np.cross(s, a)
    side = float((origin - centre) @ n)
    if abs(side) <= TOL.placement_mm * 1e3:
        raise _Refusal(f"cannot tell on which side of the pinion axis the rack {rack} lies (its "
                       f"origin is on the axis plane); model the rack around its pitch line or "
                       f"name the rack part with rack='...'")
    r = v["module"] * v["pinion_teeth"] / 2.0
    k = r * (1.0 if side > 0 else -1.0) * (-1.0 if rides else 1.0)  # mm of slide per rad
    return (k if driven is pri else 1.0 / k), (rack, rev.child)


def _screw(d: CoupleDecl, driven: CompiledMate, driver: CompiledMate, v: dict[str, float],
           model: CompiledModel) -> tuple[float, tuple[str, str]]:
    sense = _parallel(driver, driven, "a lead screw and its nut")
    hand = 1.0 if d.named.get("hand", "right") == "right" else -1.0
    rides = _rides(driver, driven, model)
    side = driven.parent if rides else driven.child
    named = str(d.named.get("nut") or "")
    if named:
        names = [p.name for p in model.parts if not p.block_of]
        if named not in names:
            raise _Refusal(f"nut={named!r} is not a part{did_you_mean(named, names)}")
        group = rigid_groups(model)
        if group.get(named) != group.get(side):
            raise _Refusal(f"nut={named!r} does not move with {side} (the nut side of {driven.name})")
        nut = named
    else:
        nut = _nut(model, side, driver)
    return -hand * sense * (-1.0 if rides else 1.0) * v["lead"] / (2 * math.pi), (driver.child, nut)


def rigid_groups(model: CompiledModel) -> dict[str, str]:
    """Part name -> the first part, in plan order, of its rigid group: parts joined by static
    mates (union-find), a colour block with its painted part. The links of
    :func:`procedura_brep.articulation.articulate`; mates naming unknown parts are skipped here
    (the articulation refuses them)."""
    order = {p.name: i for i, p in enumerate(model.parts)}
    root = {p.name: p.name for p in model.parts}

    def find(n: str) -> str:
        while root[n] != n:
            root[n] = root[root[n]]
            n = root[n]
        return n

    def join(x: str, y: str) -> None:
        a, b = find(x), find(y)
        if a != b:
            keep, drop = (a, b) if order[a] < order[b] else (b, a)
            root[drop] = keep

    for m in model.mates:
        if m.kind == "static" and m.child in root and m.parent in root:
            join(m.child, m.parent)
    for p in model.parts:
        if p.block_of and p.block_of in root:
            join(p.name, p.block_of)
    return {n: find(n) for n in root}


def _nut(model: CompiledModel, side: str, screw: CompiledMate) -> str:
    """The part that engages the screw on the nut's side: of the parts rigid with ``side``
    (the slide's moving or fixed part) whose box the screw axis passes through within the
    screw's own span, the one that comes nearest the axis there (exact distance: a nut's
    thread reaches inside the screw's crest, a carriage's clearance bore or a sleeve stays
    outside it), the smaller on a tie; ``side`` itself when no part qualifies."""
    from .. import kernel

    group = rigid_groups(model)
    origin = np.asarray(screw.world_frame, float)[:3, 3]
    axis = _axis(screw)
    try:
        s_lo, s_hi = (np.asarray(x, float) for x in kernel.bbox(model.part(screw.child).shape(),
                                                                  optimal=False))
    except KeyError:
        return side
    s_span = _line_span(s_lo, s_hi, origin, axis)
    if s_span is None:
        return side
    found: list[tuple[str, tuple[float, float], float]] = []
    for p in model.parts:
        if p.block_of or p.name == screw.child or group.get(p.name) != group.get(side):
            continue
        lo, hi = (np.asarray(x, float) for x in kernel.bbox(p.shape(), optimal=False))
        span = _line_span(lo, hi, origin, axis)
        if span is None or span[1] < s_span[0] or s_span[1] < span[0]:
            continue
        found.append((p.name, (max(span[0], s_span[0]), min(span[1], s_span[1])),
                      float(np.prod(np.maximum(hi - lo, 1e-9)))))
    if len(found) < 2:
        return found[0][0] if found else side

    def near(row: tuple[str, tuple[float, float], float]) -> tuple[float, float]:
        t0, t1 = row[1]
        gap = kernel.segment_distance(model.part(row[0]).shape(), origin + t0 * axis, origin + t1 * axis)
        return round(gap, 6), row[2]
    return min(found, key=near)[0]


def _line_span(lo: np.ndarray, hi: np.ndarray, origin: np.ndarray, d: np.ndarray
               ) -> tuple[float, float] | None:
    """The params (along unit ``d`` from ``origin``) where the line enters and leaves the box
    ``lo``-``hi`` (slab test, 1e-6 mm slack), or None when it misses it."""
    t0, t1 = -math.inf, math.inf
    for k in range(3):
        if abs(d[k]) < 1e-12:
            if origin[k] < lo[k] - 1e-6 or origin[k] > hi[k] + 1e-6:
                return None
            continue
        a, b = (lo[k] - origin[k]) / d[k], (hi[k] - origin[k]) / d[k]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
    return (t0, t1) if t0 <= t1 else None


def _linkage(d: CoupleDecl, driven: CompiledMate, driver: CompiledMate, v: dict[str, float],
             model: CompiledModel) -> tuple[float, tuple[str, str]]:
    cut_name = str(d.named["closes"])
    mates = {m.name: m for m in model.mates}
    cut = mates.get(cut_name)
    if cut is None:
        raise _Refusal(f"closes={cut_name!r} is not a mate of the program{did_you_mean(cut_name, mates)}")
    if cut.type not in CUT_TYPES:
        raise _Refusal(f"closes={cut_name!r}: a loop is cut at a {' or '.join(CUT_TYPES)} mate "
                       f"(a pin or a ball the exports can close as a point); {cut_name} is {cut.type}")
    if cut.primary:
        raise _Refusal(f"closes={cut_name!r}: that mate places {cut.child}, so it closes no loop; "
                       f"the cut is the mate whose child an earlier mate already placed")
    if cut_name in (driven.name, driver.name):
        raise _Refusal(f"closes={cut_name!r}: the cut joint cannot be the driver or the driven joint")
    return 0.0, (cut.child, cut.parent)


def cut_gap(parent_world: np.ndarray, fp: np.ndarray, child_world: np.ndarray, fc: np.ndarray
            ) -> float:
    """Distance (mm) between a cut joint's two anchors: the parent's frame origin and the
    child's, each placed in the world."""
    a = (parent_world @ fp)[:3, 3]
    b = (child_world @ fc)[:3, 3]
    return float(np.linalg.norm(a - b))


#: Mate types a loop may be cut at: a point constraint closes them.
CUT_TYPES = ("revolute", "spherical")
_RATIO = {"gear": _gear, "belt": _belt, "rack_pinion": _rack, "screw": _screw, "linkage": _linkage}


def si_ratio(c: CompiledCoupling, driven_type: str, driver_type: str) -> float:
    """The ratio in SI joint units (rad and m): mm/rad -> m/rad, rad/mm -> rad/m."""
    scale = (1e-3 if _slides(driven_type) else 1.0) / (1e-3 if _slides(driver_type) else 1.0)
    return c.ratio * scale


__all__ = ["CUT_TYPES", "MAX_COUPLINGS", "SPECS", "CouplingSpec", "CouplingType", "check_keywords",
           "cut_gap", "resolve", "si_ratio"]
