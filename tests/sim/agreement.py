"""Cross-format joint agreement: mate frames (mates.json) vs MJCF, URDF (both profiles), USD."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from procedura_brep.articulation.tree import Articulation
from procedura_brep.sim.fidelity import angle, bundle_joint_frames

TOL_M = 1e-6
TOL_RAD = 1e-6


def joint_errors(root: Path, art: Articulation) -> dict[tuple[str, str], tuple[float, float]]:
    """``{(format, joint): (anchor error m, axis error rad)}`` for every joint in every format;
    a strict-URDF spherical joint contributes its three revolutes (axes vs the mate frame's
    X, Y, Z). Missing joints raise AssertionError naming the format."""
    out = {}
    for fmt, frames in bundle_joint_frames(root, art).items():
        for j in art.joints:
            frame = j.frame
            if fmt == "urdf-strict" and j.type == "spherical":
                keys = [(f"{j.name}__{a}", frame[:3, k]) for k, a in enumerate("xyz")]
            elif j.type == "cylindrical" and fmt != "usd":  # slide + turn, one axis
                keys = [(d.name, frame[:3, 2]) for d in j.dofs()]
            else:
                keys = [(j.name, frame[:3, 2])]
            for key, axis in keys:
                assert key in frames, f"{fmt}: joint {key!r} missing (has {sorted(frames)})"
                anchor, got_axis = frames[key]
                da = float(np.linalg.norm(anchor - frame[:3, 3] / 1000.0))
                dr = angle(got_axis, axis)
                out[(fmt, key)] = (da, dr)
    return out


def assert_joints_agree(root: Path, art: Articulation) -> None:
    """Every joint anchor within :data:`TOL_M` and axis within :data:`TOL_RAD` in every format
    (a MuJoCo ball joint has no axis: its MJCF/URDF-mujoco axis is not compared)."""
    spherical = {j.name for j in art.joints if j.type == "spherical"}
    for (fmt, key), (da, dr) in joint_errors(root, art).items():
        assert da <= TOL_M, f"{fmt}: joint {key!r} anchor off by {da:.3g} m"
        if key in spherical and fmt in ("mjcf", "urdf-mujoco"):
            continue
        assert dr <= TOL_RAD, f"{fmt}: joint {key!r} axis off by {dr:.3g} rad"
