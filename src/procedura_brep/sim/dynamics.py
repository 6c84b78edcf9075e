"""Dynamic checks in MuJoCo: B1 settle and hold, B2 joint sweeps, B4 wheeled mobility, B7 smoke run.

Each function takes a compiled ``MjModel`` and returns a :class:`CheckResult` plus the qpos
trajectory of the phase it judged (for frames when it fails).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..articulation.tree import Articulation, JointDof
from ..config import TOL
from ..export.mjcf import SERVO_OMEGA
from ..mates.kinds import JointKind
from .report import CheckResult

if TYPE_CHECKING:
    from mujoco import MjData, MjModel

#: B1: simulated settle time, s.
SETTLE_S = 2.0
#: B1: max root linear speed at the end of the settle (m/s), free roots only.
SETTLE_ROOT_SPEED = 0.05
#: B1: the drift of a held joint is its largest over the last this many seconds of the settle
#: (once the hold's setpoint has settled, :data:`HOLD_KI`), so a saturated joint that swings
#: about a sagged pose is judged by its swing, not by where the swing was at 2 s.
HOLD_WINDOW_S = 1.0
#: B1: integral gain of the hold, 1/s. Each position servo's setpoint is moved by this rate times
#: its error (home minus where it is), as a real servo controller's integral term does: the
#: exported servos are proportional (8 Hz), so without it a servo that is far from its effort
#: still droops by load / stiffness (the recorded robot arm's wrist drooped 4.3 deg under 0.09 N m
#: with 10 N m of effort). With it, a servo that is not saturated ends at home to within
#: micro-degrees and the drift that is left is what the effort cannot hold. A fifth of the
#: servo's natural frequency: the setpoint settles in ~0.1 s, well apart from the servo itself.
HOLD_KI = SERVO_OMEGA / 5.0
#: B1/B2: an actuator whose force is within this fraction of its force limit is saturated.
SATURATION = 0.99
#: B1: the effort a failure suggests is this times the gravity load at home (rounded up).
EFFORT_MARGIN = 1.2
#: B2: ramp and hold durations, s.
SWEEP_RAMP_S, SWEEP_HOLD_S = 1.5, 0.5
#: B2: continuous joints are spun at this fraction of their velocity limit (capped at 2 pi).
SPIN_FRACTION = 0.5
#: B2: the spin lasts this long, s.
SPIN_S = 1.0
#: B2: a joint moving faster than this (rad/s or m/s) at the end of a hold is still on its way.
MOVING_SPEED = 1e-3
#: B2: the most contact pairs a reason names.
MAX_PAIRS = 3
#: B4: drive time, s (the minimum travel ratio is ``TOL.drive_min_ratio``).
DRIVE_S = 3.0
#: B7: smoke-run length and control period, s; RNG seed.
SMOKE_S, SMOKE_PERIOD_S, SMOKE_SEED = 2.0, 0.1, 0

_PIECE = re.compile(r"^(.+)__c\d+$")


def warnings_of(d) -> dict[str, int]:
    """Non-zero MuJoCo warning counters by name."""
    import mujoco
    out = {}
    for name, w in mujoco.mjtWarning.__members__.items():
        if name == "mjNWARNING":
            continue
        n = int(d.warning[int(w)].number)
        if n:
            out[name] = n
    return out


def exported_names(art: Articulation) -> list[str]:
    """The MuJoCo joint names: a spherical joint's own, every other joint's 1-DOF joints
    (a cylindrical joint's ``__slide`` and ``__turn``)."""
    return [n for j in art.joints for n in ([j.name] if j.kind.ball
                                             else [d.name for d in j.dofs()])]


def _dof(art: Articulation, name: str) -> JointDof:
    for j in art.joints:
        for d in j.dofs():
            if d.name == name:
                return d
    raise KeyError(f"no 1-DOF joint named {name!r}")


def _ids(m, art: Articulation):
    import mujoco
    names = exported_names(art)
    jid = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in names}
    aid = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in names}
    return jid, aid


def _free_dof(m) -> int | None:
    import mujoco
    for i in range(m.njnt):
        if m.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE:
            return int(m.jnt_dofadr[i])
    return None


def _free_qpos(m) -> int | None:
    """qpos address of the free joint (its position is qpos[adr:adr + 3]), or None."""
    import mujoco
    for i in range(m.njnt):
        if m.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE:
            return int(m.jnt_qposadr[i])
    return None


@dataclass(frozen=True)
class Held:
    """One DOF that B1 holds at its home with a position servo (a spherical joint's three).

    Attributes:
        name: the exported MuJoCo joint (a 1-DOF joint's, or the spherical joint's own).
        kind: its joint kind (the DOF's; a cylindrical joint's slide or turn).
        child: the articulation link it moves (its subtree moves with it).
        jid: the MuJoCo joint id.
        actuators: its actuator ids (three for a ball).
        effort: the actuators' force limit (N m or N), the mate's ``effort``.
    """

    name: str
    kind: JointKind
    child: str
    jid: int
    actuators: tuple[int, ...]
    effort: float

    @property
    def unit(self) -> str:
        """The unit of its load and effort: ``N`` (a slide) or ``N m``."""
        return "N" if self.kind.slides else "N m"


