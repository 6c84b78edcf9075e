"""Dynamic checks in MuJoCo: B1 settle, B2 joint sweeps, B4 wheeled mobility, B7 smoke run.

Each function takes a compiled ``MjModel`` and returns a :class:`CheckResult` plus the qpos
trajectory of the phase it judged (for frames when it fails).
"""

from __future__ import annotations

import math

import numpy as np

from ..articulation.tree import Articulation, JointDof
from ..config import TOL
from .report import CheckResult

#: B1: simulated settle time, s.
SETTLE_S = 2.0
#: B1: max root linear speed at the end of the settle (m/s), free roots only.
SETTLE_ROOT_SPEED = 0.05
#: B2: ramp and hold durations, s.
SWEEP_RAMP_S, SWEEP_HOLD_S = 1.5, 0.5
#: B2: continuous joints are spun at this fraction of their velocity limit (capped at 2 pi).
SPIN_FRACTION = 0.5
#: B4: drive time, s (the minimum travel ratio is ``TOL.drive_min_ratio``).
DRIVE_S = 3.0
#: B7: smoke-run length and control period, s; RNG seed.
SMOKE_S, SMOKE_PERIOD_S, SMOKE_SEED = 2.0, 0.1, 0


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


def check_b1(m, art: Articulation) -> tuple[CheckResult, list[np.ndarray]]:
    """B1: hold every servo at the compiled pose for :data:`SETTLE_S`; nothing keeps moving."""
    import mujoco
    d = mujoco.MjData(m)
    traj = []
    steps = int(SETTLE_S / m.opt.timestep)
    for k in range(steps):
        mujoco.mj_step(m, d)
        if k % 50 == 0:
            traj.append(d.qpos.copy())
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
    problems = []
    if not finite:
        problems.append("state became NaN/inf")
    if jspeed > TOL.settle_joint_speed:
        problems.append(f"joint {worst!r} still moving at {jspeed:.3g} after {SETTLE_S} s")
    if rspeed > SETTLE_ROOT_SPEED:
        problems.append(f"root link {art.root.name!r} still moving at {rspeed:.3g} m/s")
    if warns:
        problems.append(f"MuJoCo warnings {warns}")
    measured = {"max_joint_speed": jspeed, "root_speed_mps": rspeed, "warnings": sum(warns.values())}
    limits = {"max_joint_speed": TOL.settle_joint_speed, "root_speed_mps": SETTLE_ROOT_SPEED, "warnings": 0}
    return CheckResult("B1", "dynamic settle", not problems, measured, limits,
                       "; ".join(problems) or f"settled within {SETTLE_S} s"), traj


def _separation(m, d, jid: int) -> float:
    """Distance between a joint's anchor seen from the child and from its parent body."""
    child = int(m.jnt_bodyid[jid])
    parent = int(m.body_parentid[child])
    local = m.body_pos[child] + _rot(m.body_quat[child]) @ m.jnt_pos[jid]
    from_parent = d.xpos[parent] + d.xmat[parent].reshape(3, 3) @ local
    return float(np.linalg.norm(from_parent - d.xanchor[jid]))


def _rot(q: np.ndarray) -> np.ndarray:
    import mujoco
    r = np.zeros(9)
    mujoco.mju_quat2Mat(r, q)
    return r.reshape(3, 3)


def sweep_joint(m, art: Articulation, name: str) -> dict:
    """Drive one 1-DOF joint (a joint's name, or a cylindrical joint's ``__slide`` / ``__turn``)
    through its range (others held at 0). Returns reach data and the trajectory; gravity should
    be off in ``m`` (the sweep tests range, B1 tests gravity)."""
    import mujoco
    j = _dof(art, name)
    jid, aid = _ids(m, art)
    i, a = jid[name], aid[name]
    qadr = int(m.jnt_qposadr[i])
    d = mujoco.MjData(m)
    dt = m.opt.timestep
    traj, qs, sep = [], [], 0.0
    if j.drive == "velocity":  # a speed servo (the articulation's drive): spin it
        v = min(SPIN_FRACTION * j.velocity, 2 * math.pi)
        steps = int(1.0 / dt)
        for k in range(steps):
            d.ctrl[a] = v
            mujoco.mj_step(m, d)
            sep = max(sep, _separation(m, d, i))
            if k % 25 == 0:
                traj.append(d.qpos.copy())
        turned = float(d.qpos[qadr])
        return {"reach": turned / (v * steps * dt), "qmin": 0.0, "qmax": turned,
                "separation_m": sep, "traj": traj, "warnings": warnings_of(d)}
    lo, hi = float(j.lower), float(j.upper)
    plan = [(0.0, lo, SWEEP_RAMP_S), (lo, lo, SWEEP_HOLD_S), (lo, hi, 2 * SWEEP_RAMP_S),
            (hi, hi, SWEEP_HOLD_S)]
    k = 0
    for start, end, dur in plan:
        n = max(1, int(dur / dt))
        for s in range(n):
            d.ctrl[a] = start + (end - start) * (s + 1) / n
            mujoco.mj_step(m, d)
            q = float(d.qpos[qadr])
            qs.append(q)
            sep = max(sep, _separation(m, d, i))
            if k % 25 == 0:
                traj.append(d.qpos.copy())
            k += 1
    qmin, qmax = min(qs), max(qs)
    span = hi - lo
    return {"reach": (qmax - qmin) / span if span > 0 else 1.0, "qmin": qmin, "qmax": qmax,
            "separation_m": sep, "traj": traj, "warnings": warnings_of(d)}


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
