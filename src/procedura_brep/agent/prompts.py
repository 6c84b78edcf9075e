"""Prompts are data: markdown templates next to this module, plus a reference generated from
the program API and the mate vocabulary (so the model sees exactly what the compiler accepts)."""

from __future__ import annotations

import inspect
from functools import lru_cache
from pathlib import Path
from typing import Any

PROMPTS = Path(__file__).parent / "prompts"


def template(name: str) -> str:
    return (PROMPTS / f"{name}.md").read_text(encoding="utf-8")


def part_format() -> str:
    """The five-block reply format of one part and its rules, as the build requests state them
    (build_system.md from "Reply with five blocks" up to its example): what an ``edit_part``
    reply must follow wherever the model never saw a build request (``revise``)."""
    text = template("build_system")
    start, end = text.index("Reply with five blocks"), text.index("\nExample")
    return text[start:end].strip()


@lru_cache(maxsize=1)
def reference() -> str:
    """The program API reference: docstrings of material/part/paint/frames/mate, mate types,
    materials."""
    from .. import materials
    from ..mates import TYPES
    from ..program import api
    out = ["## The program API", inspect.cleandoc(api.__doc__ or "")]
    for fn in (api.material, api.part, api.paint, api.frames, api.mate, api.couple):
        out.append(f"### {fn.__name__}{inspect.signature(fn)}\n{inspect.cleandoc(fn.__doc__ or '')}")
    out.append(gearing_reference())
    out.append("## Mate types (type: DOF; fits, default first; every option: default, range, meaning)")
    for t in TYPES.values():
        fits = ", ".join([t.default_fit] + [f for f in t.fits if f != t.default_fit])
        rows = [f"- {t.name} ({t.kind}, {t.dof.count} DOF): {t.doc}. fits: {fits}. options:"]
        rows += [f"    - {option_line(k, o)}" for k, o in t.options.items()]
        out.append("\n".join(rows))
    out.append(conventions())
    out.append("## Built-in materials (key: class, density kg/m^3; a part weighs its solid unless it "
               "declares @part(hollow=wall) or @part(mass=kg); declare others with material(...))\n"
               + ", ".join(
                   f"{m.name} ({m.material_class}, {m.density:g})" for m in materials.MATERIALS.values()))
    return "\n\n".join(out)


#: What the coupling gate checks, as the model's requests state it (docs/gates.md has the rest).
COUPLING_GATE = (
    "The coupling gate checks every couple(...) against the solids: it counts the teeth of the "
    "meshing parts from their geometry and compares them with the params couple(...) names (a "
    "ratio typed against the teeth fails), reads the module from the tip circle, and requires a "
    "gear pair's axis distance of (z1 + z2) * m / 2 (external) or (z2 - z1) * m / 2 (ring) within "
    "{centre:g} mm, a pinion's axis at m z / 2 from the rack's pitch line (the rack part's origin), "
    "a nut's slide axis on the screw's axis; then it sweeps the meshing pair over one tooth pitch "
    "and fails any teeth that interfere. So build gears with spur_gear / ring_gear / rack from the "
    "same params and place them by their pitch radii. Phase: a spur gear has a tooth on its +X, "
    "a ring gear a tooth space, a rack a tooth at x = 0; two gears facing each other along X mesh "
    "when the second's tooth count is odd with phase=0, and with phase=0.5 when it is even.")


def gearing_reference() -> str:
    """The transmission geometry helpers (``program/gearing.py``) as the model's requests state
    them: each signature and its docstring's first paragraph, then what the coupling gate checks."""
    from ..program import gearing
    rows = ["## Transmission helpers (real teeth and threads; each around its own origin, axis +Z, "
            "returns one solid; each also as make_<name>, e.g. make_rack(...), which a part "
            "named like the helper, def rack(), does not hide)"]
    for name in ("spur_gear", "ring_gear", "rack", "lead_screw", "lead_nut", "pulley"):
        fn = getattr(gearing, name)
        doc = inspect.cleandoc(fn.__doc__ or "").split("\n\n")[0].replace("\n", " ")
        rows.append(f"- {name}{inspect.signature(fn)}: {doc}")
    from ..config import TOL
    return "\n".join(rows) + "\n\n" + COUPLING_GATE.format(centre=TOL.coupling_centre_mm)


def option_line(name: str, opt: Any) -> str:
    """``name = default, range [lo, hi]: meaning (unit)`` for one mate option."""
    if opt.choices:
        rng = "one of " + ", ".join(repr(c) for c in opt.choices)
    elif opt.low is not None or opt.high is not None:
        rng = f"{'whole number in ' if opt.integer else ''}{opt.range_text()}"
    elif isinstance(opt.default, bool):
        rng = "True or False"
    else:
        rng = "any"
    return f"{name} = {opt.default!r}, range {rng}: {opt.doc}"


