"""The closed mate vocabulary: nine static types and four kinematic ones.

Every type fixes its degree-of-freedom signature, the fit classes it accepts, and its options
(with defaults and allowed ranges), and is the one home of its behaviour: one class per family
(static :class:`MateType`, :class:`RevoluteType`, :class:`PrismaticType`, :class:`SphericalType`,
:class:`CylindricalType`) owns its motion, ``Delta``, home value, range check and joint kind
(:mod:`.kinds`: the URDF / MJCF / USD mapping), and names its feature macro. Callers ask the type
(``TYPES[name].motion``, ``.joint_kind(options)``, ...) and never compare type names. This module
is pure data plus validation (no numeric or CAD import); the geometry of each macro lives in
:mod:`procedura_brep.mates.features` and the ``Delta`` math in :mod:`procedura_brep.mates.placement`.

Frame convention: a mate frame's +Z is the mate axis and points from the parent into the child.
After placement the child's frame coincides with the parent's (same origin, same axes), offset
only by ``Delta``: a rotation about Z for ``revolute``, a translation along Z for ``prismatic``,
a rotation for ``spherical``; static types apply no axial offset (their fit offset is per-side,
radial or lateral, and is cut into the features).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal, cast

from ..errors import MateError
from .fits import FIT_CLASSES, Fit, FitClass, iso273, iso286
from .kinds import CONTINUOUS, CYLINDRICAL, PRISMATIC, REVOLUTE, SPHERICAL, JointKind, Motion

if TYPE_CHECKING:
    import numpy as np

MateKind = Literal["static", "kinematic"]


@dataclass(frozen=True)
class Option:
    """One type-specific option: default and allowed range (None = unbounded).

    The range is closed, ``[low, high]``, unless ``open_low``: then ``low`` itself is refused,
    ``(low, high]`` (an effort or a speed limit of 0 would be a joint that cannot move: a
    kinematic mate always moves; use a static mate for a part that must not).
    """

    default: Any
    low: float | None = None
    high: float | None = None
    integer: bool = False
    doc: str = ""
    open_low: bool = False
    choices: tuple[str, ...] = ()

    def admits(self, value: float) -> bool:
        """Whether ``value`` lies in the option's range."""
        if self.low is not None and (value < self.low or (self.open_low and value == self.low)):
            return False
        return self.high is None or value <= self.high

    def range_text(self) -> str:
        lo = "-inf" if self.low is None else f"{self.low:g}"
        hi = "inf" if self.high is None else f"{self.high:g}"
        return f"{'(' if self.open_low else '['}{lo}, {hi}]"


@dataclass(frozen=True)
class Dof:
    """Degree-of-freedom signature in the mate frame: free translation and rotation axes."""

    translation: tuple[str, ...] = ()
    rotation: tuple[str, ...] = ()

    @property
    def count(self) -> int:
        return len(self.translation) + len(self.rotation)

    def as_dict(self) -> dict[str, Any]:
        return {"count": self.count, "translation": list(self.translation),
                "rotation": list(self.rotation)}