def held_dofs(m: MjModel, art: Articulation) -> list[Held]:
    """The position-held DOFs of ``art`` in the MuJoCo model ``m``: every position-driven 1-DOF
    joint (a cylindrical joint's slide and a limited turn included) and every spherical joint
    (its three hold servos, as :mod:`procedura_brep.export.mjcf` writes them). Velocity-driven
    joints (wheels, spinning joints) hold a speed, not a pose, and are left out."""
    import mujoco
    out: list[Held] = []
    for j in art.joints:
        if j.kind.ball:
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            acts = tuple(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"{j.name}__{ax}")
                         for ax in "xyz")
            if jid >= 0 and all(a >= 0 for a in acts):
                out.append(Held(j.name, j.kind, j.child, jid, acts, float(j.effort)))
            continue
        for dof in j.dofs():
            if dof.drive != "position":
                continue
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, dof.name)
            act = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, dof.name)
            if jid >= 0 and act >= 0:
                out.append(Held(dof.name, dof.kind, j.child, jid, (act,), float(dof.effort)))
    return out


def subtree_bodies(m: MjModel, body: int) -> set[int]:
    """``body`` and every MuJoCo body below it."""
    out = {int(body)}
    for b in range(int(body) + 1, m.nbody):  # a body's id is greater than its parent's
        if int(m.body_parentid[b]) in out:
            out.add(b)
    return out


def _subtree_geoms(m: MjModel, bodies: set[int]) -> np.ndarray:
    """The ids of the geoms on ``bodies``."""
    return np.array([g for g in range(m.ngeom) if int(m.geom_bodyid[g]) in bodies], dtype=int)


def _box_corners(m: MjModel, d: MjData, geoms: np.ndarray) -> np.ndarray:
    """World corners (n*8, 3), m, of the geoms' boxes (``geom_aabb``, in each geom's frame)."""
    if not len(geoms):
        return np.zeros((0, 3))
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    aabb = m.geom_aabb[geoms]
    local = aabb[:, None, :3] + signs[None, :, :] * aabb[:, None, 3:]  # (n, 8, 3)
    rot = d.geom_xmat[geoms].reshape(-1, 3, 3)
    world = np.einsum("nij,nkj->nki", rot, local) + d.geom_xpos[geoms][:, None, :]
    return world.reshape(-1, 3)


def _drift(m: MjModel, qpos: np.ndarray, h: Held) -> float:
    """How far ``h`` is from home (qpos 0 / the identity quaternion): rad, or m for a slide.
    A ball's is its rotation angle from home (a tilt, a twist or both)."""
    adr = int(m.jnt_qposadr[h.jid])
    if h.kind.ball:
        w = min(1.0, abs(float(qpos[adr])) / max(float(np.linalg.norm(qpos[adr:adr + 4])), 1e-12))
        return 2.0 * math.acos(w)
    return float(qpos[adr])


def _tip_mm(m: MjModel, settled: np.ndarray, h: Held, home_corners: np.ndarray,
            geoms: np.ndarray) -> float:
    """The most any box corner of ``h``'s child subtree moves, mm, when ``h`` alone goes from
    home to its settled value (every other joint at home, so a drift downstream is not counted
    against it)."""
    import mujoco
    if not len(geoms):
        return 0.0
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    adr, n = int(m.jnt_qposadr[h.jid]), (4 if h.kind.ball else 1)
    d.qpos[adr:adr + n] = settled[adr:adr + n]
    mujoco.mj_kinematics(m, d)
    return float(np.linalg.norm(_box_corners(m, d, geoms) - home_corners, axis=1).max()) * 1000.0


def _round_up(x: float) -> float:
    """``x`` rounded up to two significant figures (a suggested effort)."""
    if x <= 0:
        return 0.0
    scale = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / scale - 1e-9) * scale


def _hold_problem(h: Held, row: dict[str, Any], with_gravity: bool) -> str:
    """The B1 failure message of one DOF that did not hold its home (``with_gravity``: it moved
    the way gravity pulls it, so it sags)."""
    ball, slides = h.kind.ball, h.kind.slides
    drift = row["drift_mm"] if slides else row["drift_deg"]
    unit = "mm" if slides else "deg"
    load = row["gravity_force_N"] if slides else row["gravity_torque_Nm"]
    what = "force" if slides else "torque"
    verb = "sags" if with_gravity else "drifts"
    force = row["actuator_force_N"] if slides else row["actuator_torque_Nm"]
    # a ball's three servos each hold one component of its load
    axis = (f" ({row['servo_load_Nm']:.3g} N m of it on one servo axis)"
            if ball and row["servo_load_Nm"] < 0.99 * load else "")
    msg = (f"joint {h.name!r} {verb} {drift:.3g} {unit} from home (its far end moves "
           f"{row['tip_mm']:.3g} mm) under {load:.3g} {h.unit} of gravity {what}{axis}; "
           f"its effort is {h.effort:.3g} {h.unit}")
    if row["saturated"]:
        need = _round_up(EFFORT_MARGIN * (row["servo_load_Nm"] if ball else load))
        return (msg + f": raise effort to at least ~{need:.3g} {h.unit} or lighten link "
                      f"{h.child!r} and what it carries")
    return (msg + f": its servo is not saturated ({abs(force):.3g} of {h.effort:.3g} {h.unit}), "
                  f"so a contact or a joint limit holds it off home")


