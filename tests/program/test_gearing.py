"""The transmission helpers of the program vocabulary (program/gearing.py): teeth, pitch
circles, racks on their pitch line, threads that fit their nut, pulleys, and clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from procedura_brep.gates.coupling import Line, measure_teeth
from procedura_brep.program import gearing

Z_AXIS = Line(np.zeros(3), np.array([0.0, 0.0, 1.0]))


def _valid(part) -> bool:
    from OCP.BRepCheck import BRepCheck_Analyzer
    return len(part.solids()) == 1 and BRepCheck_Analyzer(part.wrapped).IsValid()


def _box(part):
    bb = part.bounding_box()
    return np.array([bb.min.X, bb.min.Y, bb.min.Z]), np.array([bb.max.X, bb.max.Y, bb.max.Z])


@pytest.mark.parametrize("m, z", [(1.5, 17), (1.0, 40)])
def test_spur_gear_teeth_pitch_circle_and_validity(m, z):
    g = gearing.spur_gear(m, z, 10, bore=6)
    assert _valid(g)
    teeth = measure_teeth(g.wrapped, Z_AXIS, 0.0, internal=False)
    assert teeth is not None and teeth.count == z
    assert teeth.module == pytest.approx(m, rel=1e-6)          # tip circle m (z + 2) / 2
    assert teeth.module * z / 2 == pytest.approx(m * z / 2)      # so the pitch radius is m z / 2
    lo, hi = _box(g)
    assert lo[2] == pytest.approx(-5, abs=1e-6) and hi[2] == pytest.approx(5, abs=1e-6)
    assert np.all(np.abs(lo[:2] + hi[:2]) / 2 < m)  # around its own origin (odd z: a tooth vs a space)
    disc = math.pi * (m * z / 2) ** 2 * 10 - math.pi * 3 ** 2 * 10
    assert g.volume == pytest.approx(disc, rel=0.04)


def test_spur_gear_phase_turns_half_a_pitch():
    from build123d import Vector
    m, z = 1.5, 18
    r = m * z / 2
    plain, turned = gearing.spur_gear(m, z, 6), gearing.spur_gear(m, z, 6, phase=0.5)
    on_x = Vector(r, 0, 0)
    assert plain.is_inside(on_x) and not turned.is_inside(on_x)  # a tooth on +X, then a space


def test_ring_gear_teeth_inside():
    m, z = 1.5, 48
    g = gearing.ring_gear(m, z, 8)
    assert _valid(g)
    teeth = measure_teeth(g.wrapped, Z_AXIS, 0.0, internal=True)
    assert teeth is not None and teeth.count == z and teeth.internal
    assert teeth.tip_r == pytest.approx(m * (z - 2) / 2, abs=1e-6)
    assert teeth.module == pytest.approx(m, rel=1e-6)
    lo, hi = _box(g)
    assert hi[0] == pytest.approx(m * (z / 2 + gearing.DEDENDUM) + 3 * m, abs=1e-3)  # default rim


def test_rack_pitch_line_on_its_origin():
    from build123d import Vector
    m = 2.0
    r = gearing.rack(m, 60, 8, 7)
    assert _valid(r)
    lo, hi = _box(r)
    assert hi[1] == pytest.approx(m, abs=1e-6)          # tips one addendum above the pitch line
    assert lo[1] == pytest.approx(-7, abs=1e-6)         # back face at -height
    n = round((hi[0] - lo[0]) / (math.pi * m))
    assert n % 2 == 1 and abs(n * math.pi * m - 60) <= math.pi * m
    assert r.is_inside(Vector(0, 0.5 * m, 0))           # a tooth centred on x = 0
    assert not r.is_inside(Vector(math.pi * m / 2, 0.5 * m, 0))


def test_lead_screw_fits_its_nut_a_whole_lead_apart():
    from build123d import Pos
    lead = 3.0
    screw = gearing.lead_screw(12, lead, 36)
    nut = gearing.lead_nut(12, lead, 12)
    assert _valid(screw) and _valid(nut)
    lo, hi = _box(screw)
    assert hi[2] == pytest.approx(36, abs=1e-6) and hi[0] == pytest.approx(6, abs=1e-3)
    assert (screw & (Pos(0, 0, 4 * lead) * nut)).volume == pytest.approx(0, abs=1e-6)
    assert (screw & (Pos(0, 0, 4.5 * lead) * nut)).volume > 10   # half a lead off: threads clash


def test_pulleys():
    timing = gearing.pulley(6, teeth=20, bore=5)
    smooth = gearing.pulley(6, diameter=30)
    assert _valid(timing) and _valid(smooth)
    assert _box(smooth)[1][0] == pytest.approx(15 + 2.0, abs=1e-6)  # flange one pitch above
    assert _box(timing)[1][0] == pytest.approx(20 * 2.0 / math.pi / 2 + 2.0, abs=1e-6)


@pytest.mark.parametrize("call, words", [
    (lambda: gearing.spur_gear(0, 20, 10), "spur_gear: module must be > 0, got 0"),
    (lambda: gearing.spur_gear(-1.5, 20, 10), "module must be > 0"),
    (lambda: gearing.spur_gear(1.5, 5, 10), "spur_gear: teeth must be in [6, 400], got 5"),
    (lambda: gearing.spur_gear(1.5, 10**6, 10), "spur_gear: teeth must be in [6, 400], got 1000000"),
    (lambda: gearing.rack(1.0, 10**5, 8, 7), "rack: length 100000 mm holds 31831 teeth"),
    (lambda: gearing.lead_screw(12, 1, 10**4), "lead_screw: length 10000 mm must be more than two"),
    (lambda: gearing.spur_gear(1.5, 20.5, 10), "teeth must be a whole number"),
    (lambda: gearing.spur_gear(1.5, 20, 10, bore=40), "bore 40 mm leaves less than one module"),
    (lambda: gearing.ring_gear(1.0, 4, 10), "ring_gear: teeth must be in [6, 400]"),
    (lambda: gearing.rack(2.0, 5, 8, 7), "rack: length 5 mm holds fewer than 2 teeth"),
    (lambda: gearing.rack(2.0, 60, 8, 2), "rack: height 2 mm must exceed"),
    (lambda: gearing.lead_screw(12, 5, 60), "lead_screw: lead 5 mm is more than a third"),
    (lambda: gearing.lead_nut(12, 3, 12, hand="up"), "lead_nut: hand must be 'right' or 'left'"),
    (lambda: gearing.pulley(6), "pulley: give exactly one of teeth="),
    (lambda: gearing.spur_gear(1.5, 20, float("nan")), "width must be a finite number"),
])
def test_bad_sizes_are_one_line_errors(call, words):
    from procedura_brep.errors import ProceduraError
    with pytest.raises(gearing.GearingError) as info:
        call()
    assert isinstance(info.value, ProceduraError) and words in str(info.value)
    assert "\n" not in str(info.value)


def test_programs_see_the_helpers_not_the_libraries():
    import procedura_brep.program as api
    names = set(api.__all__)
    assert set(gearing.HELPERS) <= names
    assert not {"py_gearworks", "bd_warehouse", "pgw", "gearing"} & names
    assert api.spur_gear is gearing.spur_gear


def test_a_bad_size_in_a_program_is_a_finding_naming_the_part_and_the_helper(worker):
    from pathlib import Path
    src = (Path(__file__).parents[1] / "gates" / "drive.py").read_text()
    src = src.replace("z_planet = 12       # teeth of the planet", "z_planet = 5        # teeth of the planet")
    model = worker.compile(src)
    errors = [f for f in model.findings if f.severity == "error"]
    assert [f.part for f in errors] == ["planet"]
    assert "spur_gear: teeth must be in [6, 400], got 5" in errors[0].message and errors[0].line


def test_a_part_named_like_a_helper_builds_with_its_make_alias(worker):
    """A part named ``lead_screw`` hides the helper ``lead_screw`` inside the program (its
    function takes the name: a recorded run's first attempt called the part itself); the same
    helper stays reachable as ``make_lead_screw`` and its build request says so."""
    from procedura_brep.agent.context import part_slice
    from procedura_brep.agent.plan import parse_plan
    src = '''"""A lead screw part named like the helper."""
from procedura_brep.program import *

# === params ===
screw_d = 10.0  # mm
screw_lead = 2.0  # mm per turn

# === helpers ===

# === parts ===
@part(detail="major", material="steel", description="a lead screw")
def lead_screw():
    return make_lead_screw(screw_d, screw_lead, 40.0)

# === frames ===
frames("lead_screw", hub=Location((0, 0, 0)))

# === assembly ===
'''
    model = worker.compile(src)
    assert model.ok, [f.message for f in model.findings]
    shadowed = worker.compile(src.replace("make_lead_screw(", "lead_screw("))
    assert not shadowed.ok and "takes 0 positional arguments" in shadowed.findings[0].message
    plan = parse_plan({"parts": [{"name": "base", "detail": "silhouette", "description": "a base plate 100 mm"},
                                 {"name": "lead_screw", "detail": "major", "description": "a 10 mm lead screw",
                                  "mates": [{"partner": "base", "type": "revolute", "nominal": "screw_d"}]}]})
    assert "so build its geometry with make_lead_screw(...)" in part_slice(plan, plan.part("lead_screw"))
    assert "make_" not in part_slice(plan, plan.part("base"))
