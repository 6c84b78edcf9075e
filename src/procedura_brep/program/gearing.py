"""Transmission geometry for programs: spur and ring gears, racks, lead screws, nuts, pulleys.

The names below are the program vocabulary (``from procedura_brep.program import *`` binds
them); a program calls them inside a part and gets a build123d ``Part`` around the part's own
origin: axis +Z, the pitch circle centred at the origin, the face width centred on z = 0 (a
rack: its pitch line on the X axis, teeth towards +Y). They are pure functions of their numbers
(cache friendly) and record nothing: the ratio a coupling uses comes only from the
``couple(...)`` params, and the coupling gate (``gates/coupling.py``) measures the teeth back
from the solid.

Libraries (measured in ``benchmarks/gears.py``): involute gears, ring gears and racks from
py_gearworks 0.0.24 (one tooth family, so a pinion meshes its ring and its rack; a ``backlash``
parameter; z = 60 in 0.10 s against bd_warehouse's 0.43 s; Apache-2.0); threads are one
helical sweep of a trapezoid fused to the core (faster than bd_warehouse's per-turn
``Thread``, see the benchmark). The library's modules are never handed to a program: only
these wrappers are.

Tooth phase: a spur gear has a tooth centred on +X, a ring gear a tooth space on +X, a rack a
tooth centred on x = 0. ``phase`` turns (or, for a rack, shifts) the teeth by that many tooth
pitches, so two gears whose frames face each other along X mesh when the second one's tooth
count is odd with ``phase=0``, and with ``phase=0.5`` when it is even.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from ..errors import ProceduraError


class GearingError(ProceduraError, ValueError):
    """A transmission helper was given an unusable size (the message names the helper, the
    argument, its value and the allowed range)."""

#: Fewest teeth a gear helper accepts (below it an involute pinion undercuts badly).
MIN_TEETH: int = 6
#: Most teeth (and thread turns) a helper builds: beyond it the solid's faces run into the
#: sandbox's size caps after minutes of work, so the helper refuses at once.
MAX_TEETH: int = 400
#: Default tooth thinning on the pitch circle, as a fraction of the module (per gear): a pair
#: of gears with the default has a circular backlash of 0.08 m.
BACKLASH_PER_MODULE: float = 0.04
#: Tooth proportions (ISO 53 basic rack): addendum 1 m; dedendum 1.2 m (py_gearworks' default).
ADDENDUM: float = 1.0
DEDENDUM: float = 1.2


def _number(fn: str, name: str, value: Any, *, above: float | None = 0.0,
            at_least: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise GearingError(f"{fn}: {name} must be a finite number, got {value!r:.40}")
    if above is not None and not value > above:
        raise GearingError(f"{fn}: {name} must be > {above:g}, got {value:g}")
    if at_least is not None and value < at_least:
        raise GearingError(f"{fn}: {name} must be >= {at_least:g}, got {value:g}")
    return float(value)


def _teeth(fn: str, value: Any, name: str = "teeth") -> int:
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise GearingError(f"{fn}: {name} must be a whole number, got {value!r:.40}")
    if not MIN_TEETH <= value <= MAX_TEETH:
        raise GearingError(f"{fn}: {name} must be in [{MIN_TEETH}, {MAX_TEETH}], got {value}")
    return value


def _backlash(fn: str, backlash: Any, module: float) -> float:
    if backlash is None:
        return BACKLASH_PER_MODULE * module
    bl = _number(fn, "backlash", backlash, above=None, at_least=0.0)
    if bl > 0.5 * module:
        raise GearingError(f"{fn}: backlash must be <= half the module ({0.5 * module:g} mm), "
                         f"got {bl:g}")
    return bl


def _pressure(fn: str, pressure_angle: Any) -> float:
    pa = _number(fn, "pressure_angle", pressure_angle)
    if not 10.0 <= pa <= 35.0:
        raise GearingError(f"{fn}: pressure_angle must be in [10, 35] degrees, got {pa:g}")
    return math.radians(pa)


def spur_gear(module: float, teeth: int, width: float, *, bore: float = 0.0,
              pressure_angle: float = 20.0, backlash: float | None = None,
              phase: float = 0.0) -> Any:
    """An involute spur gear: axis +Z, pitch circle (radius ``module * teeth / 2``) centred at
    the origin, face width centred on z = 0, a tooth centred on +X (see ``phase``).

    Args:
        module: mm (> 0); the pitch diameter is ``module * teeth``.
        teeth: whole number, 6 .. 400.
        width: face width, mm (> 0).
        bore: diameter of a through bore, mm (0: none); must leave a rim of one module
            under the tooth roots.
        pressure_angle: degrees, 10..35 (20 standard).
        backlash: tooth thinning on the pitch circle, mm (default ``0.04 * module``); a pair's
            circular backlash is the sum of both gears'.
        phase: turn the teeth by this many tooth pitches (0.5: a space on +X).

    Example::

        @part(material="steel", description="20-tooth pinion, m 1.5")
        def pinion():
            return spur_gear(m, z_pinion, gear_w, bore=shaft_d)
    """
    fn = "spur_gear"
    m = _number(fn, "module", module)
    z = _teeth(fn, teeth)
    w = _number(fn, "width", width)
    b = _number(fn, "bore", bore, above=None, at_least=0.0)
    pa = _pressure(fn, pressure_angle)
    bl = _backlash(fn, backlash, m)
    ph = _number(fn, "phase", phase, above=None)
    root_d = m * (z - 2 * DEDENDUM)
    if b and b > root_d - 2 * m:
        raise GearingError(f"{fn}: bore {b:g} mm leaves less than one module under the tooth roots "
                         f"(root diameter {root_d:g} mm); at most {max(root_d - 2 * m, 0):g}")
    import py_gearworks as pgw  # type: ignore[import-untyped]

    gear = pgw.SpurGear(number_of_teeth=z, module=m, height=w, pressure_angle=pa,
                        backlash=bl / m, z_anchor=0.5, angle=2 * math.pi * ph / z)
    out = gear.build_part()
    if b:
        from build123d import Cylinder
        out = out - Cylinder(b / 2, w * 2)
    return _one_solid(fn, out)


def ring_gear(module: float, teeth: int, width: float, *, rim: float | None = None,
              pressure_angle: float = 20.0, backlash: float | None = None,
              phase: float = 0.0) -> Any:
    """An internal (ring) gear: teeth inside, axis +Z, pitch circle (radius
    ``module * teeth / 2``) centred at the origin, width centred on z = 0, a tooth space on +X.

    Args:
        module: mm (> 0).
        teeth: whole number >= 6 (a planet meshing inside needs fewer teeth than the ring).
        width: mm (> 0).
        rim: radial wall outside the tooth roots, mm (default ``3 * module``); the outer
            diameter is ``module * (teeth + 2.4) + 2 * rim``.
        pressure_angle: degrees, 10..35.
        backlash: tooth thinning on the pitch circle, mm (default ``0.04 * module``).
        phase: turn the teeth by this many tooth pitches.
    """
    fn = "ring_gear"
    m = _number(fn, "module", module)
    z = _teeth(fn, teeth)
    w = _number(fn, "width", width)
    r = 3 * m if rim is None else _number(fn, "rim", rim)
    pa = _pressure(fn, pressure_angle)
    bl = _backlash(fn, backlash, m)
    ph = _number(fn, "phase", phase, above=None)
    import py_gearworks as pgw

    gear = pgw.SpurRingGear(number_of_teeth=z, module=m, height=w, pressure_angle=pa,
                            backlash=bl / m, z_anchor=0.5, angle=2 * math.pi * ph / z,
                            outside_ring_coefficient=DEDENDUM + r / m)
    return _one_solid(fn, gear.build_part())


def rack(module: float, length: float, width: float, height: float, *,
         pressure_angle: float = 20.0, backlash: float | None = None, phase: float = 0.0) -> Any:
    """A straight involute rack: pitch line on the X axis, teeth towards +Y, a tooth centred
    on x = 0, face width centred on z = 0; a pinion of ``teeth`` at ``(x, module * teeth / 2)``
    with its axis along Z meshes it.

    Args:
        module: mm (> 0).
        length: mm along X; rounded to an odd number of teeth (pitch ``pi * module``, a
            tooth centred on x = 0), at least 2 pitches.
        width: face width along Z, mm (> 0).
        height: from the back face (``y = -height``) to the pitch line, mm; more than the
            dedendum plus half a module (``1.7 * module``).
        pressure_angle: degrees, 10..35.
        backlash: tooth thinning on the pitch line, mm (default ``0.04 * module``).
        phase: shift the teeth along +X by this many tooth pitches.
    """
    fn = "rack"
    m = _number(fn, "module", module)
    count = _number(fn, "length", length) / (math.pi * m)
    n = 2 * math.floor(count / 2) + 1  # the odd count nearest: a tooth is centred on x = 0
    if count > MAX_TEETH:
        raise GearingError(f"rack: length {length:g} mm holds {count:.0f} teeth of pitch "
                           f"{math.pi * m:.3g} mm; at most {MAX_TEETH}")
    if count < 2:
        raise GearingError(f"rack: length {length:g} mm holds fewer than 2 teeth of pitch "
                         f"{math.pi * m:.3g} mm (module {m:g}); at least {2 * math.pi * m:.3g}")
    w = _number(fn, "width", width)
    h = _number(fn, "height", height)
    if h <= (DEDENDUM + 0.5) * m:
        raise GearingError(f"rack: height {h:g} mm must exceed the dedendum plus half a module "
                         f"({(DEDENDUM + 0.5) * m:g} mm at module {m:g})")
    pa = _pressure(fn, pressure_angle)
    bl = _backlash(fn, backlash, m)
    ph = _number(fn, "phase", phase, above=None)
    import py_gearworks as pgw
    from build123d import Align, Box, Pos, Rot

    body = pgw.InvoluteRack(number_of_teeth=n, module=m, height=w, pressure_angle=pa,
                            backlash=bl / m).build_part()
    # py_gearworks: teeth along +X, the rack along Y with its (odd count: middle) reference
    # tooth on y = 0, z in [0, w]; turned so the teeth point to +Y and the rack runs along X
    body = Rot(Z=90) * Pos(0, 0, -w / 2) * body
    back = Box(n * math.pi * m, h - (DEDENDUM - 0.2) * m, w,
               align=(Align.CENTER, Align.MAX, Align.CENTER))
    body = body + Pos(0, -(DEDENDUM - 0.2) * m, 0) * back
    shift = ph * math.pi * m
    return _one_solid(fn, Pos(shift, 0, 0) * body)


def _thread_profile(lead: float) -> tuple[float, float, float]:
    """(depth, crest width, root width) of a 30-degree trapezoidal thread of pitch ``lead``
    (ISO 2904 proportions: depth P/2, crest 0.366 P)."""
    depth = 0.5 * lead
    crest = 0.366 * lead
    return depth, crest, crest + 2 * depth * math.tan(math.radians(15))


def _hand(fn: str, hand: Any) -> Literal["right", "left"]:
    if hand not in ("right", "left"):
        raise GearingError(f"{fn}: hand must be 'right' or 'left', got {hand!r:.40}")
    return "right" if hand == "right" else "left"


def _thread(root_r: float, apex_r: float, lead: float, length: float, hand: str) -> Any:
    """One helical trapezoidal thread from radius ``root_r`` (sunk 0.1 lead into the body it
    fuses with) to ``apex_r``: one swept solid, so the fuse with the core is one boolean
    (``benchmarks/gears.py``: 1.7 s against 14 s for bd_warehouse's per-turn ``Thread``).

    An external thread's ridge crosses +X at z = lead/2 + k lead; an internal one's (a nut's)
    at z = k lead, so a nut sits on its screw when their origins are a whole number of leads
    apart. The turns stay inside z = 0 .. length."""
    from build123d import Helix, Plane, Polygon, Pos, sweep

    depth, crest, root = _thread_profile(lead)
    sink = 0.1 * lead * (1 if apex_r > root_r else -1)
    r0 = root_r - sink
    profile = Plane.XZ * Polygon((r0, -root / 2), (apex_r, -crest / 2), (apex_r, crest / 2),
                                 (r0, root / 2), align=None)
    inner = apex_r < root_r
    path = Helix(pitch=lead, height=length - (2 if inner else 1) * lead, radius=r0,
                 lefthand=hand == "left")
    return Pos(0, 0, lead if inner else lead / 2) * sweep(profile, path=path, is_frenet=True)


def lead_screw(diameter: float, lead: float, length: float, *,
               hand: Literal["right", "left"] = "right") -> Any:
    """A single-start trapezoidal lead screw: axis +Z from z = 0 to ``length``, major diameter
    ``diameter``, advancing ``lead`` mm per turn.

    Args:
        diameter: major (outside) diameter, mm (> 0).
        lead: mm per turn (> 0, at most a third of the diameter).
        length: mm (> 2 leads).
        hand: ``"right"`` or ``"left"``.
    """
    fn = "lead_screw"
    d = _number(fn, "diameter", diameter)
    p = _number(fn, "lead", lead)
    n = _number(fn, "length", length)
    h = _hand(fn, hand)
    if p > d / 3:
        raise GearingError(f"lead_screw: lead {p:g} mm is more than a third of the diameter "
                           f"{d:g} mm; at most {d / 3:.3g}")
    if not 2 * p < n <= MAX_TEETH * p:
        raise GearingError(f"lead_screw: length {n:g} mm must be more than two leads and at most "
                           f"{MAX_TEETH} ({2 * p:g} .. {MAX_TEETH * p:g} mm at lead {p:g})")
    from build123d import Align, Cylinder

    depth = _thread_profile(p)[0]
    core = Cylinder(d / 2 - depth, n, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return _one_solid(fn, core + _thread(d / 2 - depth, d / 2, p, n, h))


def lead_nut(diameter: float, lead: float, length: float, *, outer: float | None = None,
             clearance: float = 0.1, hand: Literal["right", "left"] = "right") -> Any:
    """The nut of :func:`lead_screw` (same ``diameter``, ``lead`` and ``hand``): a round body
    on axis +Z from z = 0 to ``length`` with the internal thread, ``clearance`` mm radial play.

    Args:
        diameter: the screw's major diameter, mm.
        lead: mm per turn.
        length: mm (> 2 leads).
        outer: outside diameter, mm (default ``2 * diameter``).
        clearance: radial play, mm (>= 0).
        hand: ``"right"`` or ``"left"``.
    """
    fn = "lead_nut"
    d = _number(fn, "diameter", diameter)
    p = _number(fn, "lead", lead)
    n = _number(fn, "length", length)
    c = _number(fn, "clearance", clearance, above=None, at_least=0.0)
    o = 2 * d if outer is None else _number(fn, "outer", outer)
    h = _hand(fn, hand)
    if p > d / 3:
        raise GearingError(f"lead_nut: lead {p:g} mm is more than a third of the diameter "
                           f"{d:g} mm; at most {d / 3:.3g}")
    if not 2 * p < n <= MAX_TEETH * p:
        raise GearingError(f"lead_nut: length {n:g} mm must be more than two leads and at most "
                           f"{MAX_TEETH} ({2 * p:g} .. {MAX_TEETH * p:g} mm at lead {p:g})")
    if o <= d + 2 * c + p:
        raise GearingError(f"lead_nut: outer {o:g} mm leaves no wall around the thread; more "
                           f"than {d + 2 * c + p:g}")
    from build123d import Align, Cylinder

    depth = _thread_profile(p)[0]
    z0 = (Align.CENTER, Align.CENTER, Align.MIN)
    body = Cylinder(o / 2, n, align=z0) - Cylinder(d / 2 + c, n, align=z0)
    return _one_solid(fn, body + _thread(d / 2 + c, d / 2 - depth + c, p, n, h))


def pulley(width: float, *, teeth: int | None = None, diameter: float | None = None,
           pitch: float = 2.0, bore: float = 0.0, flange: float = 1.0) -> Any:
    """A belt pulley on axis +Z, width centred on z = 0, with a flange on each side: a timing
    pulley of ``teeth`` grooves at belt ``pitch`` (pitch diameter ``teeth * pitch / pi``), or a
    smooth one of pitch ``diameter``. Give exactly one of ``teeth`` and ``diameter``.

    Args:
        width: belt width, mm (> 0); the flanges add ``flange`` mm on each side.
        teeth: whole number >= 6 (a timing pulley).
        diameter: pitch diameter of a smooth pulley, mm.
        pitch: belt pitch of a timing pulley, mm (2: GT2).
        bore: through bore diameter, mm (0: none).
        flange: flange thickness, mm (> 0); flanges stand one pitch above the pitch circle.
    """
    fn = "pulley"
    w = _number(fn, "width", width)
    f = _number(fn, "flange", flange)
    b = _number(fn, "bore", bore, above=None, at_least=0.0)
    if (teeth is None) == (diameter is None):
        raise GearingError("pulley: give exactly one of teeth= (a timing pulley) and diameter= "
                         "(a smooth one)")
    from build123d import Cylinder, PolarLocations, Pos

    if teeth is not None:
        z = _teeth(fn, teeth)
        p = _number(fn, "pitch", pitch)
        pd = z * p / math.pi
        od = pd - 0.508 * p / 2.0  # the belt's pitch line sits outside the tips (GT2: 0.254)
        body = Cylinder(od / 2, w)
        groove = Cylinder(0.3 * p, w * 2)
        body = body - [loc * groove for loc in PolarLocations(od / 2, z)]
    else:
        pd = _number(fn, "diameter", diameter)
        body = Cylinder(pd / 2, w)
        p = _number(fn, "pitch", pitch)
    fr = pd / 2 + p
    body = body + Pos(0, 0, (w + f) / 2) * Cylinder(fr, f) + Pos(0, 0, -(w + f) / 2) * Cylinder(fr, f)
    if b:
        if b >= pd - 2 * p:
            raise GearingError(f"pulley: bore {b:g} mm leaves no rim inside the pitch diameter "
                             f"{pd:.3g} mm; at most {pd - 2 * p:.3g}")
        body = body - Cylinder(b / 2, w + 4 * f)
    return _one_solid(fn, body)


def _one_solid(fn: str, shape: Any) -> Any:
    """``shape`` as one build123d Part, or a GearingError when the library gave something else."""
    from build123d import Part

    solids = shape.solids()
    if len(solids) != 1:
        raise GearingError(f"{fn}: the geometry came out as {len(solids)} solids, not one; check "
                         f"the sizes (a bore or rim too large?)")
    return Part([solids[0]])


#: The names a program sees (``from procedura_brep.program import *``).
HELPERS: tuple[str, ...] = ("spur_gear", "ring_gear", "rack", "lead_screw", "lead_nut", "pulley")