def check_b1(m: MjModel, art: Articulation) -> tuple[CheckResult, list[np.ndarray]]:
    """B1: hold every servo at the compiled pose for :data:`SETTLE_S` with gravity; nothing
    keeps moving, and every position-held joint stays at its home.

    Position servos hold home with an integral term (:data:`HOLD_KI`), so a servo whose effort
    suffices ends at home and a joint that sags is one whose effort cannot carry its load. Each
    held DOF (:func:`held_dofs`) is judged on its drift from home (``TOL.hold_drift_deg``, or
    ``TOL.hold_drift_mm`` for a slide; a ball: its rotation angle from home) and on how far that
    drift alone moves the far end of its child subtree (``TOL.hold_tip_mm``: the largest
    displacement of any corner of a subtree geom's box, with every other joint at home). A failure
    names the joint, the drift, the gravity torque or force it holds at home (``qfrc_bias`` at
    the compiled pose, zero velocity) and its effort.
    """
    import mujoco
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    gravity = d.qfrc_bias.copy()  # zero velocity: the generalised gravity force at home
    held = held_dofs(m, art)
    geoms = {h.name: _subtree_geoms(m, subtree_bodies(m, int(m.jnt_bodyid[h.jid]))) for h in held}
    home_corners = {h.name: _box_corners(m, d, g) for h, g in zip(held, geoms.values())}
    acts = np.array([a for h in held for a in h.actuators], dtype=int)
    # the setpoint may leave the joint's range (a home at the end of the range, loaded into it,
    # needs a setpoint past that end), by at most the range's width; the force stays limited
    width = m.actuator_ctrlrange[acts, 1] - m.actuator_ctrlrange[acts, 0]
    lo, hi = m.actuator_ctrlrange[acts, 0] - width, m.actuator_ctrlrange[acts, 1] + width
    setpoint = np.zeros(len(acts))  # home is actuator length 0 (joint 0, identity quaternion)
    traj = []
    dt = float(m.opt.timestep)
    steps = int(SETTLE_S / dt)
    # each held DOF's largest drift over the judged window, and the pose it had then
    peak = {h.name: (0.0, m.qpos0.copy()) for h in held}
    saturated = {h.name: False for h in held}  # at its force limit at some step of the window
    limited = m.actuator_ctrllimited[acts].copy()
    m.actuator_ctrllimited[acts] = 0  # MuJoCo would clamp ctrl to the range
    try:
        for k in range(steps):
            if len(acts):
                setpoint = np.clip(setpoint - dt * HOLD_KI * d.actuator_length[acts], lo, hi)
                d.ctrl[acts] = setpoint
            mujoco.mj_step(m, d)
            if k % 50 == 0:
                traj.append(d.qpos.copy())
            if (k + 1) * dt > SETTLE_S - HOLD_WINDOW_S:
                for h in held:
                    q = _drift(m, d.qpos, h)
                    if abs(q) > abs(peak[h.name][0]):
                        peak[h.name] = (q, d.qpos.copy())
                    saturated[h.name] |= bool(np.any(np.abs(d.actuator_force[list(h.actuators)])
                                                     >= SATURATION * h.effort))
    finally:
        m.actuator_ctrllimited[acts] = limited
    free = _free_dof(m)
    jid, _ = _ids(m, art)
    balls = {j.name for j in art.joints if j.kind.ball}
    speeds = {n: float(np.abs(d.qvel[m.jnt_dofadr[i]:m.jnt_dofadr[i] + (3 if n in balls else 1)]).max())
              for n, i in jid.items() if i >= 0}
    worst = max(speeds, key=speeds.get) if speeds else None
    jspeed = speeds.get(worst, 0.0) if worst else 0.0
    rspeed = float(np.linalg.norm(d.qvel[free:free + 3])) if free is not None else 0.0
    warns = warnings_of(d)
    finite = bool(np.all(np.isfinite(d.qpos)))
    rows: dict[str, dict[str, Any]] = {}
    holds: list[str] = []
    worst_deg = worst_mm = worst_tip = 0.0
    for h in held if finite else ():  # a state that blew up is reported as such, not per joint
        dof = int(m.jnt_dofadr[h.jid])
        n = 3 if h.kind.ball else 1
        load_vec = gravity[dof:dof + n]
        force = d.actuator_force[list(h.actuators)]
        drift, pose = peak[h.name]
        tip = _tip_mm(m, pose, h, home_corners[h.name], geoms[h.name])
        if h.kind.ball:
            load, servo_load = float(np.linalg.norm(load_vec)), float(np.abs(load_vec).max())
        else:
            load = servo_load = float(abs(load_vec[0]))
        # qfrc_bias > 0: gravity pulls the joint towards negative values
        with_gravity = bool(load > 0 and (h.kind.ball or drift * float(load_vec[0]) < 0))
        if h.kind.slides:
            row = {"drift_mm": abs(drift) * 1000.0, "gravity_force_N": load, "effort_N": h.effort,
                   "actuator_force_N": float(force[0])}
            worst_mm = max(worst_mm, row["drift_mm"])
            bad = row["drift_mm"] > TOL.hold_drift_mm
        else:
            row = {"drift_deg": math.degrees(abs(drift)), "gravity_torque_Nm": load,
                   "effort_Nm": h.effort,
                   "actuator_torque_Nm": float(np.abs(force).max() if h.kind.ball else force[0])}
            if h.kind.ball:
                row["servo_load_Nm"] = servo_load
            worst_deg = max(worst_deg, row["drift_deg"])
            bad = row["drift_deg"] > TOL.hold_drift_deg
        row.update(tip_mm=tip, saturated=saturated[h.name])
        worst_tip = max(worst_tip, tip)
        rows[h.name] = row
        if bad or tip > TOL.hold_tip_mm:
            holds.append(_hold_problem(h, row, with_gravity))
    problems = []
    if not finite:
        problems.append("state became NaN/inf")
    if jspeed > TOL.settle_joint_speed:
        problems.append(f"joint {worst!r} still moving at {jspeed:.3g} after {SETTLE_S} s")
    if rspeed > SETTLE_ROOT_SPEED:
        problems.append(f"root link {art.root.name!r} still moving at {rspeed:.3g} m/s")
    if warns:
        problems.append(f"MuJoCo warnings {warns}")
    problems.extend(holds)
    measured = {"max_joint_speed": jspeed, "root_speed_mps": rspeed, "warnings": sum(warns.values()),
                "max_drift_deg": worst_deg, "max_drift_mm": worst_mm, "max_tip_mm": worst_tip,
                "joints": rows}
    limits = {"max_joint_speed": TOL.settle_joint_speed, "root_speed_mps": SETTLE_ROOT_SPEED,
              "warnings": 0, "max_drift_deg": TOL.hold_drift_deg, "max_drift_mm": TOL.hold_drift_mm,
              "max_tip_mm": TOL.hold_tip_mm}
    ok = (f"settled within {SETTLE_S} s; {len(held)} held joints within {TOL.hold_drift_deg} deg / "
          f"{TOL.hold_drift_mm} mm of home (far ends within {TOL.hold_tip_mm} mm)")
    return CheckResult("B1", "dynamic settle", not problems, measured, limits,
                       "; ".join(problems) or ok), traj