@dataclass(frozen=True)
class MateType:
    """A mate type: name, kind, DOF signature, accepted fits and options, and its behaviour.

    This base class is the static family (0 DOF, identity ``Delta``, no joint); each kinematic
    family is a subclass that owns its motion, its ``Delta`` and home value, its range check and
    the joint kind it exports as (:mod:`.kinds`). ``macro`` names the feature macro of
    :mod:`.features` that builds its male and female halves (kept there: it needs build123d).
    """

    name: str
    kind: MateKind
    dof: Dof
    fits: tuple[FitClass, ...]
    default_fit: FitClass
    options: dict[str, Option] = field(default_factory=dict)
    table: Literal["iso286", "iso273"] = "iso286"
    doc: str = ""
    macro: str = ""
    pcd_factor: float | None = None

    #: What ``Delta`` moves (:class:`.kinds.Motion`).
    motion: ClassVar[Motion] = Motion.NONE
    #: Whether ``limits`` is required (a slide needs a travel).
    needs_limits: ClassVar[bool] = False

    def resolve_fit(self, nominal: float, fit: FitClass) -> Fit:
        """The resolved fit for ``nominal`` (mm) under this type's table."""
        return iso273(nominal, fit) if self.table == "iso273" else iso286(nominal, fit)

    def pcd(self, nominal: float, options: dict[str, Any]) -> float:
        """The pitch circle diameter (mm) of its ring of bolts or studs (0 without a ring): the
        ``pcd`` option, else ``pcd_factor`` times the nominal (as its feature macro); 0 for a
        single bolt (``count`` 1: on the frame axis)."""
        if self.pcd_factor is None or options.get("count") == 1:
            return 0.0
        return float(options.get("pcd") or self.pcd_factor * nominal)

    def joint_kind(self, options: dict[str, Any]) -> JointKind | None:
        """The articulation joint kind of a mate with ``options`` (None: a static mate, no joint)."""
        return None

    def home_value(self, options: dict[str, Any]) -> float | tuple[float, ...] | None:
        """The joint value at which the child is placed (None for a static mate)."""
        return None

    def delta(self, value: float | Sequence[float] | None = None) -> np.ndarray:
        """``Delta`` (4x4, mm) at joint value ``value`` (None: home/identity)."""
        from .motion import motion_delta
        return motion_delta(self.motion, value)

    def check_value(self, mate: str, value: float | Sequence[float], *,
                    limits: tuple[float, float] | None = None, cone: float | None = None,
                    angle_limits: tuple[float, float] | None = None) -> None:
        """Refuse a joint value outside its range (a static mate has none to check).

        Raises:
            RangeError: the value is outside the range; names the mate, the value and the range.
        """


@dataclass(frozen=True)
class _AxialType(MateType):
    """One DOF along or about frame Z: a scalar home and a range check in the kind's unit."""

    axial_kind: ClassVar[JointKind]

    def home_value(self, options: dict[str, Any]) -> float:
        return float(options.get("home") or 0.0)

    def check_value(self, mate: str, value: float | Sequence[float], *,
                    limits: tuple[float, float] | None = None, cone: float | None = None,
                    angle_limits: tuple[float, float] | None = None) -> None:
        from .motion import check_linear
        check_linear(f"{mate} ({self.name}) position", float(value), limits,  # type: ignore[arg-type]  # one DOF: a scalar
                     self.axial_kind.mate_unit)


@dataclass(frozen=True)
class RevoluteType(_AxialType):
    """A turn about frame Z: limited in degrees, or continuous without limits."""

    motion: ClassVar[Motion] = Motion.TURN
    axial_kind: ClassVar[JointKind] = REVOLUTE

    def joint_kind(self, options: dict[str, Any]) -> JointKind:
        return CONTINUOUS if options.get("limits") is None else REVOLUTE


@dataclass(frozen=True)
class PrismaticType(_AxialType):
    """A slide along frame Z, limits in millimetres (required)."""

    motion: ClassVar[Motion] = Motion.SLIDE
    needs_limits: ClassVar[bool] = True
    axial_kind: ClassVar[JointKind] = PRISMATIC

    def joint_kind(self, options: dict[str, Any]) -> JointKind:
        return PRISMATIC


@dataclass(frozen=True)
class SphericalType(MateType):
    """A ball about the frame origin, its tilt bounded by a cone (degrees)."""

    motion: ClassVar[Motion] = Motion.BALL

    def joint_kind(self, options: dict[str, Any]) -> JointKind:
        return SPHERICAL

    def home_value(self, options: dict[str, Any]) -> tuple[float, float, float]:
        return (0.0, 0.0, 0.0)

    def check_value(self, mate: str, value: float | Sequence[float], *,
                    limits: tuple[float, float] | None = None, cone: float | None = None,
                    angle_limits: tuple[float, float] | None = None) -> None:
        if cone is None:
            return
        from .motion import check_tilt
        check_tilt(f"{mate} ({self.name}) tilt", value, cone)  # type: ignore[arg-type]  # a ball's value: (rx, ry, rz)


