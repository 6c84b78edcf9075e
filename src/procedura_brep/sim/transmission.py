"""Battery B8 "transmission": every coupling's driven joint follows its driver in MuJoCo.

For each chain head (an actuated joint that drives couplings, directly or down a gear train),
one simulation of the exported scene (``model.xml``: the equalities as written there) ramps
the head's servo from 0 to the low end of its range and on to the high end, where the range is
the head's own limits narrowed to what keeps every joint of its chain inside its limits
(:data:`RANGE_FRACTION` of it; a continuous head without limits: +-:data:`FREE_TURN` rad); a
speed-driven head (a continuous joint) is run at half its velocity limit at most, the same
span either side of 0.
Gravity and contacts are off: the check measures the transmission, not loads or collisions
(B1, B2 and B3 judge those).

Per coupling: the measured ratio is the least-squares slope of the driven joint's positions
against the driver's over the run; it passes when it is within ``TOL.coupling_ratio_rel`` of
the declared ratio (:class:`~procedura_brep.articulation.tree.Coupling`, from the program's
params), with the same sign, the driver moved at least :data:`MIN_TRAVEL` of what was
commanded, and MuJoCo raised no warning.

A linkage: its driver is ramped over :data:`RANGE_FRACTION` of its own limits (+-:data:`FREE_TURN`
without), and the cut joint's two anchors (the connect's point on each body) stay within
``TOL.coupling_cut_mm`` of each other; the driver must travel :data:`MIN_TRAVEL` of the command
(a loop that locks stops it), and the driven joint must move.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ..articulation.tree import Articulation, Coupling, Joint
from ..config import TOL
from .dynamics import warnings_of
from .report import CheckResult

if TYPE_CHECKING:
    from mujoco import MjModel

#: Fraction of the chain's common range the head is driven over (clear of the joint limits).
RANGE_FRACTION = 0.9
#: Half-range, rad, of a continuous head whose chain sets no limit.
FREE_TURN = math.pi
#: Seconds of each leg of the ramp (0 -> low end; low -> high end takes twice this).
LEG_S = 1.0
#: The driver must travel at least this fraction of the commanded span.
MIN_TRAVEL = 0.5
#: Every this many steps a state is kept for the failure frames.
FRAME_EVERY = 50


def _heads(art: Articulation) -> dict[str, list[Coupling]]:
    """Chain head -> the couplings below it, in the articulation's order."""
    out: dict[str, list[Coupling]] = {}
    for c in art.couplings:
        if c.type == "linkage":
            continue
        out.setdefault(art.root_driver(c.driver)[0], []).append(c)
    return out


def head_range(art: Articulation, head: str, couplings: list[Coupling]) -> tuple[float, float]:
    """The head's travel (SI, from the compiled pose) that keeps every joint of its chain
    within its limits, shrunk to :data:`RANGE_FRACTION`."""
    h = art.joint(head)
    lo, hi = (h.lower, h.upper) if h.lower is not None and h.upper is not None else (-math.inf, math.inf)
    for name in {n for c in couplings for n in (c.driven, c.driver)} - {head}:
        j = art.joint(name)
        _, ratio, offset = art.root_driver(name)
        if j.lower is None or j.upper is None or ratio == 0:
            continue
        a, b = (j.lower - offset) / ratio, (j.upper - offset) / ratio
        lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
    if not math.isfinite(lo):
        lo = -FREE_TURN
    if not math.isfinite(hi):
        hi = FREE_TURN
    if hi <= lo:
        return 0.0, 0.0
    return _central(lo, hi)


def _central(lo: float, hi: float) -> tuple[float, float]:
    """The middle :data:`RANGE_FRACTION` of ``lo..hi`` (clear of the limits' stops)."""
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * RANGE_FRACTION
    return mid - half, mid + half