def _separation(m, d, jid: int) -> float:
    """Distance between a joint's anchor seen from the child and from its parent body."""
    return _Anchor(m, jid)(d)


class _Anchor:
    """:func:`_separation` of one joint, its parent-side anchor (constant) computed once."""

    def __init__(self, m, jid: int) -> None:
        child = int(m.jnt_bodyid[jid])
        self.jid, self.parent = int(jid), int(m.body_parentid[child])
        self.local = m.body_pos[child] + _rot(m.body_quat[child]) @ m.jnt_pos[jid]

    def __call__(self, d) -> float:
        from_parent = d.xpos[self.parent] + d.xmat[self.parent].reshape(3, 3) @ self.local
        return float(np.linalg.norm(from_parent - d.xanchor[self.jid]))


def _rot(q: np.ndarray) -> np.ndarray:
    import mujoco
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, q)
    return r.reshape(3, 3)


@dataclass(frozen=True)
class Stop:
    """Where a swept joint was at the end of one leg of its B2 sweep (the end of its hold, or of
    a spin), and what held it there.

    Attributes:
        target: the commanded end of the leg (rad or m; a spin: the commanded turn).
        distance: how far the leg commanded the joint to go (rad or m).
        ramp_s: the time the leg's ramp gave that travel (a spin: its length).
        reached: the farthest the joint got towards ``target`` during the leg.
        speed: its speed towards ``target`` at the end (rad/s or m/s).
        force: its actuator force then (N m or N).
        load: the bias and constraint force on its DOF then (N m or N; gravity is off in B2).
        inertia: its joint-space inertia then (kg m^2 or kg).
        contacts: ``(part, link, other part, other link)`` of every contact between its child
            subtree and the rest, the moving side first.
    """

    target: float
    distance: float
    ramp_s: float
    reached: float
    speed: float
    force: float
    load: float
    inertia: float
    contacts: tuple[tuple[str, str, str, str], ...]


def _part_of(m: MjModel, geom: int) -> str:
    """The part a geom belongs to (a collision piece ``<part>__c<k>`` or the visual ``<part>``)."""
    name = m.geom(geom).name
    hit = _PIECE.match(name)
    return hit.group(1) if hit else name


