"""Feature macros: the male half added to the child and the female half cut from the parent.

Both halves of every mate derive from the one nominal ``d`` plus the resolved :class:`Fit`:
the male is sized from ``fit.shaft`` and the female from ``fit.hole``, so an edit to the nominal
param moves both halves together. Shapes are built in the **mate frame** (origin on the mating
plane, +Z from parent into child); the compiler moves them by the part's frame location.

This module imports build123d and runs only inside the sandboxed compile worker.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from build123d import Align, Box, Cylinder, Location, Part, Pos, Rot, Sphere, chamfer

from .fits import Fit, iso273
from .vocabulary import TYPES

TOP = (Align.CENTER, Align.CENTER, Align.MAX)  # hangs below z = 0
BOTTOM = (Align.CENTER, Align.CENTER, Align.MIN)
Halves = tuple[Part | None, Part | None]


def _relief(d: float) -> float:
    """Extra depth of a blind female feature so the male never bottoms out."""
    return max(0.2, 0.05 * d)


def _pin(dia: float, depth: float, tip: bool = True) -> Part:
    p = Cylinder(dia / 2, depth, align=TOP)
    if tip and depth > 0.3 * dia:
        p = chamfer(p.edges().group_by()[0], length=min(0.1 * dia, 0.25 * depth))
    return p


def _ring(count: int, pcd: float, angle0: float) -> list[Location]:
    return [Rot(0, 0, angle0 + 360.0 * i / count) * Pos(pcd / 2, 0, 0) for i in range(count)]


def peg(d: float, fit: Fit, o: dict[str, Any], *, default_depth: float = 0.5) -> Halves:
    depth = o.get("depth") or default_depth * d
    return _pin(fit.shaft, depth), Cylinder(fit.hole / 2, depth + _relief(d), align=TOP)


def press_fit(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    return peg(d, fit, o, default_depth=0.75)


def seat_face(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    depth = o.get("depth") or max(0.5, 0.08 * d)
    # the counterbore is deeper than the pad (a relief), so the pad alone never bears: the
    # child's face around it must seat on the parent's face
    return Cylinder(fit.shaft / 2, depth, align=TOP), Cylinder(fit.hole / 2, depth + _relief(d), align=TOP)


def bolt_pattern(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    pcd = o.get("pcd") or 4.0 * d
    length = o.get("length") or 1.5 * d
    count = o["count"]
    locs = [Rot(0, 0, 0)] if count == 1 else _ring(count, pcd, o.get("angle0", 0.0))
    studs = [loc * _pin(d, length) for loc in locs]
    holes = [loc * Cylinder(fit.hole / 2, length + _relief(d), align=TOP) for loc in locs]
    return Part() + studs, Part() + holes


def flange(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    h = max(0.5, 0.06 * d)
    male = Cylinder(fit.shaft / 2, h, align=TOP)
    female = Cylinder(fit.hole / 2, h + _relief(d) * 0.5, align=TOP)
    bolt = o.get("bolt") or _bolt_for(d)
    hole = iso273(bolt, "clearance" if fit.fit == "clearance" else "location")
    pcd = o.get("pcd") or 1.5 * d
    length = 1.5 * bolt
    for loc in _ring(o["count"], pcd, o.get("angle0", 0.0)):
        male += loc * _pin(bolt, length)
        female += loc * Cylinder(hole.hole / 2, length + _relief(bolt), align=TOP)
    return male, female


def _bolt_for(d: float) -> float:
    from .fits import ISO273_MM
    target = max(1.6, d / 10.0)
    return min(ISO273_MM, key=lambda s: abs(s - target))


def tab_slot(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    t = o.get("thickness") or 0.25 * d
    depth = o.get("depth") or 0.6 * d
    gap = fit.offset  # per side, signed
    tab = Box(d - gap, t - gap, depth, align=TOP)
    slot = Box(d + gap, t + gap, depth + _relief(d), align=TOP)
    return tab, slot


def lip_rabbet(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    w = o.get("wall") or max(0.8, 0.06 * d)
    depth = o.get("depth") or max(0.5, 0.1 * d)
    g = fit.offset
    lip = Cylinder(d / 2 - g / 2, depth, align=TOP) - Cylinder(d / 2 - w + g / 2, depth, align=TOP)
    outer = d / 2 + g / 2
    inner = d / 2 - w - g / 2
    groove = (Cylinder(outer, depth + _relief(d) * 0.5, align=TOP)
              - Cylinder(inner, depth + _relief(d) * 0.5, align=TOP))
    return lip, groove


def snap_tab(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    depth = o.get("depth") or 0.8 * d
    t = max(0.6, 0.12 * d)
    catch = fit.interference  # the hook's preload into the window wall, per side
    beam = Box(d, t, depth, align=TOP)
    hook_h = max(0.4, 0.15 * depth)
    hook = Pos(0, t / 2, -depth + hook_h / 2) * Box(d, 2 * catch, hook_h)
    window = Box(d + 0.2, t, depth + _relief(d), align=TOP)
    return beam + hook, window


def key(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    length = o.get("length") or 3.0 * d
    g = fit.offset
    male = Box(d - g, length, d)  # half below the mating plane, half in the child
    # The keyway reaches up through the key's upper half too: on a curved seat (a key in a bore)
    # the parent's surface rises above the tangent plane beside the frame, and that crescent
    # would otherwise hold the key's corners (4 mm key in a 30 mm bore: 0.134 mm deep).
    depth = d / 2 + _relief(d) * 0.5
    female = Pos(0, 0, d / 2) * Box(d + g, length + g, depth + d / 2, align=TOP)
    return male, female


def revolute(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    depth = o.get("depth") or 1.0 * d
    return _pin(fit.shaft, depth), Cylinder(fit.hole / 2, depth + _relief(d), align=TOP)


def prismatic(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    depth = o.get("depth") or 2.0 * d
    lo = min(0.0, o["limits"][0])
    bar = Box(fit.shaft, fit.shaft, depth, align=TOP)
    slot = Box(fit.hole, fit.hole, depth - lo + _relief(d), align=TOP)
    return bar, slot


def cylindrical(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    """A round shaft of diameter d (``fit.shaft``) in a bore deep enough for the travel."""
    depth = o.get("depth") or 2.0 * d
    lo = min(0.0, o["limits"][0])
    return (_pin(fit.shaft, depth),
            Cylinder(fit.hole / 2, depth - lo + _relief(d), align=TOP))


def spherical(d: float, fit: Fit, o: dict[str, Any]) -> Halves:
    return Sphere(fit.shaft / 2), Sphere(fit.hole / 2)


#: Every feature macro by function name; a mate type names its own (``MateType.macro``).
MACROS: dict[str, Callable[[float, Fit, dict[str, Any]], Halves]] = {f.__name__: f for f in (
    bolt_pattern, peg, seat_face, flange, tab_slot, press_fit, lip_rabbet, snap_tab, key,
    revolute, prismatic, spherical, cylindrical)}


def macro(mtype: str) -> Callable[[float, Fit, dict[str, Any]], Halves]:
    """The feature macro of mate type ``mtype`` (the one its :class:`.vocabulary.MateType`
    names)."""
    return MACROS[TYPES[mtype].macro]


#: Half a turn about the mate frame's X: the mating plane's mirror (z -> -z, y -> -y).
FLIP = Rot(180, 0, 0)


def build(mtype: str, d: float, fit: Fit, options: dict[str, Any]) -> Halves:
    """(male, female) for a mate of type ``mtype``, in mate-frame coordinates, or (None, None).

    With ``male="parent"`` both halves are turned half a turn about the frame's X axis, so the
    male stands up into the child (+Z) and the female is cut upwards into the child; every
    macro is symmetric under that turn apart from the side it points to.
    """
    if not options.get("features", True):
        return None, None
    male, female = macro(mtype)(d, fit, options)
    if male_side(options) == "parent":
        male = None if male is None else FLIP * male
        female = None if female is None else FLIP * female
    return male, female


def male_side(options: dict[str, Any]) -> str:
    """``"child"`` or ``"parent"``: which part the male half is added to."""
    return str(options.get("male") or "child")


def sides(child: str, parent: str, options: dict[str, Any]) -> tuple[str, str]:
    """(the part that gets the male half, the part the female half is cut from)."""
    return (parent, child) if male_side(options) == "parent" else (child, parent)


__all__ = ["MACROS", "build", "macro", "male_side", "sides"]
