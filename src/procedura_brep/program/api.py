"""The program API: what a program (and the model writing it) imports.

A program starts with ``from procedura_brep.program import *``, which brings in build123d's
modelling vocabulary (solids, sketches, operations, ``Location``, ``Axis``, ``Align`` ...),
``math``, and the declarations below (``material``, ``part``, ``paint``, ``frames``, ``mate``,
``couple``).
File import/export functions are *not* exported:
programs never touch files.

Example (a complete two-part program)::

    from procedura_brep.program import *

    # === params ===
    base_w = 120.0  # mm, base side
    base_t = 12.0   # mm, base thickness
    post_d = 20.0   # mm, post diameter
    post_h = 80.0   # mm
    spigot_d = 12.0  # mm, spigot under the post (smaller: its shoulder seats): nominal of the peg_socket

    # === helpers ===

    # === parts ===
    material("post_paint", base="painted_steel", rgb=(0.1, 0.3, 0.8), roughness=0.4)

    @part(detail="silhouette", material="cast_iron", description="square base")
    def base():
        b = Box(base_w, base_w, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
        return fillet(b.edges().filter_by(Axis.Z), radius=6)

    @part(detail="major", material="post_paint", description="post on the base centre")
    def post():
        return Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

    # === frames ===
    frames("base", top=Location((0, 0, base_t)))
    frames("post", foot=Location((0, 0, 0)))

    # === assembly ===
    mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")
"""

from __future__ import annotations

import inspect
from typing import Any, Callable

from ..errors import MateError, ProgramFormatError
from .registry import DETAILS, CoupleDecl, MateDecl, PaintDecl, PartDecl, active

#: Most disconnected solids a part may declare (``@part(pieces=N)``).
MAX_PIECES: int = 1000


def material(name: str, *, base: str | None = None, rgb: tuple[float, float, float] | None = None,
             roughness: float | None = None, metalness: float | None = None,
             density: float | None = None, material_class: str | None = None,
             wear: float | None = None) -> None:
    """Declare a PBR material of this program (a module-level call at the top of the parts
    section); parts then name it in ``@part(material=...)`` like a built-in one.

    Args:
        name: snake_case, not a built-in material's name.
        base: a built-in (or earlier declared) material whose values the others override;
            without it, ``rgb``, ``roughness``, ``metalness``, ``density`` and
            ``material_class`` are all required.
        rgb: base colour (albedo), three numbers each in [0, 1] (sRGB).
        roughness: 0 mirror .. 1 matte, in [0, 1].
        metalness: 0 dielectric .. 1 metal, in [0, 1].
        density: kg/m^3, in ``config.MATERIAL.density_range`` (1 .. 25000); masses follow.
        material_class: one of metal, polymer, elastomer, ceramic, composite, wood, glass.
        wear: 0 new .. 1 worn, in [0, 1] (default 0, or the base's).

    Example::

        material("hull_paint", base="painted_steel", rgb=(0.8, 0.1, 0.1), roughness=0.4, wear=0.2)
        material("tyre_rubber", rgb=(0.05, 0.05, 0.05), roughness=0.9, metalness=0.0,
                 density=1150, material_class="elastomer")
    """
    values = {"base": base, "rgb": rgb, "roughness": roughness, "metalness": metalness,
              "density": density, "material_class": material_class, "wear": wear}
    active().add_material(name, _caller_line(), **values)


def part(*, detail: str = "major", material: str = "steel", description: str = "",
         pieces: int = 1, mass: float | None = None, hollow: float | None = None
         ) -> Callable[[Callable[[], Any]], Callable[[], Any]]:
    """Register a function as a part. The part's name is the function's name (snake_case).

    The function takes no arguments, reads params as globals, and returns one build123d solid
    (``Part``, ``Solid`` or a ``Compound`` of solids) in **part-local** coordinates. It never
    places itself: placement is solved from its mates.

    Args:
        detail: ``"silhouette"`` (the big shapes), ``"major"`` (major features) or ``"sub"``
            (small sub-features such as bolts and knobs).
        material: a material of the library: a built-in key (``steel``, ``aluminium``,
            ``rubber`` ...) or one the program declares with :func:`material`.
        description: one line: what the part is, its size and where it sits.
        pieces: how many disconnected solids the part is on purpose (default 1); any other
            detached piece is a gate finding.
        mass: what the part weighs, in kg (> 0), when its solid is not what it weighs (a
            box standing for a chassis full of air): the density is scaled so the part
            weighs this; centre of mass and inertia keep the solid's shape. A param may
            give it (``mass=chassis_kg``).
        hollow: the wall thickness in mm (> 0) of a part that is a shell (a casting, a
            cover, a box chassis): it weighs as that shell of its material; the geometry
            stays the solid you return. Less than half the part's thickness. At most one of
            ``mass`` and ``hollow``; neither: the part is solid.

    Example::

        @part(detail="major", material="rubber", description="120 mm tyre, 40 mm wide")
        def wheel_fl():
            tyre = Cylinder(wheel_d / 2, wheel_w) - Cylinder(hub_d / 2, wheel_w)
            return fillet(tyre.edges(), radius=4)
    """
    if detail not in DETAILS:
        raise ProgramFormatError(f"detail {detail!r} is not one of {', '.join(DETAILS)}")
    if isinstance(pieces, bool) or not isinstance(pieces, int) or not 1 <= pieces <= MAX_PIECES:
        raise ProgramFormatError(f"pieces={pieces!r} must be an integer in [1, {MAX_PIECES}]")
    if mass is not None and hollow is not None:
        raise ProgramFormatError(f"mass={mass!r:.40} and hollow={hollow!r:.40}: give one of them "
                                 f"(mass= says what the part weighs; hollow= makes it a shell)")
    mass_kg, wall_mm = _positive("mass", mass, "kg"), _positive("hollow", hollow, "mm")

    def register(fn: Callable[[], Any]) -> Callable[[], Any]:
        code = fn.__code__
        end = max((ln for _, _, ln in code.co_lines() if ln), default=code.co_firstlineno)
        active().add_part(PartDecl(fn.__name__, fn, detail, material, description,
                                   code.co_firstlineno, end, pieces, mass_kg, wall_mm))
        return fn

    return register