def contact_pairs(m: MjModel, d: MjData, bodies: set[int]) -> tuple[tuple[str, str, str, str], ...]:
    """``(part, link, other part, other link)`` of every current contact between a body in
    ``bodies`` and one outside it (a link is a MuJoCo body), each pair once."""
    out: list[tuple[str, str, str, str]] = []
    for c in d.contact[: d.ncon]:
        g1, g2 = int(c.geom1), int(c.geom2)
        b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
        if (b1 in bodies) == (b2 in bodies):
            continue
        if b1 not in bodies:
            g1, g2, b1, b2 = g2, g1, b2, b1
        pair = (_part_of(m, g1), m.body(b1).name, _part_of(m, g2), m.body(b2).name)
        if pair not in out:
            out.append(pair)
    return tuple(out)


def _stop(m: MjModel, d: MjData, dof: int, act: int, bodies: set[int], target: float,
          distance: float, ramp_s: float, reached: float, sign: float) -> Stop:
    """The :class:`Stop` of the state ``d`` (``sign``: +1 when the leg moves the joint up)."""
    import mujoco
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    inertia = float(full[dof, dof])
    load = float(d.qfrc_bias[dof] - d.qfrc_passive[dof] - d.qfrc_constraint[dof])
    return Stop(target, distance, ramp_s, reached, sign * float(d.qvel[dof]),
                float(d.actuator_force[act]), load, inertia, contact_pairs(m, d, bodies))


def reach_why(dof: JointDof, stop: Stop) -> tuple[str, str]:
    """``(cause, reason)`` of one leg of a sweep that fell short, in this order: ``collision``
    (the contact pairs and where the joint stopped), ``effort`` (its actuator saturated: the
    force limit, the load, and the time that effort needs to move the joint's inertia that far
    against the time the sweep gave), ``ramp`` (still on its way when the leg ended: the time
    its ``velocity`` limit needs for the travel against the ramp's), or ``unknown`` (none of
    these: the numbers). A ramp faster than the velocity limit is named in every reason (a spin
    has no ramp: it is commanded at half its velocity limit)."""
    kind = dof.kind
    unit = "N" if kind.slides else "N m"
    vunit = "m/s" if kind.slides else "rad/s"
    spin = dof.drive == "velocity"
    moving = stop.speed > MOVING_SPEED
    if spin:
        got = f"it turned {kind.label(stop.reached)} of the {kind.label(stop.target)} commanded"
    else:
        got = f"it got to {kind.label(stop.reached)} of {kind.label(stop.target)}"
    where = (f"{got}, still moving at {stop.speed:.3g} {vunit} when the hold ended"
             if moving and not spin else got)
    velocity_time = stop.distance / dof.velocity if dof.velocity > 0 else math.inf
    too_fast = (f"{kind.label(stop.distance)} at its velocity limit {dof.velocity:.3g} {vunit} "
                f"takes {velocity_time:.3g} s, the ramp gave {stop.ramp_s:.3g} s")
    note = "" if spin or velocity_time <= stop.ramp_s else f" (also, {too_fast})"
    if stop.contacts:
        pairs = ", ".join(f"{p!r} (link {lk!r}) against {q!r} (link {ok!r})"
                          for p, lk, q, ok in stop.contacts[:MAX_PAIRS])
        more = len(stop.contacts) - MAX_PAIRS
        return "collision", (f"a collision: {got}, with {pairs}"
                             f"{f' and {more} more pairs' if more > 0 else ''} in contact{note}")
    if abs(stop.force) >= SATURATION * dof.effort:
        if spin:  # from rest to the commanded speed at full effort
            need = stop.inertia * (stop.target / stop.ramp_s) / dof.effort
            what = f"spinning its {stop.inertia:.3g} kg m^2 up to speed"
        else:  # at full effort, accelerating half way and braking the rest
            need = 2.0 * math.sqrt(stop.distance * stop.inertia / dof.effort)
            what = (f"moving its {stop.inertia:.3g} {'kg' if kind.slides else 'kg m^2'} over "
                    f"{kind.label(stop.distance)}")
        load = (f" against {abs(stop.load):.3g} {unit} of bias and constraint force"
                if abs(stop.load) > 0.01 * dof.effort else "")
        return "effort", (f"too little effort: {where}; its actuator is saturated at its effort "
                          f"{dof.effort:.3g} {unit}{load}; {what} takes at least {need:.3g} s at "
                          f"that effort, the {'spin' if spin else 'ramp'} gave {stop.ramp_s:.3g} s"
                          f"{'' if spin else f' (and the hold {SWEEP_HOLD_S:.3g} s)'}{note}")
    if moving and not spin:
        return "ramp", f"the ramp was too short: {where}; {too_fast}"
    return "unknown", (f"{where} with no contact and its actuator below its effort "
                       f"({abs(stop.force):.3g} of {dof.effort:.3g} {unit}){note}")