@dataclass(frozen=True)
class CylindricalType(MateType):
    """A slide along and a turn about frame Z: values ``(z mm, angle deg)``."""

    motion: ClassVar[Motion] = Motion.SLIDE_TURN
    needs_limits: ClassVar[bool] = True

    def joint_kind(self, options: dict[str, Any]) -> JointKind:
        return CYLINDRICAL

    def home_value(self, options: dict[str, Any]) -> tuple[float, float]:
        return (float(options.get("home") or 0.0), float(options.get("home_angle") or 0.0))

    def check_value(self, mate: str, value: float | Sequence[float], *,
                    limits: tuple[float, float] | None = None, cone: float | None = None,
                    angle_limits: tuple[float, float] | None = None) -> None:
        from .motion import check_linear
        z, ang = (float(v) for v in value)  # type: ignore[union-attr]  # cylindrical: (z, angle), never a scalar
        check_linear(f"{mate} ({self.name}) position", z, limits, PRISMATIC.mate_unit)
        check_linear(f"{mate} ({self.name}) angle", ang, angle_limits, REVOLUTE.mate_unit)


_FEAT = Option(True, doc="build the male/female features (False: frames only)")
#: Which part carries the male half (``"parent"``: a pulley on a shaft, a nut on a rod, a collar
#: on a column: the male is added to the parent, the female cut from the child, so the shaft is
#: not drilled).
MALE_SIDES = ("child", "parent")
_MALE = Option("child", choices=MALE_SIDES,
               doc="which part carries the male half: child (default) or parent")
_DEPTH = Option(None, 0.1, 10000.0, doc="engagement depth along -Z, mm (default from nominal)")

STATIC_DOF = Dof()

