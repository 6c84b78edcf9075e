"""Closed-form placement: ``T_child = T_parent * F_parent * Delta * F_child^-1``.

Pure numpy on 4x4 homogeneous matrices (millimetres), so the parent process can re-derive and
check every placement without the CAD kernel. ``Delta`` is the joint's motion in the mate frame,
chosen by the type's :class:`.kinds.Motion`: identity for static mates, a rotation about Z for
``revolute``, a translation along Z for ``prismatic``, a rotation about the frame origin for
``spherical``, both of the first two for ``cylindrical``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .motion import (
    check_linear,
    check_tilt,
    motion_delta,
    plane_basis,
    rigid_inverse,
    rot_x,
    rot_y,
    rot_z,
    spherical_delta,
    spherical_tilt_deg,
    trans,
)
from .vocabulary import TYPES

__all__ = ["check_linear", "check_tilt", "check_value", "delta", "home_value", "motion_delta",
           "plane_basis", "rigid_inverse", "rot_x", "rot_y", "rot_z", "spherical_delta", "spherical_tilt_deg",
           "trans"]


def check_value(mate: str, mtype: str, value: float | Sequence[float],
                *, limits: tuple[float, float] | None = None, cone: float | None = None,
                angle_limits: tuple[float, float] | None = None) -> None:
    """Refuse a joint value outside its range, naming the mate, the value and the range (the
    type's own check, :meth:`.vocabulary.MateType.check_value`).

    Raises:
        RangeError: revolute angle (deg) or prismatic position (mm) outside ``limits``, or a
            spherical tilt (deg) beyond ``cone``, or a cylindrical (z mm, angle deg) outside
            ``limits`` / ``angle_limits``.
    """
    TYPES[mtype].check_value(mate, value, limits=limits, cone=cone, angle_limits=angle_limits)


def delta(mtype: str, value: float | Sequence[float] | None = None) -> np.ndarray:
    """``Delta`` for a mate type at joint value ``value`` (None = home/identity); a cylindrical
    value is ``(z mm, angle deg)``: ``trans(z) @ rot_z(angle)``."""
    return TYPES[mtype].delta(value)


def home_value(mtype: str, options: dict[str, Any]) -> float | tuple[float, ...] | None:
    """The joint value at which a kinematic mate places its child (None for static mates)."""
    return TYPES[mtype].home_value(options)


def solve(parent_world: np.ndarray, f_parent: np.ndarray, f_child: np.ndarray,
          d: np.ndarray | None = None) -> np.ndarray:
    """The child's world transform so that its frame lands on the parent's (times ``d``)."""
    d = np.eye(4) if d is None else d
    world: np.ndarray = parent_world @ f_parent @ d @ rigid_inverse(f_child)
    return world


def residual(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """(distance mm, angle rad) between two rigid transforms."""
    dist = float(np.linalg.norm(a[:3, 3] - b[:3, 3]))
    r = a[:3, :3].T @ b[:3, :3]
    cos = max(-1.0, min(1.0, (float(np.trace(r)) - 1.0) / 2.0))
    # acos loses precision near 0; use the skew part for small angles
    skew = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2.0
    ang = math.atan2(float(np.linalg.norm(skew)), cos)
    return dist, ang