def sweep_joint(m: MjModel, art: Articulation, name: str) -> dict[str, Any]:
    """Drive one 1-DOF joint (a joint's name, or a cylindrical joint's ``__slide`` / ``__turn``)
    through its range (others held at 0). Returns reach data and the trajectory; gravity should
    be off in ``m`` (the sweep tests range, B1 tests gravity).

    When the reach is under ``TOL.sweep_reach``, ``why`` says why (:func:`reach_why` of each leg
    that fell short: to the lower limit, to the upper limit, or the spin) and ``cause`` is the
    first leg's cause; both are None otherwise. ``ramp_s`` is the time the ramp gives the full
    range and ``ramp_needed_s`` the time the joint's ``velocity`` limit needs for it (None for a
    spin)."""
    import mujoco
    j = _dof(art, name)
    jid, aid = _ids(m, art)
    i, a = jid[name], aid[name]
    qadr, dof = int(m.jnt_qposadr[i]), int(m.jnt_dofadr[i])
    bodies = subtree_bodies(m, int(m.jnt_bodyid[i]))
    d = mujoco.MjData(m)
    dt = m.opt.timestep
    traj, qs, sep = [], [], 0.0
    separation = _Anchor(m, i)
    if j.drive == "velocity":  # a speed servo (the articulation's drive): spin it
        v = min(SPIN_FRACTION * j.velocity, 2 * math.pi)
        steps = int(SPIN_S / dt)
        for k in range(steps):
            d.ctrl[a] = v
            mujoco.mj_step(m, d)
            sep = max(sep, separation(d))
            if k % 25 == 0:
                traj.append(d.qpos.copy())
        turned = float(d.qpos[qadr])
        commanded = v * steps * dt
        out = {"reach": turned / commanded, "qmin": 0.0, "qmax": turned, "separation_m": sep,
               "traj": traj, "warnings": warnings_of(d), "ramp_s": steps * dt,
               "ramp_needed_s": None, "why": None, "cause": None}
        if out["reach"] < TOL.sweep_reach:
            stop = _stop(m, d, dof, a, bodies, commanded, commanded, steps * dt, turned, 1.0)
            out["cause"], out["why"] = reach_why(j, stop)
        return out
    lo, hi = float(j.lower), float(j.upper)
    legs = [[(0.0, lo, SWEEP_RAMP_S), (lo, lo, SWEEP_HOLD_S)],
            [(lo, hi, 2 * SWEEP_RAMP_S), (hi, hi, SWEEP_HOLD_S)]]
    stops: list[Stop] = []
    k = 0
    for leg, sign in zip(legs, (-1.0, 1.0)):
        far = -math.inf
        for start, end, dur in leg:
            n = max(1, int(dur / dt))
            for s in range(n):
                d.ctrl[a] = start + (end - start) * (s + 1) / n
                mujoco.mj_step(m, d)
                q = float(d.qpos[qadr])
                qs.append(q)
                far = max(far, sign * q)
                sep = max(sep, separation(d))
                if k % 25 == 0:
                    traj.append(d.qpos.copy())
                k += 1
        (start, end, dur), _ = leg
        stops.append(_stop(m, d, dof, a, bodies, end, abs(end - start), dur, sign * far, sign))
    qmin, qmax = min(qs), max(qs)
    span = hi - lo
    reach = (qmax - qmin) / span if span > 0 else 1.0
    out = {"reach": reach, "qmin": qmin, "qmax": qmax, "separation_m": sep, "traj": traj,
           "warnings": warnings_of(d), "ramp_s": 2 * SWEEP_RAMP_S,
           "ramp_needed_s": span / j.velocity if j.velocity > 0 else None, "why": None,
           "cause": None}
    if reach < TOL.sweep_reach:
        # the legs that fell short: each by more than half the allowed shortfall, else the worse
        short = [max(0.0, qmin - lo), max(0.0, hi - qmax)]
        legs_short = [x for x, gap in zip(stops, short) if gap > 0.5 * (1 - TOL.sweep_reach) * span]
        legs_short = legs_short or [stops[int(np.argmax(short))]]
        whys = [reach_why(j, x) for x in legs_short]
        out["cause"] = whys[0][0]
        out["why"] = "; ".join(f"towards {j.kind.label(x.target)}: {w}"
                               for x, (_, w) in zip(legs_short, whys))
    return out


def sweep_joints(m: MjModel, art: Articulation, names: list[str]) -> dict[str, dict[str, Any]]:
    """:func:`sweep_joint` of every 1-DOF joint in ``names``, in fewer simulations: joints that
    cannot touch each other's motion (:func:`independent_groups`) are driven together, each on
    its own schedule, in one simulation of the model; a joint that does not come out of it
    clean (short of ``TOL.sweep_reach``, separated by more than ``TOL.sweep_separation_m``, or
    any MuJoCo warning in the group) is driven again alone, so every finding, its reason and
    its frames are those of its own sweep. The rest drive alone, as before."""
    out: dict[str, dict[str, Any]] = {}
    for group in independent_groups(m, art, names):
        if len(group) > 1:
            together = _sweep_group(m, art, group)
            for name, x in together.items():
                if (x["reach"] >= TOL.sweep_reach and x["separation_m"] <= TOL.sweep_separation_m
                        and not x["warnings"]):
                    out[name] = x
        for name in group:
            if name not in out:
                out[name] = sweep_joint(m, art, name)
    return {n: out[n] for n in names}