TYPES: dict[str, MateType] = {t.name: t for t in [
    MateType("bolt_pattern", "static", STATIC_DOF, ("clearance", "location"), "clearance",
             {"count": Option(4, 1, 36, integer=True,
                              doc="number of bolts (1: a single bolt on the frame axis, pcd unused)"),
              "pcd": Option(None, 1.0, 5000.0, doc="pitch circle diameter, mm (default 4 d)"),
              "length": Option(None, 0.1, 5000.0, doc="stud length below the frame, mm (default 1.5 d)"),
              "angle0": Option(0.0, -360.0, 360.0, doc="angle of the first bolt from +X, deg"),
              "features": _FEAT, "male": _MALE},
             table="iso273",
             macro="bolt_pattern", pcd_factor=4.0,
             doc="studs of M-size d on the child through ISO 273 clearance holes in the parent"),
    MateType("peg_socket", "static", STATIC_DOF, ("clearance", "location", "press"), "location",
             {"depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="peg",
             doc="cylindrical peg of diameter d on the child in a blind socket in the parent"),
    MateType("seat_face", "static", STATIC_DOF, ("clearance", "location"), "location",
             {"depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="seat_face",
             doc="round seating pad of diameter d on the child in a spot-faced counterbore"),
    MateType("flange", "static", STATIC_DOF, ("clearance", "location"), "location",
             {"count": Option(6, 3, 36, integer=True, doc="number of flange studs"),
              "pcd": Option(None, 1.0, 5000.0, doc="stud pitch circle, mm (default 1.5 d)"),
              "bolt": Option(None, 1.6, 64.0, doc="stud M-size, mm (default from d)"),
              "angle0": Option(0.0, -360.0, 360.0, doc="angle of the first stud from +X, deg"),
              "features": _FEAT, "male": _MALE},
             macro="flange", pcd_factor=1.5,
             doc="pilot spigot of diameter d and height max(0.5, 0.06 d) mm plus a ring of studs "
                 "(M-size `bolt`, each 1.5 bolt long), all reaching along -Z from the frame into a "
                 "pilot recess and clearance holes in the parent"),
    MateType("tab_slot", "static", STATIC_DOF, ("clearance", "location", "press"), "location",
             {"thickness": Option(None, 0.1, 1000.0, doc="tab thickness, mm (default 0.25 d)"),
              "depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="tab_slot",
             doc="rectangular tab of width d along frame X and thickness along frame Y, reaching "
                 "depth along -Z from the frame into a matching slot in the parent"),
    MateType("press_fit", "static", STATIC_DOF, ("press", "location"), "press",
             {"depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="press_fit",
             doc="pin of diameter d pressed into an interference bore"),
    MateType("lip_rabbet", "static", STATIC_DOF, ("clearance", "location"), "location",
             {"wall": Option(None, 0.1, 1000.0, doc="lip wall thickness, mm (default 0.06 d)"),
              "depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="lip_rabbet",
             doc="annular lip of outer diameter d on the child in an annular groove"),
    MateType("snap_tab", "static", STATIC_DOF, ("snap",), "snap",
             {"depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="snap_tab",
             doc="cantilever tab of width d with a hook, preloaded into a window by the snap fit"),
    MateType("key", "static", STATIC_DOF, ("clearance", "location", "press"), "location",
             {"length": Option(None, 0.1, 5000.0, doc="key length along frame Y, mm (default 3 d)"),
              "features": _FEAT, "male": _MALE},
             macro="key",
             doc="square key of width d, half in the child, half in a keyway in the parent"),
    RevoluteType("revolute", "kinematic", Dof(rotation=("z",)), ("clearance", "location"), "clearance",
             {"limits": Option(None, -360.0, 360.0, doc="(lo, hi) deg, or None for continuous"),
              "home": Option(0.0, -360.0, 360.0, doc="angle at which the child is placed, deg"),
              "effort": Option(10.0, 0.0, 1e6, open_low=True, doc="max torque, N m (> 0)"),
              "velocity": Option(3.0, 0.0, 1e4, open_low=True, doc="max speed, rad/s (> 0)"),
              "depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="revolute",
             doc="1 rotational DOF about frame Z: a pin of diameter d in a bore"),
    PrismaticType("prismatic", "kinematic", Dof(translation=("z",)), ("clearance", "location"), "clearance",
             {"limits": Option(None, -10000.0, 10000.0, doc="(lo, hi) mm along frame Z, required"),
              "home": Option(0.0, -10000.0, 10000.0, doc="position at which the child is placed, mm"),
              "effort": Option(100.0, 0.0, 1e6, open_low=True, doc="max force, N (> 0)"),
              "velocity": Option(0.1, 0.0, 1e3, open_low=True, doc="max speed, m/s (> 0)"),
              "depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="prismatic",
             doc="1 translational DOF along frame Z: a square guide bar of side d reaching depth "
                 "along -Z into a slot that is deepened by the negative travel; positive values "
                 "move the child out along +Z, so keep the upper limit below depth or the bar "
                 "leaves its slot; the bar is centred on the frame's Z axis, so for a slide along a "
                 "face (a gripper finger across a palm) put the frame at least d/2 inside the parent "
                 "(for a long slide, use features=False and model the ways)"),
    SphericalType("spherical", "kinematic", Dof(rotation=("x", "y", "z")), ("clearance", "location"),
             "clearance",
             {"cone": Option(30.0, 0.1, 180.0, doc="cone half-angle limit, deg"),
              "effort": Option(10.0, 0.0, 1e6, open_low=True, doc="max torque, N m (> 0)"),
              "velocity": Option(3.0, 0.0, 1e4, open_low=True, doc="max speed, rad/s (> 0)"),
              "features": _FEAT, "male": _MALE},
             macro="spherical",
             doc="3 rotational DOF about the frame origin: a ball of diameter d in a socket"),
    CylindricalType("cylindrical", "kinematic", Dof(translation=("z",), rotation=("z",)),
             ("clearance", "location"), "clearance",
             {"limits": Option(None, -10000.0, 10000.0, doc="(lo, hi) mm along frame Z, required"),
              "angle_limits": Option(None, -360.0, 360.0,
                                     doc="(lo, hi) deg about frame Z, or None for a free turn"),
              "home": Option(0.0, -10000.0, 10000.0, doc="position at which the child is placed, mm"),
              "home_angle": Option(0.0, -360.0, 360.0, doc="angle at which the child is placed, deg"),
              "effort": Option(100.0, 0.0, 1e6, open_low=True, doc="max force along the axis, N (> 0)"),
              "torque": Option(10.0, 0.0, 1e6, open_low=True, doc="max torque about the axis, N m (> 0)"),
              "velocity": Option(0.1, 0.0, 1e3, open_low=True, doc="max sliding speed, m/s (> 0)"),
              "angular_velocity": Option(3.0, 0.0, 1e4, open_low=True, doc="max turning speed, rad/s (> 0)"),
              "depth": _DEPTH, "features": _FEAT, "male": _MALE},
             macro="cylindrical",
             doc="slide along and turn about frame Z (2 DOF): a round shaft of diameter d in a "
                 "bore deep enough for the travel (a collar on a column: male=\"parent\")"),
]}

STATIC_TYPES = tuple(n for n, t in TYPES.items() if t.kind == "static")
KINEMATIC_TYPES = tuple(n for n, t in TYPES.items() if t.kind == "kinematic")


def get_type(mate: str, name: str) -> MateType:
    """The type called ``name``, or a MateError listing the vocabulary."""
    if name not in TYPES:
        from ..text import did_you_mean
        raise MateError(mate, f"unknown mate type {name!r}{did_you_mean(name, TYPES)}; use one of: "
                              f"{', '.join(TYPES)}")
    return TYPES[name]


def check_options(mate: str, mtype: MateType, fit: str, options: dict[str, Any]) -> dict[str, Any]:
    """Validate ``fit`` and ``options`` for ``mtype``; return options with defaults filled in."""
    if fit not in FIT_CLASSES:
        from ..text import did_you_mean
        raise MateError(mate, f"fit {fit!r} is not a fit class{did_you_mean(fit, FIT_CLASSES)}; use one "
                              f"of: {', '.join(FIT_CLASSES)}")
    if fit not in mtype.fits:
        raise MateError(mate, f"a {mtype.name} mate takes fit {' or '.join(mtype.fits)}, not {fit!r}")
    unknown = sorted(set(options) - set(mtype.options))
    if unknown:
        raise MateError(mate, f"unknown option(s) {', '.join(unknown)} for {mtype.name}; "
                              f"allowed: {', '.join(mtype.options) or 'none'}")
    out: dict[str, Any] = {}
    for key, opt in mtype.options.items():
        value = options.get(key, opt.default)
        if key == "pcd" and options.get("count") == 1:
            out[key] = None  # one bolt sits on the frame axis: the documented "pcd unused"
            continue
        if key in ("limits", "angle_limits"):
            value = _check_limits(mate, mtype, value, key)
        elif key == "features":
            value = bool(value)
        elif opt.choices:
            if not isinstance(value, str) or value not in opt.choices:
                raise MateError(mate, f"option {key} = {value!r} must be one of: "
                                      f"{', '.join(opt.choices)}")
        elif value is not None:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise MateError(mate, f"option {key} must be a finite number, got {value!r}")
            if opt.integer and int(value) != value:
                raise MateError(mate, f"option {key} must be a whole number, got {value!r}")
            if not opt.admits(value):
                raise MateError(mate, f"option {key} = {value:g} is outside {opt.range_text()}")
            value = int(value) if opt.integer else float(value)
        out[key] = value
    if "home" in out and out.get("limits") is not None:
        lo, hi = out["limits"]
        if not lo <= out["home"] <= hi:
            raise MateError(mate, f"home = {out['home']:g} is outside its limits [{lo:g}, {hi:g}]")
    if "home_angle" in out and out.get("angle_limits") is not None:
        lo, hi = out["angle_limits"]
        if not lo <= out["home_angle"] <= hi:
            raise MateError(mate, f"home_angle = {out['home_angle']:g} is outside its angle_limits "
                                  f"[{lo:g}, {hi:g}]")
    return out


def _check_limits(mate: str, mtype: MateType, value: Any, key: str = "limits"
                  ) -> tuple[float, float] | None:
    if value is None:
        if key == "limits" and mtype.needs_limits:
            raise MateError(mate, f"a {mtype.name} mate needs limits=(lo, hi) in mm")
        return None
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise MateError(mate, f"{key} must be (lo, hi), got {value!r}") from None
    opt = mtype.options[key]
    low, high = cast(float, opt.low), cast(float, opt.high)  # every limits option has a range
    if not (lo < hi):
        raise MateError(mate, f"{key} ({lo:g}, {hi:g}) must have lo < hi")
    if lo < low or hi > high:
        raise MateError(mate, f"{key} ({lo:g}, {hi:g}) are outside [{low:g}, {high:g}]")
    return (lo, hi)