def _drive(m: MjModel, head: Joint, lo: float, hi: float, names: list[str],
           each: Callable[[Any], None] | None = None
           ) -> tuple[dict[str, np.ndarray], dict[str, int], list[np.ndarray]]:
    """Ramp ``head`` 0 -> lo -> hi; the positions of ``names`` at every step, the warnings,
    and states for frames; ``each(d)`` after every step (a loop's cut gap)."""
    import mujoco
    act = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, head.name)
    if act < 0:
        raise KeyError(f"joint {head.name!r} has no actuator in model.xml")
    qadr = {n: int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n)]) for n in names}
    d = mujoco.MjData(m)
    dt = float(m.opt.timestep)
    rows: dict[str, list[float]] = {n: [] for n in names}
    traj: list[np.ndarray] = []
    velocity = head.drive == "velocity"
    k = 0
    for start, end, dur in ((0.0, lo, LEG_S), (lo, hi, 2 * LEG_S)):
        n = max(1, int(dur / dt))
        for s in range(n):
            d.ctrl[act] = (end - start) / dur if velocity else start + (end - start) * (s + 1) / n
            mujoco.mj_step(m, d)
            if each is not None:
                each(d)
            for name, adr in qadr.items():
                rows[name].append(float(d.qpos[adr]))
            if k % FRAME_EVERY == 0:
                traj.append(d.qpos.copy())
            k += 1
    return {n: np.asarray(v) for n, v in rows.items()}, warnings_of(d), traj


def _cut_gaps(m: MjModel, cut: str) -> tuple[Any, Any]:
    """``gap(d) -> m``: the distance between the connect's anchor on each of its bodies (the
    body2 anchor taken at qpos0, where the loop meets)."""
    import mujoco
    eid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, cut)
    if eid < 0:
        raise KeyError(f"model.xml has no equality {cut!r} closing the loop")
    b1, b2 = int(m.eq_obj1id[eid]), int(m.eq_obj2id[eid])
    a1 = np.array(m.eq_data[eid, :3], dtype=float)
    d0 = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d0)
    p = d0.xpos[b1] + d0.xmat[b1].reshape(3, 3) @ a1
    a2 = d0.xmat[b2].reshape(3, 3).T @ (p - d0.xpos[b2])

    def gap(d: Any) -> float:
        w1 = d.xpos[b1] + d.xmat[b1].reshape(3, 3) @ a1
        w2 = d.xpos[b2] + d.xmat[b2].reshape(3, 3) @ a2
        return float(np.linalg.norm(w1 - w2))
    return gap, eid


def _linkage(m: MjModel, art: Articulation, name: str, couplings: list[Coupling]
             ) -> tuple[dict[str, Any], list[str], list[np.ndarray]]:
    """One linkage's row, its problems and its states for frames."""
    src = couplings[0].source
    head = art.joint(src.driver)
    lo, hi = (head.lower, head.upper) if head.lower is not None and head.upper is not None \
        else (-FREE_TURN, FREE_TURN)
    lo, hi = _central(lo, hi)
    if head.drive == "velocity":
        a = min(-lo, hi, 0.5 * head.velocity * LEG_S)
        lo, hi = -a, a
    gap, _ = _cut_gaps(m, src.closes)
    worst_gap = 0.0

    def track(d: Any) -> None:
        nonlocal worst_gap
        worst_gap = max(worst_gap, gap(d))
    q, warns, traj = _drive(m, head, lo, hi, sorted({src.driver, src.driven}), each=track)
    x, y = np.asarray(q[src.driver]), np.asarray(q[src.driven])
    travel, commanded = float(x.max() - x.min()), hi - lo
    driven_travel = float(y.max() - y.min())
    dj = art.joint(src.driven)
    row = {"type": "linkage", "driver": src.driver, "driven": src.driven, "cut": src.closes,
           "max_cut_gap_mm": worst_gap * 1000.0, "driver_travel": travel,
           "commanded_travel": commanded, "driven_travel": driven_travel,
           "driver_travel_label": head.kind.label(travel),
           "driven_travel_label": dj.kind.label(driven_travel), "warnings": warns}
    bad = []
    if travel < MIN_TRAVEL * commanded:
        bad.append(f"its driver {src.driver!r} moved {head.kind.label(travel)} of "
                   f"{head.kind.label(commanded)} commanded (does the loop lock?)")
    if worst_gap * 1000.0 > TOL.coupling_cut_mm:
        bad.append(f"the cut joint {src.closes!r} opened by {worst_gap * 1000.0:.3g} mm "
                   f"(limit {TOL.coupling_cut_mm:g} mm)")
    if driven_travel <= 0.0:
        bad.append(f"the driven joint {src.driven!r} did not move")
    if warns:
        bad.append(f"MuJoCo warnings {warns}")
    return row, [f"linkage {name}: " + "; ".join(bad)] if bad else [], traj


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    dx = x - x.mean()
    den = float(dx @ dx)
    return float(dx @ (y - y.mean()) / den) if den > 0 else 0.0