def _static(m: MjModel, body: int) -> bool:
    """Whether ``body`` is welded to the world (no joint between it and the world body)."""
    b = int(body)
    while b != 0:
        if int(m.body_jntnum[b]) > 0 or int(m.body_mocapid[b]) >= 0:
            return False
        b = int(m.body_parentid[b])
    return True


def independent_groups(m: MjModel, art: Articulation, names: list[str]) -> list[list[str]]:
    """``names`` split into groups whose joints B2 may drive in one simulation: position-driven
    1-DOF joints (not a cylindrical joint's DOF) whose parent body is welded to the world, so
    that nothing one of them moves is carried by another's motion or pushes its parent, and
    whose swept envelopes (a hinge: the ball about its anchor through its subtree's farthest
    geom box corner; a slide: its subtree's boxes stretched over its range) keep clear of each
    other's by twice the largest contact margin and a millimetre, so that their subtrees never
    touch. In a model with a free joint or an equality constraint every joint is alone."""
    import mujoco
    singles = [[n] for n in names]
    if _free_dof(m) is not None or m.neq > 0:
        return singles
    jid, aid = _ids(m, art)
    compound = {d.name for j in art.joints if j.kind.compound for d in j.dofs()}
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    mujoco.mj_kinematics(m, d)
    pad = 2.0 * float(m.geom_margin.max(initial=0.0)) + 1e-3
    groups: list[tuple[list[str], list[tuple[np.ndarray, np.ndarray]]]] = []
    out: list[list[str]] = []
    for name in names:
        i = jid.get(name, -1)
        dof = _dof(art, name)
        body = int(m.jnt_bodyid[i]) if i >= 0 else -1
        if (i < 0 or aid.get(name, -1) < 0 or dof.drive != "position" or name in compound
                or not _static(m, int(m.body_parentid[body]))):
            out.append([name])
            continue
        corners = _box_corners(m, d, _subtree_geoms(m, subtree_bodies(m, body)))
        if not len(corners):
            out.append([name])
            continue
        if dof.kind.slides:
            axis = d.xaxis[i]
            span = (float(dof.upper) - float(dof.lower)) * 0.05  # an overshoot past the range
            ends = [corners + axis * (float(dof.lower) - span), corners + axis * (float(dof.upper) + span)]
            pts = np.vstack([corners, *ends])
            box = (pts.min(axis=0) - pad, pts.max(axis=0) + pad)
        else:
            r = float(np.linalg.norm(corners - d.xanchor[i], axis=1).max())
            box = (d.xanchor[i] - r - pad, d.xanchor[i] + r + pad)
        for members, boxes in groups:
            if all(np.any(box[0] > b[1]) or np.any(b[0] > box[1]) for b in boxes):
                members.append(name)
                boxes.append(box)
                break
        else:
            groups.append(([name], [box]))
    return [members for members, _ in groups] + out


def _sweep_group(m: MjModel, art: Articulation, names: list[str]) -> dict[str, dict[str, Any]]:
    """:func:`sweep_joint`'s position-driven sweep of every joint in ``names`` in one
    simulation (each on its own range, the same schedule), for :func:`sweep_joints`: reach,
    extremes, separation and the simulation's warnings (no trajectory and no reason: a joint
    that needs either is driven again alone)."""
    import mujoco
    jid, aid = _ids(m, art)
    dofs = [_dof(art, n) for n in names]
    jids = np.array([jid[n] for n in names])
    acts = np.array([aid[n] for n in names])
    qadr = m.jnt_qposadr[jids]
    parents = m.body_parentid[m.jnt_bodyid[jids]]
    local = np.array([_Anchor(m, int(i)).local for i in jids])
    lo = np.array([float(x.lower) for x in dofs])
    hi = np.array([float(x.upper) for x in dofs])
    zero = np.zeros(len(names))
    legs = [[(zero, lo, SWEEP_RAMP_S), (lo, lo, SWEEP_HOLD_S)],
            [(lo, hi, 2 * SWEEP_RAMP_S), (hi, hi, SWEEP_HOLD_S)]]
    d = mujoco.MjData(m)
    dt = m.opt.timestep
    qmin, qmax = np.full(len(names), np.inf), np.full(len(names), -np.inf)
    sep = np.zeros(len(names))
    for leg in legs:
        for start, end, dur in leg:
            n = max(1, int(dur / dt))
            for s in range(n):
                d.ctrl[acts] = start + (end - start) * (s + 1) / n
                mujoco.mj_step(m, d)
                q = d.qpos[qadr]
                qmin, qmax = np.minimum(qmin, q), np.maximum(qmax, q)
                rot = d.xmat[parents].reshape(-1, 3, 3)
                gap = d.xpos[parents] + np.einsum("nij,nj->ni", rot, local) - d.xanchor[jids]
                sep = np.maximum(sep, np.linalg.norm(gap, axis=1))
    warns = warnings_of(d)
    out = {}
    for k, (name, x) in enumerate(zip(names, dofs)):
        span = hi[k] - lo[k]
        reach = float((qmax[k] - qmin[k]) / span) if span > 0 else 1.0
        out[name] = {"reach": reach, "qmin": float(qmin[k]), "qmax": float(qmax[k]),
                     "separation_m": float(sep[k]), "traj": [], "warnings": warns,
                     "ramp_s": 2 * SWEEP_RAMP_S,
                     "ramp_needed_s": span / x.velocity if x.velocity > 0 else None,
                     "why": None, "cause": None}
    return out


