"""Links and joints: static mates fuse parts into rigid links, kinematic mates are the joints.

Frames (all 4x4, millimetres, world coordinates unless named ``_local``):

* the root link's frame is the root part's world placement;
* every other link's frame is its joint's world frame (origin = anchor, +Z = axis), so the joint
  axis is +Z in the child link frame and the joint origin is the identity there.

Joint position 0 is the compiled pose; a mate's limits are shifted by its ``home`` value so that
the exported range is relative to that pose (see :func:`joint_limits`).

:class:`Articulation` is the one value every consumer takes: the URDF, MJCF and USD exporters and
the MuJoCo battery read the links, joints, drives, wheels and the base (``free`` or ``welded``)
from it and derive none of them again. :func:`articulate` builds it, once per compiled model,
from the model and (optionally) its geometric evidence (:func:`.evidence.mates_evidence`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from ..errors import ProceduraError
from ..mates.kinds import CONTINUOUS, PRISMATIC, REVOLUTE, Drive, JointKind, joint_kind
from ..mates.vocabulary import TYPES
from ..program.model import CompiledCoupling, CompiledMate, CompiledModel

log = logging.getLogger(__name__)

JointType = Literal["revolute", "continuous", "prismatic", "spherical", "cylindrical"]
DofType = Literal["revolute", "continuous", "prismatic"]
#: The root link: ``free`` (a free joint: a vehicle on its wheels) or ``welded`` to the world.
Base = Literal["free", "welded"]

#: Suffixes of a cylindrical joint's two exported joints (slide, then turn, on one axis).
SLIDE, TURN = "__slide", "__turn"


@dataclass(frozen=True)
class JointDof:
    """One exported 1-DOF joint: a revolute, continuous or prismatic joint is its own; a
    cylindrical joint has two on its axis, ``<name>__slide`` (prismatic) then ``<name>__turn``
    (revolute, or continuous without angle limits)."""

    name: str
    type: DofType
    lower: float | None
    upper: float | None
    effort: float
    velocity: float
    drive: Drive = "position"
    #: The joint that drives this one through a coupling ("" when it is actuated itself): a
    #: driven joint gets no actuator or drive of its own in any export.
    driver: str = ""

    @property
    def kind(self) -> JointKind:
        """What this joint is (:mod:`procedura_brep.mates.kinds`)."""
        return joint_kind(self.type)


@dataclass(frozen=True)
class Coupling:
    """A ``couple(...)`` as every export and the battery read it: ``q_driven = offset + ratio *
    q_driver`` on the exported joints (SI units, positions from the compiled pose, signs on the
    exported axes: a wheel turned half a turn by :mod:`.wheels` counts).

    Attributes:
        name: ``<driven>__<driver>``.
        type: gear, rack_pinion, screw or belt.
        driven, driver: the joint names.
        ratio: rad/rad, m/rad or rad/m.
        offset: rad or m (0: coupled joints mesh at the compiled pose).
        mesh: the links of the two parts that engage (``("", "")`` for a belt).
        source: the compiled coupling (its params and the ratio in rad and mm).
    """

    name: str
    type: str
    driven: str
    driver: str
    ratio: float
    offset: float
    mesh: tuple[str, str]
    source: CompiledCoupling = field(repr=False, compare=False)


@dataclass(frozen=True)
class Cut:
    """A linkage's cut joint: a kinematic mate that closes a loop, left out of the tree.

    Attributes:
        name: the mate name.
        type: its mate type (revolute or spherical).
        parent, child: the links it joins (its parent part's link, its child part's).
        frame: 4x4 world frame (mm) of its anchor at the compiled pose, where the loop meets.
        mate: the source mate.
    """

    name: str
    type: str
    parent: str
    child: str
    frame: np.ndarray = field(repr=False)
    mate: CompiledMate = field(repr=False, compare=False)

    @property
    def anchor_m(self) -> np.ndarray:
        """World anchor in metres."""
        return self.frame[:3, 3] / 1000.0


def default_drive(jtype: JointType | DofType) -> Drive:
    """The drive a joint of this type gets: velocity for a continuous turn, else position."""
    return joint_kind(jtype).default_drive


class ArticulationError(ProceduraError, ValueError):
    """The mate graph is not a tree rooted at the first part (a loop or a part joined to nothing)."""


@dataclass
class Link:
    """One rigid body: the parts fused by static mates.

    Attributes:
        name: the link name (its first part in plan order).
        parts: part names in plan order.
        frame: 4x4 world frame of the link (mm).
        parent_joint: name of the joint that moves it (None for the root).
    """

    name: str
    parts: list[str]
    frame: np.ndarray
    parent_joint: str | None = None


@dataclass
class Joint:
    """One kinematic mate as a joint between two links.

    Attributes:
        name: the mate name.
        type: revolute (limited), continuous (revolute without limits), prismatic, spherical.
        parent: parent link name.
        child: child link name.
        frame: 4x4 world joint frame (mm): origin = anchor, +Z = axis.
        lower, upper: limits relative to the compiled pose (rad for rotations, m for prismatic);
            None for continuous; spherical: the cone half-angle in rad as ``upper``.
        effort: N m or N.
        velocity: rad/s or m/s.
        mate: the source mate.
        flipped: a wheel whose frame was turned half a turn about X so that a positive command
            rolls it forward (its axis is then the mate frame's -Z; see :mod:`.wheels`).
        turn_lower, turn_upper: a cylindrical joint's angle limits relative to the compiled
            pose, rad (None: a free turn); ``lower``/``upper`` are its slide limits, m.
        torque, angular_velocity: a cylindrical joint's turning limits (N m, rad/s); ``effort``
            and ``velocity`` are its sliding ones (N, m/s).
        home: the mate's ``home`` (rad or m; a cylindrical joint's slide home, m), the position
            of the compiled pose on the mate's own scale (limits are relative to it).
        drive: how the joint is driven (a cylindrical joint: its slide; its turn is
            :func:`default_drive` of the turn's type).
    """

    name: str
    type: JointType
    parent: str
    child: str
    frame: np.ndarray
    lower: float | None
    upper: float | None
    effort: float
    velocity: float
    mate: CompiledMate = field(repr=False)
    flipped: bool = False
    turn_lower: float | None = None
    turn_upper: float | None = None
    torque: float = 0.0
    angular_velocity: float = 0.0
    home: float = 0.0
    drive: Drive = "position"
    coupling: Coupling | None = None

    @property
    def kind(self) -> JointKind:
        """What this joint is (:mod:`procedura_brep.mates.kinds`)."""
        return joint_kind(self.type)

    @property
    def driven(self) -> bool:
        """Moved by a coupling from another joint (no actuator of its own)."""
        return self.coupling is not None

    def dofs(self) -> list[JointDof]:
        """The 1-DOF joints this joint exports as (none for a spherical joint)."""
        kind = self.kind
        if kind.ball:
            return []
        if kind.compound:
            turn: DofType = (CONTINUOUS if self.turn_lower is None else REVOLUTE).name  # type: ignore[assignment]  # a JointKind's name is a DofType
            return [JointDof(self.name + SLIDE, PRISMATIC.name, self.lower, self.upper,  # type: ignore[arg-type]  # the kind's name is a DofType
                             self.effort, self.velocity, self.drive),
                    JointDof(self.name + TURN, turn, self.turn_lower, self.turn_upper,
                             self.torque, self.angular_velocity, default_drive(turn))]
        return [JointDof(self.name, self.type, self.lower, self.upper, self.effort,  # type: ignore[arg-type]  # the mate type's name is a DofType
                         self.velocity, self.drive,
                         self.coupling.driver if self.coupling is not None else "")]

    @property
    def anchor_m(self) -> np.ndarray:
        """World anchor in metres."""
        return self.frame[:3, 3] / 1000.0

    @property
    def axis(self) -> np.ndarray:
        """World unit axis."""
        a = self.frame[:3, 2]
        return a / np.linalg.norm(a)


@dataclass
class Articulation:
    """Links in tree order (root first), joints in the same order as their child links.

    Attributes:
        name: the model name.
        links: the rigid bodies, root first.
        joints: one per non-root link, in link order.
        part_link: part name -> the link it belongs to.
        wheels: the wheel joints (by evidence, :mod:`.wheels`), driven by one uniform command.
        couplings: the program's couplings on the exported joints (:class:`Coupling`); each
            driven joint's ``coupling`` is its entry here. A linkage is one entry per joint of
            its loop other than the driver (type ``linkage``, ratio 0: they follow passively).
        cuts: the linkages' cut joints (:class:`Cut`): kinematic mates left out of the tree,
            closed by the exports as a point constraint.
        base: ``free`` (a free root joint) or ``welded`` (fixed to the world); :func:`articulate`
            frees the base exactly when there are wheels. Exporters write this value as given.
    """

    name: str
    links: list[Link]
    joints: list[Joint]
    part_link: dict[str, str]
    wheels: list[str] = field(default_factory=list)
    base: Base = "welded"
    couplings: list[Coupling] = field(default_factory=list)
    cuts: list[Cut] = field(default_factory=list)

    @property
    def root(self) -> Link:
        return self.links[0]

    @property
    def free(self) -> bool:
        """Whether the root link has a free joint."""
        return self.base == "free"

    @property
    def wheel_links(self) -> list[str]:
        """The child links of the wheel joints."""
        return [self.joint(w).child for w in self.wheels]

    def welded(self) -> Articulation:
        """A copy with the base welded to the world (the battery's sweep scene)."""
        return replace(self, base="welded")

    def link(self, name: str) -> Link:
        for lk in self.links:
            if lk.name == name:
                return lk
        raise KeyError(f"no link named {name!r}; links: {', '.join(k.name for k in self.links)}")

    def joint(self, name: str) -> Joint:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(f"no joint named {name!r}; joints: {', '.join(j.name for j in self.joints)}")

    def children(self, link: str) -> list[Joint]:
        return [j for j in self.joints if j.parent == link]

    def subtree(self, link: str) -> list[str]:
        """``link`` and every link below it."""
        out = [link]
        for j in self.children(link):
            out.extend(self.subtree(j.child))
        return out

    def root_driver(self, joint: str) -> tuple[str, float, float]:
        """``(joint at the head of the chain, ratio, offset)`` with ``q_joint = offset + ratio *
        q_head``: a driven joint followed up its chain of couplings (a gear train) to the joint
        nobody drives (URDF's ``<mimic>`` names that one); an actuated joint is its own head, and
        so is a joint a linkage moves (no constant ratio)."""
        ratio, offset, cur = 1.0, 0.0, joint
        for _ in range(len(self.couplings) + 1):  # couplings have no cycle (compile checks)
            c = self.joint(cur).coupling
            if c is None or c.type == "linkage":
                break
            ratio, offset = ratio * c.ratio, offset + ratio * c.offset
            cur = c.driver
        return cur, ratio, offset

    def parent_of(self, link: str) -> str | None:
        lk = self.link(link)
        return None if lk.parent_joint is None else self.joint(lk.parent_joint).parent


def mate_option(mate: CompiledMate, key: str) -> float:
    """A numeric option of ``mate``: its value, or the type's default when it is absent or None.

    An explicit value is kept as given (``effort=0`` is refused at compile time by the option's
    range, never silently replaced: see :mod:`procedura_brep.mates.vocabulary`).
    """
    value = mate.options.get(key)
    if value is None:
        value = TYPES[mate.type].options[key].default
    return float(value)


def _kind(mate: CompiledMate) -> JointKind:
    kind = TYPES[mate.type].joint_kind(mate.options)
    if kind is None:
        raise ArticulationError(f"mate {mate.name!r} of type {mate.type!r} is not kinematic")
    return kind


def mate_home(mate: CompiledMate) -> float:
    """The mate's ``home`` in SI units (rad for a revolute, m for a prismatic or cylindrical
    slide; 0 for a spherical joint)."""
    kind = TYPES[mate.type].joint_kind(mate.options)
    if kind is None or kind.ball:
        return 0.0
    return kind.to_si(mate_option(mate, "home"))


def joint_limits(mate: CompiledMate) -> tuple[JointType, float | None, float | None]:
    """(type, lower, upper) in SI units relative to the compiled (home) pose."""
    kind = _kind(mate)
    if kind.ball:
        return kind.name, 0.0, kind.to_si(mate_option(mate, "cone"))  # type: ignore[return-value]  # a JointKind's name is a JointType
    if not kind.limited:
        return kind.name, None, None  # type: ignore[return-value]  # a JointKind's name is a JointType
    lim = mate.options.get("limits")
    if lim is None:
        raise ArticulationError(
            f"{mate.type} mate {mate.name!r} has no limits; give limits=(lo, hi) in mm")
    home = mate_option(mate, "home")
    return kind.name, kind.to_si(lim[0] - home), kind.to_si(lim[1] - home)  # type: ignore[return-value]  # a JointKind's name is a JointType


def _groups(model: CompiledModel) -> dict[str, str]:
    """Part name -> link name (first part of its group): static mates joined by
    :func:`procedura_brep.program.couplings.rigid_groups`, once every mate names a known part."""
    from ..program.couplings import rigid_groups
    names = {p.name for p in model.parts}
    for m in model.mates:
        if m.kind == "static":
            for end in (m.child, m.parent):
                if end not in names:
                    raise ArticulationError(f"mate {m.name!r} names unknown part {end!r}")
    return rigid_groups(model)


def articulate(model: CompiledModel, *, evidence: dict[str, Any] | None = None) -> Articulation:
    """The articulation of ``model``: the one place links, joints, drives, wheels and the base
    are decided.

    Static mates group parts into links, kinematic mates become joints (limits relative to
    ``home``, effort, velocity, the drive of :func:`default_drive`), the tree is checked, wheels
    are found by evidence (``evidence["parts"][name]["symmetry"]`` when given, else computed)
    and get one drive sign, and the base is free exactly when there are wheels.

    Raises:
        ArticulationError: no parts; a kinematic mate joining a link to itself or closing a loop;
            a part that no mate joins to the root.
    """
    if not model.parts:
        raise ArticulationError("the model has no parts; a program needs at least one part")
    part_link = _groups(model)
    root_name = part_link[model.parts[0].name]
    members: dict[str, list[str]] = {}
    for p in model.parts:
        members.setdefault(part_link[p.name], []).append(p.name)
    cut_names = {c.closes for c in model.couplings if c.type == "linkage"}
    kin = [m for m in model.mates if m.kind == "kinematic" and m.name not in cut_names]
    joints_by_child: dict[str, Joint] = {}
    for m in kin:
        for end in (m.child, m.parent):
            if end not in part_link:
                raise ArticulationError(f"mate {m.name!r} names unknown part {end!r}")
        c, p = part_link[m.child], part_link[m.parent]
        if c == p:
            raise ArticulationError(
                f"kinematic mate {m.name!r} joins {m.child!r} and {m.parent!r}, which static mates "
                f"already fuse into link {c!r}: a loop; remove one of the mates")
        if c in joints_by_child:
            raise ArticulationError(
                f"link {c!r} has two parent joints ({joints_by_child[c].name!r} and {m.name!r}): "
                f"a loop; remove one of the mates")
        jtype, lo, hi = joint_limits(m)
        joints_by_child[c] = Joint(
            name=m.name, type=jtype, parent=p, child=c, frame=np.asarray(m.world_frame, float),
            lower=lo, upper=hi, effort=mate_option(m, "effort"),
            velocity=mate_option(m, "velocity"), mate=m, home=mate_home(m),
            drive=default_drive(jtype))
        if joint_kind(jtype).compound:
            j = joints_by_child[c]
            alim = m.options.get("angle_limits")
            h = mate_option(m, "home_angle")
            if alim is not None:
                j.turn_lower, j.turn_upper = REVOLUTE.to_si(alim[0] - h), REVOLUTE.to_si(alim[1] - h)
            j.torque, j.angular_velocity = mate_option(m, "torque"), mate_option(m, "angular_velocity")
    # walk from the root
    root_frame = np.asarray(model.part(model.parts[0].name).placement, float)
    links = [Link(root_name, members[root_name], root_frame)]
    joints: list[Joint] = []
    seen = {root_name}
    queue = [root_name]
    while queue:
        cur = queue.pop(0)
        for child, j in joints_by_child.items():
            if j.parent != cur:
                continue
            if child in seen:
                raise ArticulationError(f"joint {j.name!r} closes a loop at link {child!r}")
            seen.add(child)
            links.append(Link(child, members[child], j.frame.copy(), parent_joint=j.name))
            joints.append(j)
            queue.append(child)
    orphans = [n for n in members if n not in seen]
    if orphans:
        names = ", ".join(f"{o!r} (parts {', '.join(members[o])})" for o in orphans)
        raise ArticulationError(
            f"not joined to the root {root_name!r}: {names}; add a mate from each to a part "
            f"declared before it")
    art = Articulation(model.name, links, joints, part_link)
    art.cuts = [Cut(m.name, m.type, part_link[m.parent], part_link[m.child],
                    np.asarray(m.world_frame, float), m)
                for m in model.mates if m.name in cut_names]
    _drive_wheels(model, art, evidence)
    art.base = "free" if art.wheels else "welded"
    _couple(model, art)
    log.debug("articulated %s: %d links, %d joints, wheels %s", model.name, len(links),
              len(joints), art.wheels)
    return art


def _drive_wheels(model: CompiledModel, art: Articulation,
                  evidence: dict[str, Any] | None) -> None:
    """Find the wheels and flip those that would roll backwards (see :mod:`.wheels`)."""
    from .wheels import find_wheels, flip, forward, rolling_direction
    art.wheels = find_wheels(model, {lk.name: lk.parts for lk in art.links}, art.joints, art.subtree,
                             evidence=evidence)
    driven = {c.driven for c in model.couplings}
    driven |= {j.name for cut in art.cuts for j in _loop(art, cut)}  # a loop's joints follow
    art.wheels = [w for w in art.wheels if w not in driven]  # a coupled wheel follows its driver
    if not art.wheels:
        return
    ahead = forward(art.root.frame, art.joint(art.wheels[0]).axis)
    for name in art.wheels:
        j = art.joint(name)
        if float(rolling_direction(j.axis) @ ahead) < 0:
            j.frame = flip(j.frame)
            j.flipped = True
            art.link(j.child).frame = j.frame.copy()


def _path_up(art: Articulation, link: str) -> list[str]:
    """``link`` and its ancestors up to the root."""
    out = [link]
    while (up := art.parent_of(out[-1])) is not None:
        out.append(up)
    return out


def _loop(art: Articulation, cut: Cut) -> list[Joint]:
    """The tree joints of the loop a cut closes: from each of its two links up to their common
    ancestor."""
    a, b = _path_up(art, cut.parent), _path_up(art, cut.child)
    common = next(x for x in a if x in b)
    links = a[:a.index(common)] + b[:b.index(common)]
    return [art.joint(str(art.link(lk).parent_joint)) for lk in links]


def _linkage(art: Articulation, c: CompiledCoupling) -> None:
    """A linkage's loop: every joint but the driver follows passively (one entry each)."""
    cut = next(x for x in art.cuts if x.name == c.closes)
    loop = _loop(art, cut)
    names = [j.name for j in loop]
    for role, name in (("driven", c.driven), ("driver", c.driver)):
        if name not in names:
            raise ArticulationError(f"coupling {c.name}: its {role} joint {name!r} is not on the loop "
                                    f"that {c.closes!r} closes ({', '.join(names)})")
    for j in loop:
        if j.name == c.driver:
            continue
        if j.coupling is not None:
            raise ArticulationError(f"coupling {c.name}: joint {j.name!r} of its loop is already "
                                    f"driven by {j.coupling.driver!r}")
        if j.kind.compound or j.kind.ball:
            raise ArticulationError(f"coupling {c.name}: a loop's joints are revolute or prismatic; "
                                    f"{j.name!r} is {j.type}")
        cp = Coupling(f"{j.name}__{c.driver}", "linkage", j.name, c.driver, 0.0, 0.0,
                      (cut.child, cut.parent), c)
        art.couplings.append(cp)
        j.coupling = cp


def _couple(model: CompiledModel, art: Articulation) -> None:
    """The model's couplings on the exported joints: SI ratio, the sign of a flipped wheel."""
    from ..program.couplings import si_ratio
    names = {j.name for j in art.joints}
    for c in model.couplings:
        if c.type == "linkage":
            _linkage(art, c)
            continue
        for role, name in (("driven", c.driven), ("driver", c.driver)):
            if name not in names:
                raise ArticulationError(f"coupling {c.name}: its {role} mate {name!r} is not a joint "
                                        f"of the articulation")
        driven, driver = art.joint(c.driven), art.joint(c.driver)
        if driven.coupling is not None:
            raise ArticulationError(f"coupling {c.name}: joint {c.driven!r} is already driven by "
                                    f"{driven.coupling.driver!r}")
        if driven.kind.compound or driven.kind.ball or driver.kind.compound or driver.kind.ball:
            raise ArticulationError(f"coupling {c.name}: only revolute and prismatic joints couple")
        sign = (-1.0 if driven.flipped else 1.0) * (-1.0 if driver.flipped else 1.0)
        offset = c.offset * (driven.kind.to_si(1.0) if driven.kind.slides else 1.0)  # mm -> m; rad stays
        link_of = art.part_link
        mesh = (link_of.get(c.mesh[0], ""), link_of.get(c.mesh[1], ""))
        cp = Coupling(c.name, c.type, c.driven, c.driver, sign * si_ratio(c, driven.mate.type, driver.mate.type),
                      offset, mesh, c)  # a driven joint is never a wheel: never flipped
        art.couplings.append(cp)
        driven.coupling = cp
