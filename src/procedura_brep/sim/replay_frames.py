"""Frames of a failed battery check drawn again from the exported scene, in this process.

The battery draws failure frames in its own child process only when it can make a GL context
there (a child forked from a process that already renders cannot). The articulation stage's
battery fixer needs them anyway, so :func:`failure_frames` rebuilds the failing phase from the
bundle's ``model.xml``: for a joint check (B2) it poses each named joint through its range
(kinematic, no dynamics), otherwise it runs the scene passively from rest for
:data:`PASSIVE_S` seconds; then it renders up to :data:`.frames.MAX_FRAMES` frames with
:func:`.frames.render_frames` (best effort: no GL, no frames).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from .frames import MAX_FRAMES, render_frames

#: Seconds of passive simulation drawn for a check that names no joint.
PASSIVE_S = 1.0
_JOINT_RE = re.compile(r"joint '([A-Za-z0-9_]+)'")


def named_joints(message: str) -> list[str]:
    """Joint names a check's message quotes (``joint 'arm_pivot' reached ...``), in order."""
    return list(dict.fromkeys(_JOINT_RE.findall(message)))


def failure_states(m, joints: list[str]) -> list[np.ndarray]:
    """qpos states showing the failure: the named hinge/slide joints swept lower -> upper one
    after another, or (none usable) a passive run from rest."""
    import mujoco
    out: list[np.ndarray] = []
    usable = []
    for name in joints:
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid >= 0 and int(m.jnt_type[jid]) in (int(mujoco.mjtJoint.mjJNT_HINGE),
                                                  int(mujoco.mjtJoint.mjJNT_SLIDE)):
            usable.append(jid)
    per = max(1, MAX_FRAMES // max(1, len(usable)))
    for jid in usable:
        lo, hi = (m.jnt_range[jid] if m.jnt_limited[jid] else (0.0, 2 * np.pi))
        for t in np.linspace(0.0, 1.0, per):
            q = m.qpos0.copy()
            q[int(m.jnt_qposadr[jid])] = lo + (hi - lo) * t
            out.append(q)
    if out:
        return out
    d = mujoco.MjData(m)
    steps = int(PASSIVE_S / m.opt.timestep)
    every = max(1, steps // MAX_FRAMES)
    for k in range(steps):
        mujoco.mj_step(m, d)
        if k % every == every - 1:
            out.append(d.qpos.copy())
    return out


def failure_frames(bundle: Path, check: str, message: str, out_dir: Path) -> list[str]:
    """Render the failing phase of ``check`` from ``bundle/model.xml`` into
    ``out_dir/renders/sim/<check>_fixer_<k>.png``; paths relative to ``out_dir``."""
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(bundle / "model.xml"))
    return render_frames(m, failure_states(m, named_joints(message)), out_dir, f"{check}_fixer")


__all__ = ["failure_frames", "failure_states", "named_joints"]