def check_b4(m, art: Articulation, wheels: list[str], floor_z: float
             ) -> tuple[CheckResult, list[np.ndarray]]:
    """B4: after settling, every wheel touches the floor, and one uniform command on every wheel
    (the articulation gives all wheels one drive sign) moves the root at least
    ``TOL.drive_min_ratio`` of the ideal rolling distance while it turns by at most
    ``TOL.drive_max_yaw_deg`` (a straight drive)."""
    import mujoco
    if not wheels:
        return CheckResult("B4", "wheeled mobility", True, message="no wheels: skipped",
                           skipped=True), []
    d = mujoco.MjData(m)
    for _ in range(int(1.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    touching = set()
    for c in d.contact[: d.ncon]:
        for g, other in ((c.geom1, c.geom2), (c.geom2, c.geom1)):
            if other == floor:
                touching.add(m.body(int(m.geom_bodyid[g])).name)
    jid, aid = _ids(m, art)
    off = [w for w in wheels if not any(lk in touching for lk in art.subtree(art.joint(w).child))]
    free = _free_qpos(m)
    start = d.qpos[free:free + 3].copy() if free is not None else np.zeros(3)
    yaw0 = _yaw(d.qpos[free + 3:free + 7]) if free is not None else 0.0
    traj = []
    radius = np.mean([max(art.joint(w).anchor_m[2] - floor_z, 1e-3) for w in wheels])
    v = min(min(art.joint(w).velocity for w in wheels), 2 * math.pi)
    for k in range(int(DRIVE_S / m.opt.timestep)):
        for w in wheels:
            d.ctrl[aid[w]] = v  # one uniform command: the drive signs are the articulation's
        mujoco.mj_step(m, d)
        if k % 100 == 0:
            traj.append(d.qpos.copy())
    moved = (float(np.linalg.norm((d.qpos[free:free + 3] - start)[:2])) if free is not None
             else 0.0)
    ideal = v * radius * DRIVE_S
    ratio = moved / ideal if ideal > 0 else 0.0
    yaw = (math.degrees(_yaw(d.qpos[free + 3:free + 7]) - yaw0) if free is not None else 0.0)
    yaw = (yaw + 180.0) % 360.0 - 180.0
    problems = []
    if off:
        problems.append(f"wheel(s) {', '.join(off)} do not touch the floor after settling")
    if ratio < TOL.drive_min_ratio:
        problems.append(f"root {art.root.name!r} travelled {moved:.3g} m of {ideal:.3g} m ideal "
                        f"(ratio {ratio:.2f} < {TOL.drive_min_ratio})")
    if abs(yaw) > TOL.drive_max_yaw_deg:
        problems.append(f"a uniform command on every wheel turned the base {yaw:.3g} deg in "
                        f"{DRIVE_S} s (limit {TOL.drive_max_yaw_deg} deg): the wheels do not share "
                        f"one drive sign")
    measured = {"wheels": len(wheels), "wheels_off_ground": len(off), "travel_m": moved,
                "travel_ratio": ratio, "yaw_deg": yaw}
    limits = {"wheels_off_ground": 0, "travel_ratio": TOL.drive_min_ratio,
              "yaw_deg": TOL.drive_max_yaw_deg}
    return CheckResult("B4", "wheeled mobility", not problems, measured, limits,
                       "; ".join(problems) or f"{len(wheels)} wheels on the floor; drove {moved:.3g} m"), traj


def _yaw(q: np.ndarray) -> float:
    """Yaw (rad, about world z) of a MuJoCo quaternion (w, x, y, z)."""
    w, x, y, z = (float(c) for c in q)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def check_b7(m) -> tuple[CheckResult, list[np.ndarray]]:
    """B7: pseudo-random controls within range for :data:`SMOKE_S`; no warnings, no NaN."""
    import mujoco
    rng = np.random.default_rng(SMOKE_SEED)
    d = mujoco.MjData(m)
    lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    period = max(1, int(SMOKE_PERIOD_S / m.opt.timestep))
    traj = []
    for k in range(int(SMOKE_S / m.opt.timestep)):
        if k % period == 0 and m.nu:
            d.ctrl[:] = rng.uniform(lo, hi)
            traj.append(d.qpos.copy())
        mujoco.mj_step(m, d)
    warns = warnings_of(d)
    finite = bool(np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel)))
    problems = []
    if warns:
        problems.append(f"MuJoCo warnings {warns}")
    if not finite:
        problems.append("state became NaN/inf")
    return CheckResult("B7", "smoke run", not problems, {"warnings": sum(warns.values()),
                                                         "finite": finite},
                       {"warnings": 0, "finite": True},
                       "; ".join(problems) or f"{SMOKE_S} s of random controls, no warnings"), traj
