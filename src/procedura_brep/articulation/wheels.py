"""Wheels by evidence, and one drive sign for all of them.

A joint is a **wheel** when all of these hold:

* it is continuous (a revolute mate without limits);
* its axis lies within :data:`MAX_TILT_DEG` of the floor plane: a wheel rolls on its rim, so a
  vertical shaft whose end reaches the floor (a gearbox's journal, a turntable's spindle) is
  not one;
* its child part is round about the joint axis: the surface-covariance symmetry axis of
  :func:`procedura_brep.articulation.evidence.symmetry_axis` exists, is parallel to the joint
  axis within ``TOL.wheel_axis_deg`` and passes within ``TOL.wheel_centre_mm`` of the joint's
  axis line;
* the lowest point of its child subtree is within ``TOL.wheel_ground_mm`` of the model's lowest
  point (the floor of ``model.xml``); both exact (the parts' exact boxes, no tessellation), and
  checked before the roundness, which needs the child's mesh.

Any other continuous joint (a feed hub, a spindle, a fan) is a spinning joint: no free base for
it, no B4, and B2 sweeps it like any other joint.

**Drive sign.** A wheel turning by +w about its axis ``a`` rolls the vehicle along
``a x z`` (z up). The base's forward direction is its root link's +X on the floor plane (or, when
the first wheel rolls across that, the first wheel's rolling direction). A wheel that would
roll backwards has its joint frame turned half a turn about the frame's X axis
(:func:`flip`), so its axis (+Z of the joint frame, the child link's frame) is ``-a``: one
uniform positive command then drives every wheel forward, the same way in URDF, USD and MJCF,
which all take their joint frames from the articulation.
"""

from __future__ import annotations

import math

import numpy as np

from ..config import TOL

#: Up direction of the floor (world +Z).
UP = np.array([0.0, 0.0, 1.0])
#: Half a turn about X, exact (no rounding in the rotation entries).
HALF_TURN_X = np.diag([1.0, -1.0, -1.0, 1.0])
#: A wheel's axis is at most this far (degrees) out of the floor plane (camber and toe-in
#: included; a vertical shaft touching the floor is not a wheel).
MAX_TILT_DEG = 30.0
#: A rolling direction within this cosine of perpendicular to the root's +X is "across" it.
ACROSS_COS = 0.5


def is_round_about(symmetry: dict, point: np.ndarray, axis: np.ndarray) -> bool:
    """Whether a symmetry-evidence record says the part is round about the line (point, axis)."""
    if symmetry.get("kind") != "axis" or symmetry.get("axis") is None:
        return False
    s = np.asarray(symmetry["axis"], float)
    s = s / np.linalg.norm(s)
    if abs(float(s @ axis)) < math.cos(math.radians(TOL.wheel_axis_deg)):
        return False
    q = np.asarray(symmetry["point"], float) - point
    return float(np.linalg.norm(q - (q @ axis) * axis)) <= TOL.wheel_centre_mm


def find_wheels(model, links: dict[str, list[str]], joints: list, subtree, *,
                evidence: dict | None = None) -> list[str]:
    """Names of the wheel joints among ``joints`` (see the module doc).

    Args:
        model: the CompiledModel.
        links: link name -> its part names.
        joints: the articulation's joints.
        subtree: function link name -> the link and every link below it.
        evidence: :func:`.evidence.mates_evidence` of ``model``, whose symmetry records are
            used when given (else each candidate's symmetry axis is computed here).
    """
    from .evidence import symmetry_axis
    continuous = [j for j in joints if j.kind.wheel]
    if not continuous:
        return []
    lows: dict[str, float] = {}

    def lowest(name: str) -> float:  # the exact lowest point: no tessellation (a long thread's is seconds)
        if name not in lows:
            lows[name] = float(model.part(name).extent(UP)[0])
        return lows[name]
    floor = min(lowest(p.name) for p in model.parts)
    known = (evidence or {}).get("parts", {})
    out = []
    for j in continuous:
        if abs(float(np.asarray(j.axis, float) @ UP)) > math.sin(math.radians(MAX_TILT_DEG)):
            continue  # not rolling on the floor, whatever touches it
        parts = [p for lk in subtree(j.child) for p in links[lk]]
        if min(lowest(p) for p in parts) - floor > TOL.wheel_ground_mm:
            continue  # off the floor: a lead screw, a fan
        child = j.mate.child
        sym = (known[child]["symmetry"] if child in known
               else symmetry_axis(model.part(child).mesh()))
        if is_round_about(sym, j.frame[:3, 3], j.axis):
            out.append(j.name)
    return out


def rolling_direction(axis: np.ndarray) -> np.ndarray:
    """Unit direction the vehicle rolls when a wheel turns positively about ``axis``."""
    d = np.cross(axis, UP)
    n = float(np.linalg.norm(d))
    return d / n if n > 0 else d


def forward(root_frame: np.ndarray, first_axis: np.ndarray) -> np.ndarray:
    """The base's forward direction on the floor (see the module doc)."""
    x = np.array(root_frame[:3, 0], float)
    x[2] = 0.0
    roll = rolling_direction(first_axis)
    if float(np.linalg.norm(x)) > 0:
        x /= np.linalg.norm(x)
        if abs(float(x @ roll)) >= ACROSS_COS:
            return x
    return roll


def flip(frame: np.ndarray) -> np.ndarray:
    """The joint frame turned half a turn about its own X axis (+Z becomes -Z)."""
    return frame @ HALF_TURN_X


__all__ = ["find_wheels", "flip", "forward", "is_round_about", "rolling_direction"]