def paint(part_name: str, *, material: str, description: str = ""
          ) -> Callable[[Callable[[], Any]], Callable[[], Any]]:
    """Paint a region of a part in another material: a **colour block**. The block's name is
    the function's name (snake_case, unique among parts and blocks).

    The function takes no arguments and returns the REGION, a build123d solid in the painted
    part's **local** coordinates. At compile, after the part's mate features are applied, the
    block becomes ``part & region`` and the part becomes ``part - region``; several blocks of
    one part are cut in program order. The block is a part of the compiled model of its own
    (``block_of`` names the painted part): same placement and link as its part, its own
    material in every export; it has no frames and no mates. Volume is conserved (checked
    within ``config.MATERIAL.paint_volume_rtol``). A region that misses the part, leaves it
    empty, or reaches into one of the part's mate features (a peg, a bore, a socket) is a
    finding naming the block.

    Args:
        part_name: the painted part (a ``@part`` function of the program).
        material: a material of the library, as in ``@part(material=...)``.
        description: one line (default: "<material> block of <part>").

    Example::

        @paint("wheel", material="rubber", description="the tyre band")
        def wheel_tyre():
            return Cylinder(80, 60) - Cylinder(70, 60)
    """
    if not isinstance(material, str):
        raise ProgramFormatError(f"paint material must be a material name, got {material!r:.40}")
    if not isinstance(description, str):
        raise ProgramFormatError("paint description must be a string")

    def register(fn: Callable[[], Any]) -> Callable[[], Any]:
        code = fn.__code__
        end = max((ln for _, _, ln in code.co_lines() if ln), default=code.co_firstlineno)
        active().add_paint(PaintDecl(fn.__name__, part_name, fn, material, description,
                                     code.co_firstlineno, end))
        return fn

    return register


def frames(part_name: str, **named: Any) -> None:
    """Publish named mate frames of a part, as ``Location``s in the part's local coordinates.

    A frame's origin lies on the mating surface and its +Z axis is the mate axis, pointing from
    the parent into the child. So a parent's frame points *out of* its surface and the child's
    frame points *into* the child's body; placement makes the two frames coincide.

    Example::

        frames("base", top=Location((0, 0, base_t)))             # +Z up, out of the top face
        frames("post", foot=Location((0, 0, 0)))                 # +Z up, into the post
        frames("arm", pivot=Location((7, 0, 0), (90, 0, 0)))     # hinge axis along -Y
    """
    line = _caller_line()
    for key, loc in named.items():
        if not hasattr(loc, "to_tuple") and not hasattr(loc, "wrapped"):
            raise ProgramFormatError(f"frame {part_name}.{key} must be a Location, got {type(loc).__name__}",
                                     line=line)
        if not _finite_location(loc):
            raise ProgramFormatError(f"frame {part_name}.{key} is not finite (NaN or infinite "
                                     f"position or rotation)", line=line)
    active().add_frames(part_name, named, line)