#: Location rotations of the frames a program needs most, as (rotation, where +Z points, where
#: +X points). tests/agent/test_reference.py checks every row against build123d itself.
FRAME_ROTATIONS: tuple[tuple[tuple[int, int, int], str, str], ...] = (
    ((0, 0, 0), "+Z", "+X"),
    ((180, 0, 0), "-Z", "+X"),
    ((-90, 0, 0), "+Y", "+X"),
    ((90, 0, 0), "-Y", "+X"),
    ((0, 90, 0), "+X", "-Z"),
    ((0, -90, 0), "-X", "+Z"),
)


def conventions() -> str:
    """Frames, motion, the language and the numeric gate limits, read from the code."""
    from ..config import TOL
    from ..mates.fits import BANDS_MM, ISO273_MM, iso286
    from ..program.allowlist import FORBIDDEN_NAMES
    rows = ["## Conventions", "Lengths in mm, angles in degrees.",
            "`Location((x, y, z), (rx, ry, rz))`: the rotation is Rx(rx)\u00b7Ry(ry)\u00b7Rz(rz) (about X, then "
            "the new Y, then the new Z). Frames you will need:"]
    rows += [f"- `Location((x, y, z), {r})`: +Z along {z}, +X along {x}" for r, z, x in FRAME_ROTATIONS]
    rows += [
        "`Pos(x, y, z) * shape` moves and `Rot(rx, ry, rz) * shape` turns a shape (same rotation rule); "
        "both are in scope, with every build123d solid, sketch and operation (Box, Cylinder, Sphere, "
        "Cone, Torus, extrude, revolve, fillet, chamfer, Align, Axis, Plane ...).",
        "Motion: a revolute turns the child about +Z of its frame, positive by the right-hand rule; a "
        "prismatic moves the child along +Z (away from the parent) for positive values; a spherical "
        "joint turns about the frame origin within `cone`. `home` (the pose the child is built in) "
        "must lie inside `limits`. The MuJoCo battery sweeps each joint through its limits on its own "
        "(the other joints at home), so every moving part must clear its neighbours over its whole "
        "range.",
        "Coordinates: model each part around its own origin, in its own coordinates, with its "
        "mounting frame (the child frame of the mate that places it) at or near that origin, and give "
        "its other frames in the same coordinates; the mate places it: the compiler moves each part so "
        "its mate frames coincide with its partners' (T_child = T_parent * F_parent * Delta * "
        "F_child^-1). Never draw a part at its assembly position (a Pos(x, y, z) of where it sits in "
        "the assembly, with frames copied from its parent's; see the origin gate below). The root is "
        "the one part whose own origin is the assembly's. A part that slides or turns must still touch "
        "its parent (with features=False, model the contact yourself).",
        "The language: params are numbers or expressions of numbers, earlier params and `math`; helpers "
        "and parts are plain functions (loops, comprehensions, conditionals are fine); frames and "
        "assembly may use expressions and loops too. Forbidden: imports other than `math`, names or "
        "attributes starting with `_`, assignment to attributes, and the names "
        + ", ".join(sorted(FORBIDDEN_NAMES)) + ".",
        f"Fits: ISO 286 bands for nominals up to {BANDS_MM[-1]} mm (a larger or non-positive nominal "
        "is a compile error naming the mate). Bolt patterns take ISO 273 M-sizes: "
        + ", ".join(f"M{k:g}" for k in ISO273_MM) + " (any other size is an error listing these).",
        "## Gate limits (what the tool measures on every part)",
        f"- mate gate, every static mate of nominal d: bearing area around the frame >= "
        f"{TOL.registration_tau:g} d^2, counting faces within {TOL.registration_band_mm:g} mm of each other; "
        f"penetration <= the fit's own interference + {TOL.penetration_slack_mm:g} mm "
        f"(e.g. d = 10 mm press fit: {max(0.0, -iso286(10.0, 'press').offset):.4f} + "
        f"{TOL.penetration_slack_mm:g} mm).",
        f"- connectivity: pieces closer than {TOL.connect_mm:g} mm touch; a piece whose box side is at "
        f"least {TOL.span_tau:g} of the model's largest side and touches nothing is a visible floater "
        "(the build refuses a part that adds one).",
        f"- interference: parts may touch (coincident faces are contact, not interference: a part "
        f"seated on a face needs no pocket); a common volume of two parts thicker than "
        f"{TOL.penetration_slack_mm:g} mm fails, unless it is a mate's own fit inside that mate's "
        "features.",
        f"- battery B2: moving one joint over its limits may add at most {TOL.sim_penetration_mm:g} mm "
        "of interference with any other part (the depth and the pose are reported when it does).",
        "- compile: every part is a valid, non-empty solid; an exception names the part and the line.",
        f"- origin: a part whose body lies farther from its own origin than {TOL.origin_offset_factor:g} x "
        f"its own largest box side (at least {TOL.origin_offset_min_mm:g} mm), with its mounting frame "
        "out there at the body, is drawn at its assembly position: a `part-origin` finding naming the "
        "offset (a warning in `check`; a build attempt or edit with it is refused and retried). The "
        "root is judged on its body alone. A long part whose frame is at one end is fine: its body "
        "starts at its origin.",
    ]
    return "\n".join(rows)


def system_prompt() -> str:
    return template("oneshot_system").replace("{reference}", reference())
