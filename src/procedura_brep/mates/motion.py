"""The motion math of the mates: 4x4 homogeneous matrices (millimetres, degrees), joint-value
checks, and ``Delta`` per :class:`.kinds.Motion`. Pure numpy; it knows no mate type, so the
vocabulary (:mod:`.vocabulary`) and the placement (:mod:`.placement`) both build on it."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..errors import RangeError
from .kinds import Motion


def rot_x(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]], dtype=float)


def rot_y(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1]], dtype=float)


def rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)


def trans(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def plane_basis(n: np.ndarray) -> np.ndarray:
    """Two unit vectors (rows) spanning the plane normal to the unit ``n``: ``u`` and ``n x u``,
    with ``n, u, n x u`` right-handed (``u`` made from the world X axis, or Y when ``n`` is
    near X)."""
    helper = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, helper)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u)])


def rigid_inverse(m: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform (exact transpose of the rotation)."""
    out = np.eye(4)
    r = m[:3, :3]
    out[:3, :3] = r.T
    out[:3, 3] = -r.T @ m[:3, 3]
    return out


def check_linear(what: str, value: float, limits: tuple[float, float] | None, unit: str) -> None:
    """Refuse a 1-D joint value (deg or mm) outside ``limits`` (None: unbounded)."""
    if limits is not None and not (limits[0] <= value <= limits[1]):
        raise RangeError(what, value, limits[0], limits[1], unit=unit)


def check_tilt(what: str, value: Sequence[float], cone: float) -> None:
    """Refuse a spherical value (rx, ry, rz deg) whose tilt exceeds ``cone`` (deg)."""
    tilt = spherical_tilt_deg(spherical_delta(value))
    if tilt > cone + 1e-9:
        raise RangeError(what, tilt, 0.0, cone, unit="deg")


def spherical_delta(value: Sequence[float]) -> np.ndarray:
    """Rotation for a spherical joint value (rx, ry, rz) in degrees: intrinsic X, then Y, then Z
    (``Rx @ Ry @ Rz``, build123d's ``Intrinsic.XYZ``, as its ``BallJoint`` uses)."""
    rx, ry, rz = (float(v) for v in value)
    m: np.ndarray = rot_x(rx) @ rot_y(ry) @ rot_z(rz)
    return m


def spherical_tilt_deg(m: np.ndarray) -> float:
    """Angle between the rotated Z axis and the original Z axis, degrees (the cone measure)."""
    return math.degrees(math.acos(max(-1.0, min(1.0, float(m[2, 2])))))


def _slide_turn(value: Sequence[float]) -> np.ndarray:
    z, ang = (float(v) for v in value)
    m: np.ndarray = trans(z=z) @ rot_z(ang)
    return m


#: ``Delta`` of each motion at a joint value (deg, mm, (rx, ry, rz) deg, or (z mm, angle deg)).
_DELTAS: dict[Motion, Callable[..., np.ndarray]] = {
    Motion.NONE: lambda value: np.eye(4),
    Motion.TURN: lambda value: rot_z(float(value)),
    Motion.SLIDE: lambda value: trans(z=float(value)),
    Motion.BALL: spherical_delta,
    Motion.SLIDE_TURN: _slide_turn,
}


def motion_delta(motion: Motion, value: float | Sequence[float] | None = None) -> np.ndarray:
    """``Delta`` for ``motion`` at joint value ``value`` (None = home/identity)."""
    return np.eye(4) if value is None else _DELTAS[motion](value)
