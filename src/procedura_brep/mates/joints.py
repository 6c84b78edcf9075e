"""build123d Joint objects for mates: placement and motion go through the kernel's joints.

Static mates and the home pose of kinematic mates are placed by ``RigidJoint.connect_to``
(the parent's joint sits at ``F_parent * Delta(home)``, the child's at ``F_child``). Kinematic
mates also get the matching build123d joint on the parent, with its limits, so the part can be
moved along exactly its free DOF:

* ``revolute`` -> ``RevoluteJoint`` about the frame's Z axis. Without ``angle_reference``
  build123d picks its own zero direction (``angle_reference`` with a non-Z axis gives wrong
  poses in build123d 0.13), so the joint stores the offset between that zero and the frame's
  X axis and :func:`move` converts our angle (from the frame's X) to build123d's.
* ``prismatic`` -> ``LinearJoint`` along Z (always given an explicit range and position, which
  build123d needs to avoid a NaN location). ``LinearJoint`` keeps the world orientation of the
  parent, so the child's ``RigidJoint`` carries the frame's rotation.
* ``spherical`` -> ``BallJoint`` at the frame, rotations X then Y then Z in degrees.
* ``cylindrical`` -> a ``LinearJoint`` on the parent driving a massless carrier, and a
  ``RevoluteJoint`` on the carrier driving the child (build123d's own ``CylindricalJoint``
  reads its angle reference in world coordinates against a part-local axis, which gives wrong
  poses on a rotated parent). :meth:`KinematicJoint.move` takes ``(z mm, angle deg)``.

Runs only where build123d is imported (the sandbox child and tests).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from build123d import Axis, BallJoint, LinearJoint, Location, RevoluteJoint, RigidJoint

from .kinds import Motion
from .placement import check_value
from .vocabulary import TYPES


@dataclass
class KinematicJoint:
    """A build123d joint on the parent plus the child's rigid joint it drives.

    ``mtype`` is the mate type (whose range check :meth:`move` applies; empty for a cylindrical
    mate's inner slide and turn, which the mate checks); ``motion`` is how :meth:`move` drives
    the joint.
    """

    mtype: str
    joint: Any
    child: RigidJoint
    name: str = ""
    limits: tuple[float, float] | None = None
    cone: float | None = None
    offset_deg: float = 0.0
    turn: "KinematicJoint | None" = None
    angle_limits: tuple[float, float] | None = None
    motion: Motion = Motion.NONE

    def move(self, value: float | tuple[float, float, float]) -> None:
        """Move the child to joint value ``value`` (deg, mm, or (rx, ry, rz) deg).

        Raises:
            RangeError: the value is outside the mate's limits (or cone); the message names the
                mate, the value and the range.
        """
        if self.mtype:  # a cylindrical mate's inner slide and turn: checked by the mate
            check_value(self.name, self.mtype, value, limits=self.limits, cone=self.cone,
                        angle_limits=self.angle_limits)
        if self.motion is Motion.SLIDE_TURN:
            z, ang = (float(v) for v in value)  # type: ignore[union-attr]  # SLIDE_TURN: (z, angle)
            self.joint.connect_to(self.child, position=z)
            self.turn.move(ang)  # type: ignore[union-attr]  # _slide_turn always sets the inner turn
        elif self.motion is Motion.TURN:
            self.joint.connect_to(self.child, angle=float(value) - self.offset_deg)  # type: ignore[arg-type]  # TURN: a scalar
        elif self.motion is Motion.SLIDE:
            self.joint.connect_to(self.child, position=float(value))  # type: ignore[arg-type]  # SLIDE: a scalar
        else:
            self.joint.connect_to(self.child, angles=tuple(value))  # type: ignore[arg-type]  # BALL: (rx, ry, rz)


def _rotation_only(loc: Location) -> Location:
    o = loc.orientation  # Euler angles (deg) as a Vector; the overloads want a tuple
    return Location((0, 0, 0), (o.X, o.Y, o.Z))


def rigid_place(parent: Any, child: Any, f_parent: Location, f_child: Location, label: str) -> Location:
    """Place ``child`` so its frame ``f_child`` lands on ``f_parent`` of ``parent`` (in place).

    Returns the child's new location.
    """
    pj = RigidJoint(f"{label}@parent", parent, joint_location=parent.location * f_parent)
    cj = RigidJoint(f"{label}@child", child, joint_location=child.location * f_child)
    pj.connect_to(cj)
    placed: Location = child.location
    return placed


def kinematic(mtype: str, parent: Any, child: Any, f_parent: Location, f_child: Location, label: str,
              *, limits: tuple[float, float] | None = None, cone: float | None = None,
              angle_limits: tuple[float, float] | None = None,
              home: tuple[float, float] = (0.0, 0.0)) -> KinematicJoint:
    """The build123d joint of a kinematic mate, attached to ``parent`` and driving ``child``.

    ``parent`` must already sit at its world location; frames are part-local. A cylindrical
    mate's carrier is placed at the slide value ``home[0]``. The joint built is the one of the
    type's :class:`.kinds.Motion`.
    """
    motion = TYPES[mtype].motion if mtype in TYPES else Motion.NONE
    if motion not in _BUILDERS:
        raise ValueError(f"{mtype!r} is not a kinematic mate type")
    j = _BUILDERS[motion](parent, child, f_parent, f_child, label, limits=limits, cone=cone,
                          angle_limits=angle_limits, home=home)
    j.mtype = mtype
    return j


def _slide_turn(parent: Any, child: Any, f_parent: Location, f_child: Location, label: str, *,
                limits: tuple[float, float] | None, angle_limits: tuple[float, float] | None,
                home: tuple[float, float], **_: Any) -> KinematicJoint:
    if limits is None:
        raise ValueError("a cylindrical joint needs limits")
    from build123d import Box
    carrier = Box(1, 1, 1)  # massless stand-in for the slide's moving side; never exported
    slide = _slide(parent, carrier, f_parent, Location(), f"{label}@slide", limits=limits)
    slide.joint.connect_to(slide.child, position=float(home[0]))
    turn = _turn(carrier, child, Location(), f_child, f"{label}@turn", limits=angle_limits)
    return KinematicJoint("", slide.joint, slide.child, label, limits, None, 0.0, turn,
                          angle_limits, Motion.SLIDE_TURN)


def _world_axis(parent: Any, f_parent: Location) -> tuple[Location, Any, Any]:
    world = parent.location * f_parent  # build123d joints take world locations at creation
    origin = world.position
    return world, origin, (world * Location((0, 0, 1))).position - origin


def _turn(parent: Any, child: Any, f_parent: Location, f_child: Location, label: str, *,
          limits: tuple[float, float] | None, **_: Any) -> KinematicJoint:
    _world, origin, z_dir = _world_axis(parent, f_parent)
    lo, hi = limits if limits is not None else (-math.inf, math.inf)
    probe = RevoluteJoint(f"{label}@probe", parent, axis=Axis(origin, z_dir))
    rel = f_parent.inverse() * probe.relative_axis.location
    del parent.joints[f"{label}@probe"]
    m = rel.wrapped.Transformation()
    offset = math.degrees(math.atan2(m.Value(2, 1), m.Value(1, 1)))
    joint = RevoluteJoint(label, parent, axis=Axis(origin, z_dir),
                          angular_range=(lo - offset, hi - offset))
    child_frame = child.location * f_child
    return KinematicJoint("", joint, RigidJoint(f"{label}@child", child, joint_location=child_frame),
                          label, limits, None, offset, motion=Motion.TURN)


def _slide(parent: Any, child: Any, f_parent: Location, f_child: Location, label: str, *,
           limits: tuple[float, float] | None, **_: Any) -> KinematicJoint:
    if limits is None:
        raise ValueError("a prismatic joint needs limits")
    _world, origin, z_dir = _world_axis(parent, f_parent)
    joint = LinearJoint(label, parent, axis=Axis(origin, z_dir), linear_range=limits)
    carrier = child.location * f_child * _rotation_only(f_parent).inverse()
    return KinematicJoint("", joint, RigidJoint(f"{label}@child", child, joint_location=carrier),
                          label, limits, motion=Motion.SLIDE)


def _ball(parent: Any, child: Any, f_parent: Location, f_child: Location, label: str, *,
          cone: float | None, **_: Any) -> KinematicJoint:
    world, _, _ = _world_axis(parent, f_parent)
    c = float(cone if cone is not None else 180.0)
    joint = BallJoint(label, parent, joint_location=world,
                      angular_range=((-c, c), (-c, c), (-180.0, 180.0)))
    child_frame = child.location * f_child
    return KinematicJoint("", joint, RigidJoint(f"{label}@child", child, joint_location=child_frame),
                          label, None, c, motion=Motion.BALL)


#: The build123d joint of each kinematic motion.
_BUILDERS: dict[Motion, Callable[..., KinematicJoint]] = {
    Motion.TURN: _turn, Motion.SLIDE: _slide, Motion.BALL: _ball, Motion.SLIDE_TURN: _slide_turn}


__all__ = ["KinematicJoint", "kinematic", "rigid_place"]
