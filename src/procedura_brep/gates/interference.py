"""Interference gate: no two parts may share volume unless a declared fit allows it.

Every pair of parts is considered, mate partners or not. Pairs are prefiltered by their boxes
(grown by ``TOL.mesh_linear_mm``, since a mesh box can be that much smaller than the solid's,
and required to overlap by more than ``TOL.penetration_slack_mm`` on every axis, since a thinner
overlap cannot hold a thicker common); then the exact common (:func:`.common.common`, shared
with the mate gate and bounded by ``TOL.boolean_pair_budget``, on crops when over it) is split
into solids, and each solid is judged. **Contact is not interference**: parts that touch (a
common thinner than ``TOL.penetration_slack_mm``, including none at all) pass. A pair whose
common could not be computed within the bound is **not verified**: a ``not-verified`` warning
that says what stopped it, listed under ``measured["not_verified"]``, never a pass of that pair
and never a blocking error. Each solid is judged:

* it reaches into the feature region of a mate between the two parts
  (:func:`~procedura_brep.gates.mate_gate.region`) and its depth in that mate's frame is within
  ``delta_max(fit) = max(0, -offset) + penetration_slack_mm``: **allowed** (a press, snap or
  tight location fit's own interference);
* it reaches into the region of a *static* mate but is deeper: the mate gate reports it
  (``mate-penetration``); here it is listed as not allowed, with ``judged_by = "mate"``;
* it reaches into the region of a kinematic mate and is deeper than that fit allows, or it lies
  outside every partner region, or the parts are not partners at all: an ``interference``
  finding (depth, volume, both part names, the limit); outside any fit the limit is
  ``penetration_slack_mm`` (boolean noise).

Depth is the solid's thickness (:mod:`.common`): its minimum width, or the radial wall of a ring
about a mate axis. The battery's B3 rest scan reads :func:`scan` too, so both agree.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledMate, CompiledModel, Finding
from .common import Common, common
from .geometry import box_pairs, part_geometry
from .locate import describe
from .mate_gate import penetration_limit, region, unverified_finding
from .policy import GateResult, result


@dataclass
class PairOverlap:
    """The judged overlap of two parts (``a`` before ``b`` in plan order).

    Attributes:
        depth: the worst solid's depth, mm (the worst not-allowed one when any is not allowed;
            0 when not verified).
        volume: total common volume, mm^3 (None when not verified).
        limit: the depth allowed for that solid, mm.
        allowed: every solid is allowed.
        judged_by: ``"fit"`` (allowed by a mate's fit), ``"mate"`` (a static mate's own
            penetration, reported by the mate gate), ``"interference"`` (this gate's finding).
        mate: the mate whose region the worst solid reaches, if any.
        exact: the common was computed (False: the pair is not verified, see ``reason``).
        reason: why the pair is not verified.
        lo, hi: the worst solid's box, world mm.
        point: a point inside the worst solid (its node nearest the box centre), world mm.
    """

    a: str
    b: str
    depth: float
    volume: float | None
    limit: float
    allowed: bool
    judged_by: str
    mate: str | None = None
    exact: bool = True
    reason: str = ""
    lo: list[float] = field(default_factory=list)
    hi: list[float] = field(default_factory=list)
    point: list[float] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        out = {"a": self.a, "b": self.b, "depth_mm": round(self.depth, 6),
               "volume_mm3": None if self.volume is None else round(self.volume, 6),
               "limit_mm": round(self.limit, 6), "allowed": self.allowed,
               "judged_by": self.judged_by, "mate": self.mate, "exact": self.exact,
               "bbox": [self.lo, self.hi], "point": self.point}
        if not self.exact:
            out["reason"] = self.reason
        return out


def candidate_pairs(model: CompiledModel) -> list[tuple[int, int]]:
    """Part index pairs whose (padded) boxes overlap by more than the slack on every axis."""
    if len(model.parts) < 2:
        return []
    geos = [part_geometry(p) for p in model.parts]
    shrink = TOL.penetration_slack_mm / 2.0 - TOL.mesh_linear_mm
    lo = np.array([g.lo for g in geos]) + shrink
    hi = np.array([g.hi for g in geos]) - shrink
    return [tuple(p) for p in box_pairs(lo, hi, 0.0).tolist()]


def _judge(a: str, b: str, com: Common, mates: list[CompiledMate],
           frames: list[np.ndarray]) -> PairOverlap | None:
    slack = TOL.penetration_slack_mm
    if not com.exact:
        return PairOverlap(a, b, 0.0, None, slack, True, "unverified",
                           mates[0].name if mates else None, False, com.reason)
    rows = []
    for s in com.solids:
        verdict = None
        for m in mates:
            rad, half = region(m)
            if not s.touches(m.world_frame, rad, half):
                continue
            d, lim = s.depth(m.world_frame), penetration_limit(m.fit or {})
            if d <= lim:
                verdict = (d, lim, True, "fit", m.name)
                break
            verdict = verdict or (d, lim, False, "mate" if m.kind == "static" else "interference",
                                  m.name)
        if verdict is None:
            d = s.free_depth(frames)
            if d <= slack:
                continue
            verdict = (d, slack, False, "interference", None)
        rows.append((verdict, s))
    if not rows:
        return None
    bad = [r for r in rows if not r[0][2]]
    (d, lim, _, how, mname), s = max(bad or rows, key=lambda r: r[0][0])
    # a pair is an interference finding when any solid is; otherwise the mate gate's or allowed
    if any(r[0][3] == "interference" for r in bad):
        (d, lim, _, how, mname), s = max((r for r in bad if r[0][3] == "interference"),
                                         key=lambda r: r[0][0])
    return PairOverlap(a, b, d, com.volume, lim, not bad, how, mname, True, "",
                       np.round(s.lo, 4).tolist(), np.round(s.hi, 4).tolist(),
                       np.round(s.inner_point(), 4).tolist())


def scan(model: CompiledModel) -> list[PairOverlap]:
    """Every overlapping pair of parts with its verdict (allowed ones included), plan order."""
    out = []
    by_pair: dict[frozenset[str], list[CompiledMate]] = {}  # the mates of each pair of partners
    by_part: dict[str, list[int]] = {}  # each part's mates, by their place in model.mates
    for k, m in enumerate(model.mates):
        by_pair.setdefault(frozenset((m.child, m.parent)), []).append(m)
        for name in dict.fromkeys((m.child, m.parent)):
            by_part.setdefault(name, []).append(k)
    for i, j in candidate_pairs(model):
        pa, pb = model.parts[i], model.parts[j]
        if pa.owner == pb.owner:
            continue  # a colour block and its painted part (or two of its blocks) share cut faces
        ga, gb = part_geometry(pa), part_geometry(pb)
        com = common(ga, pa.shape(), gb, pb.shape())
        mates = by_pair.get(frozenset((pa.name, pb.name)), [])
        frames = [model.mates[k].world_frame
                  for k in sorted({*by_part.get(pa.name, ()), *by_part.get(pb.name, ())})]
        row = _judge(pa.name, pb.name, com, mates, frames)
        if row is not None:
            out.append(row)
    return out


def _fmt(v: list[float]) -> str:
    return ", ".join(f"{x:.1f}" for x in v)


def interference_findings(model: CompiledModel, rows: list[PairOverlap]) -> list[Finding]:
    """``interference`` errors for the rows this gate judges, ``not-verified`` warnings for the
    pairs it could not decide (a static mate's pair is the mate gate's to report)."""
    out = []
    lines = {p.name: (p.lines[0] or None) for p in model.parts}
    static = {frozenset((m.child, m.parent)) for m in model.mates if m.kind == "static"}
    for r in rows:
        if not r.exact and frozenset((r.a, r.b)) not in static:
            out.append(unverified_finding(r.b, r.a, r.reason, line=lines.get(r.b)))
        if r.allowed or r.judged_by != "interference":
            continue
        if r.mate is None:
            why = ("outside every feature region of their mates" if any(
                {m.child, m.parent} == {r.a, r.b} for m in model.mates) else
                "they are not mate partners, so no fit allows it")
        else:
            why = f"beyond what the fit of mate {r.mate} allows"
        vol = "" if r.volume is None else f", volume {r.volume:.3g} mm^3"
        box = f" at ({_fmt(r.point)}) mm, bbox ({_fmt(r.lo)})..({_fmt(r.hi)}) mm"
        where = "; ".join(describe(model.part(n), np.asarray(r.point)) for n in (r.b, r.a)) \
            if r.point else ""
        out.append(Finding(
            "interference",
            f"{r.b} and {r.a} interpenetrate: depth {r.depth:.3g} mm{vol}{box} > {r.limit:.3g} mm "
            f"allowed ({why}); there: {where}; move {r.b} out of {r.a} or shrink one of them",
            part=r.b, mate=r.mate, line=lines.get(r.b), value=r.depth, limit=r.limit, other=r.a))
    return out


def interference_gate(model: CompiledModel) -> tuple[list[Finding], GateResult]:
    """Run the interference gate; ``measured`` has ``pairs`` (every overlapping pair, judged),
    ``max_depth_mm`` (worst pair this gate reports, 0 when none) and ``not_verified`` (the
    pairs whose exact common was not computed, with the reason)."""
    rows = scan(model)
    findings = interference_findings(model, rows)
    worst = max((r.depth for r in rows if not r.allowed and r.judged_by == "interference"),
                default=0.0)
    return findings, result("interference", findings, {
        "pairs": [r.as_dict() for r in rows if r.exact], "max_depth_mm": round(worst, 6),
        "limit_mm": TOL.penetration_slack_mm,
        "not_verified": [{"a": r.a, "b": r.b, "reason": r.reason} for r in rows if not r.exact]})