def mate(child: str, parent: str, type: str, *, nominal: str, fit: str | None = None,
         name: str | None = None, **options: Any) -> None:
    """Declare a mate joining ``"child_part.frame"`` to ``"parent_part.frame"``.

    The compiler adds the male feature to the child, cuts the female from the parent (both from
    the one nominal and the fit), and solves the child's placement. Declare mates in plan order:
    the parent must already be placed (the first part is the root).

    Args:
        child: ``"part.frame"`` of the new part.
        parent: ``"part.frame"`` of a part declared earlier.
        type: static ``bolt_pattern``, ``peg_socket``, ``seat_face``, ``flange``, ``tab_slot``,
            ``press_fit``, ``lip_rabbet``, ``snap_tab``, ``key``; kinematic ``revolute``,
            ``prismatic``, ``spherical``, ``cylindrical`` (slide plus turn on one axis).
        nominal: the NAME of the param holding the shared size d (a string such as
            ``"pin_d"``), never a number.
        fit: ``clearance`` | ``location`` | ``press`` | ``snap`` (default depends on the type).
        name: the mate's stable id (default ``<child part>_<child frame>``).
        **options: type-specific: ``count``, ``pcd``, ``depth``, ``limits=(lo, hi)``, ``home``,
            ``cone``, ``angle_limits``, ``effort``, ``velocity``, ``features=False``,
            ``male="parent"`` (the male
            half on the parent: a pulley on a shaft, so the shaft is not cut) ...

    Example::

        mate("post.foot", "base.top", "peg_socket", nominal="post_d", fit="location")
        mate("arm.pivot", "post.head", "revolute", nominal="pin_d", limits=(-60, 60))
        mate("jaw.slide", "body.rail", "prismatic", nominal="rail_w", limits=(0, 80))
    """
    line = _caller_line()
    if name is not None and not isinstance(name, str):
        raise ProgramFormatError(f"mate name must be a string, got {type(name).__name__}", line=line)
    cpart, cframe = _split(child, "child", line)
    ppart, pframe = _split(parent, "parent", line)
    mname = name or f"{cpart}_{cframe}"
    if not isinstance(nominal, str):
        raise MateError(mname, f"nominal must be a param name (a string such as 'pin_d'), "
                               f"not the literal {nominal!r}; add a param and pass its name")
    active().add_mate(MateDecl(mname, cpart, cframe, ppart, pframe, type, nominal, fit,
                               dict(options), line))


def couple(driven: str, driver: str, type: str, **named: Any) -> None:
    """Declare that the ``driven`` mate's joint follows the ``driver`` mate's joint: a
    transmission (both are kinematic mates declared in the assembly section).

    Every numeric input is the NAME of a param (a string), never a number, so one edit changes
    the geometry and the ratio together. The ratio and its sign are derived at compile from
    the params and the two joints' world axes (an external gear mesh reverses the sense).

    Args:
        driven: the mate whose joint follows (it gets no actuator of its own).
        driver: the mate whose joint drives it.
        type: ``gear`` (two revolutes; ``driver_teeth=``, ``driven_teeth=``, ``internal=False``:
            ``True`` for a ring gear), ``rack_pinion`` (a prismatic and a revolute, either
            order; ``pinion_teeth=``, ``module=``; pitch radius m z / 2; ``rack="part"`` names
            the rack part when it is not the slider), ``screw`` (driver revolute, driven
            prismatic; ``lead=`` in mm per turn, ``hand="right"|"left"``; ``nut="part"`` names the
            threaded nut when it is not the smallest part on the slide's side that the screw
            axis passes through), ``belt`` (two
            revolutes, same sense; ``driver_teeth=``/``driven_teeth=`` or
            ``driver_diameter=``/``driven_diameter=``), ``linkage`` (a closed loop: any two
            joints of the loop; ``closes="<mate>"`` names the loop's cut joint, a revolute or
            spherical mate whose child an earlier mate already placed; its frames must meet
            at the compiled pose; the loop's joints other than the driver follow it).

    Example::

        couple("wheel_axle", "pinion_axle", "gear", driver_teeth="z_pinion", driven_teeth="z_wheel")
        couple("carriage_slide", "screw_turn", "screw", lead="screw_lead", hand="right")
        couple("rocker_base", "crank_base", "linkage", closes="loop_pin")
    """
    from .couplings import check_keywords
    line = _caller_line()
    checked = check_keywords(driven, driver, type, named, line)
    active().add_coupling(CoupleDecl(driven, driver, type, checked, line))


def _positive(what: str, value: Any, unit: str) -> float | None:
    """A ``@part`` mass or wall: None, or a positive finite number (a param's value)."""
    import math
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or value <= 0:
        example = "body_kg" if what == "mass" else "wall_t"
        raise ProgramFormatError(f"{what}={value!r:.40} must be a positive number in {unit} "
                                 f"(or a param holding one, unquoted: {what}={example})")
    return float(value)


def _finite_location(loc: Any) -> bool:
    """False when a Location's transform holds a NaN or an infinity."""
    import math
    try:
        t = loc.wrapped.Transformation()
        return all(math.isfinite(t.Value(r, c)) for r in range(1, 4) for c in range(1, 5))
    except (AttributeError, TypeError, ValueError):
        return True  # not Location-like: refused when placed


def _split(ref: str, role: str, line: int | None) -> tuple[str, str]:
    if not isinstance(ref, str) or ref.count(".") != 1:
        raise ProgramFormatError(f"{role} must be 'part.frame', got {ref!r}", line=line)
    a, b = ref.split(".")
    return a, b


def _caller_line() -> int | None:
    frame = inspect.currentframe()
    try:
        f = frame.f_back.f_back if frame and frame.f_back else None
        while f is not None and f.f_code.co_filename != "<program>":
            f = f.f_back
        return f.f_lineno if f is not None else None
    finally:
        del frame