def check_b8(m: MjModel, art: Articulation) -> tuple[CheckResult, list[np.ndarray]]:
    """B8: each coupling's measured ratio in MuJoCo (see the module docstring)."""
    import mujoco
    if not art.couplings:
        return CheckResult("B8", "transmission", True, message="no couplings: skipped",
                           skipped=True), []
    gravity, flags = m.opt.gravity.copy(), int(m.opt.disableflags)
    m.opt.gravity[:] = 0.0
    m.opt.disableflags = flags | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    rows: dict[str, Any] = {}
    problems: list[str] = []
    worst_traj: list[np.ndarray] = []
    worst = 0.0
    try:
        for head, couplings in _heads(art).items():
            lo, hi = head_range(art, head, couplings)
            h = art.joint(head)
            if h.drive == "velocity":  # a speed servo: symmetric legs at half its speed limit
                a = min(-lo, hi, 0.5 * h.velocity * LEG_S)
                lo, hi = -a, a
            names = sorted({n for c in couplings for n in (c.driven, c.driver)})
            if hi - lo <= 0:
                problems.append(f"joint {head!r} cannot move without taking a coupled joint past "
                                f"its limits (the limits and ratios of {', '.join(names)} disagree)")
                continue
            q, warns, traj = _drive(m, art.joint(head), lo, hi, names)
            for c in couplings:
                x, y = q[c.driver], q[c.driven]
                _, to_head, _ = art.root_driver(c.driver)
                commanded = abs(to_head) * (hi - lo)
                travel = float(x.max() - x.min())
                measured = _slope(x, y)
                err = abs(measured - c.ratio) / abs(c.ratio) if c.ratio else math.inf
                residual = float(np.abs(y - (c.offset + c.ratio * x)).max())
                dj, rj = art.joint(c.driven), art.joint(c.driver)
                rows[c.name] = {"type": c.type, "driver": c.driver, "driven": c.driven,
                                "declared": c.ratio, "measured": measured, "rel_err": err,
                                "driver_travel": travel, "commanded_travel": commanded,
                                "max_residual": residual,
                                "max_residual_label": dj.kind.label(residual),
                                "driver_travel_label": rj.kind.label(travel),
                                "warnings": warns}
                worst = max(worst, err)
                bad = []
                if travel < MIN_TRAVEL * commanded:
                    bad.append(f"its driver {c.driver!r} moved {rj.kind.label(travel)} of "
                               f"{rj.kind.label(commanded)} commanded")
                elif math.copysign(1.0, measured) != math.copysign(1.0, c.ratio):
                    bad.append(f"turns the wrong way: measured ratio {measured:.5g}, declared "
                               f"{c.ratio:.5g}")
                elif err > TOL.coupling_ratio_rel:
                    bad.append(f"measured ratio {measured:.5g} is {100 * err:.2f}% off the "
                               f"declared {c.ratio:.5g} (limit {100 * TOL.coupling_ratio_rel:g}%)")
                if warns:
                    bad.append(f"MuJoCo warnings {warns}")
                if bad:
                    problems.append(f"coupling {c.name} ({c.type}): " + "; ".join(bad))
                    worst_traj = worst_traj or traj
        linkages: dict[str, list[Coupling]] = {}
        for c in art.couplings:
            if c.type == "linkage":
                linkages.setdefault(c.source.name, []).append(c)
        for name, group in linkages.items():
            row, bad, traj = _linkage(m, art, name, group)
            rows[name] = row
            problems.extend(bad)
            if bad:
                worst_traj = worst_traj or traj
    finally:
        m.opt.gravity[:] = gravity
        m.opt.disableflags = flags
    gaps = [r["max_cut_gap_mm"] for r in rows.values() if r["type"] == "linkage"]
    measured_all = {"max_ratio_rel_err": worst, "max_cut_gap_mm": max(gaps, default=0.0),
                    "couplings": rows}
    n_ratio = len(rows) - len(gaps)
    parts = ([f"{n_ratio} couplings follow their drivers within {100 * worst:.3g}% of the declared "
              f"ratios"] if n_ratio else []) + \
        ([f"{len(gaps)} loops stay closed within {max(gaps):.3g} mm"] if gaps else [])
    message = "; ".join(problems) or "; ".join(parts)
    return CheckResult("B8", "transmission", not problems, measured_all,
                       {"max_ratio_rel_err": TOL.coupling_ratio_rel,
                        "max_cut_gap_mm": TOL.coupling_cut_mm}, message), worst_traj


__all__ = ["check_b8", "head_range"]
