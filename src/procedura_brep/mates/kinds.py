"""Joint kinds: what an articulation joint is, for every consumer, in one table.

A kinematic mate type (:mod:`.vocabulary`) becomes one of five joint kinds once its options are
known: a ``revolute`` mate with limits is a ``revolute`` joint, without limits a ``continuous``
one; ``prismatic``, ``spherical`` and ``cylindrical`` mates keep their name. Each kind owns what
the exporters, the battery, the sweeps and the wheel finder need to know about it (its motion,
its units, its URDF / MJCF / UsdPhysics names, its default drive, whether it can be a wheel), so
no consumer compares joint-type names. Pure data: no numeric or CAD import.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Literal


class Motion(str, Enum):
    """The motion a mate allows the child in the mate frame (``Delta``'s shape)."""

    NONE = "none"
    """A static mate: identity."""
    TURN = "turn"
    """A rotation about frame Z (revolute, continuous)."""
    SLIDE = "slide"
    """A translation along frame Z (prismatic)."""
    BALL = "ball"
    """A rotation about the frame origin (spherical)."""
    SLIDE_TURN = "slide_turn"
    """A translation along and a rotation about frame Z (cylindrical)."""


#: How a joint is driven: ``position`` (a servo to a commanded position inside the limits; for a
#: spherical joint, three hold servos about the frame's axes) or ``velocity`` (a speed servo: a
#: continuous joint, a wheel).
Drive = Literal["position", "velocity"]


@dataclass(frozen=True)
class JointKind:
    """One articulation joint kind and its mapping onto every export format.

    Attributes:
        name: the articulation joint type (``Joint.type``).
        motion: what the joint moves (:class:`Motion`).
        limited: whether its range is bounded (False: a continuous turn).
        unit: the SI unit of its values and limits: ``rad`` (a turn, a ball's cone) or ``m``.
        mate_unit: the unit of the mate's own limits and ``home``: ``deg`` or ``mm``.
        urdf: the URDF ``<joint type>`` of its one joint; None where it is written as several
            (a cylindrical joint's slide and turn; a spherical joint in the strict profile).
        mjcf: the MuJoCo joint type (``hinge``, ``slide``, ``ball``); None where it is several.
        usd: the UsdPhysics joint schema (``Joint``: a generic D6 joint with locked DOF).
        usd_drive: the UsdPhysics ``DriveAPI`` instance of its one DOF (None: none or several).
        default_drive: the drive it gets unless a plan says otherwise.
        wheel: whether it may be a wheel (:mod:`procedura_brep.articulation.wheels`).
    """

    name: str
    motion: Motion
    limited: bool
    unit: Literal["rad", "m"]
    mate_unit: Literal["deg", "mm"]
    urdf: str | None
    mjcf: str | None
    usd: str
    usd_drive: Literal["angular", "linear"] | None
    default_drive: Drive = "position"
    wheel: bool = False

    @property
    def turns(self) -> bool:
        """A 1-DOF rotation about the joint axis (revolute or continuous)."""
        return self.motion is Motion.TURN

    @property
    def slides(self) -> bool:
        """A 1-DOF translation along the joint axis (prismatic)."""
        return self.motion is Motion.SLIDE

    @property
    def ball(self) -> bool:
        """A 3-DOF rotation about the joint origin (spherical)."""
        return self.motion is Motion.BALL

    @property
    def compound(self) -> bool:
        """Exported as several 1-DOF joints on one axis (cylindrical: a slide, then a turn)."""
        return self.motion is Motion.SLIDE_TURN

    @property
    def endless(self) -> bool:
        """A turn without limits (continuous): swept over one full turn, speed-driven."""
        return self.turns and not self.limited

    def to_si(self, value: float) -> float:
        """A mate-unit value (deg or mm) in this kind's SI unit (rad or m)."""
        return math.radians(value) if self.mate_unit == "deg" else value / 1000.0

    def label(self, value: float) -> str:
        """A joint value (SI) for a person: ``12.5 mm`` or ``30 deg``."""
        if self.unit == "m":
            return f"{value * 1000:.4g} mm"
        return f"{math.degrees(value):.4g} deg"


REVOLUTE = JointKind("revolute", Motion.TURN, True, "rad", "deg", "revolute", "hinge",
                     "RevoluteJoint", "angular")
CONTINUOUS = JointKind("continuous", Motion.TURN, False, "rad", "deg", "continuous", "hinge",
                       "RevoluteJoint", "angular", default_drive="velocity", wheel=True)
PRISMATIC = JointKind("prismatic", Motion.SLIDE, True, "m", "mm", "prismatic", "slide",
                      "PrismaticJoint", "linear")
SPHERICAL = JointKind("spherical", Motion.BALL, True, "rad", "deg", "spherical", "ball",
                      "SphericalJoint", None)
CYLINDRICAL = JointKind("cylindrical", Motion.SLIDE_TURN, True, "m", "mm", None, None,
                        "Joint", None)

#: Every joint kind by name (``Joint.type`` / ``JointDof.type``).
JOINT_KINDS: dict[str, JointKind] = {k.name: k for k in
                                     (REVOLUTE, CONTINUOUS, PRISMATIC, SPHERICAL, CYLINDRICAL)}


def joint_kind(name: str) -> JointKind:
    """The joint kind called ``name``.

    Raises:
        KeyError: not a joint kind, naming the known ones.
    """
    try:
        return JOINT_KINDS[name]
    except KeyError:
        raise KeyError(f"unknown joint type {name!r}; joint types: {', '.join(JOINT_KINDS)}") from None


__all__ = ["CONTINUOUS", "CYLINDRICAL", "Drive", "JOINT_KINDS", "JointKind", "Motion", "PRISMATIC",
           "REVOLUTE", "SPHERICAL", "joint_kind"]
