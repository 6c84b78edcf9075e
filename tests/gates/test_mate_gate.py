from __future__ import annotations

import pytest

from procedura_brep.config import TOL
from procedura_brep.gates.mate_gate import mate_gate, penetration_limit


def _run(model):
    findings, res = mate_gate(model)
    return {f.code: f for f in findings}, res.measured["post_on_base"], res


def test_seated_peg_passes(make_peg):
    codes, m, res = _run(make_peg(10.0, "clearance"))
    assert res.passed and not codes
    # the post's bottom face around the peg, out to the bearing radius (1 d), bears on the base
    assert m["area_mm2"] > m["area_limit_mm2"] == pytest.approx(TOL.registration_tau * 100)
    r = TOL.bearing_radius_factor * 10.0
    assert m["area_mm2"] == pytest.approx(3.14159 * (r * r - 25), rel=0.02)
    assert m["penetration_mm"] == 0.0


def test_hovering_peg_fails_on_area(make_peg):
    codes, m, res = _run(make_peg(10.0, "clearance", lift=0.5))
    assert not res.passed
    f = codes["mate-registration"]
    assert f.value == m["area_mm2"] == 0.0 and f.limit == pytest.approx(5.0)
    assert f.mate == "post_on_base" and f.part == "post" and f.line == 12
    assert "mate-penetration" not in codes


def test_gouging_peg_fails_on_penetration(make_peg):
    codes, m, res = _run(make_peg(10.0, "clearance", lift=-2.0))
    f = codes["mate-penetration"]
    assert f.value == pytest.approx(2.0, abs=1e-6)
    assert f.limit == pytest.approx(penetration_limit(make_peg(10.0).mates[0].fit))
    assert not res.passed


def test_press_fit_within_iso_interference_passes(make_peg):
    model = make_peg(40.0, "press", depth=20.0)
    fit = model.mates[0].fit
    assert fit["offset"] < 0  # a real interference fit
    codes, m, res = _run(model)
    assert res.passed, codes
    assert 0 < m["penetration_mm"] <= m["penetration_limit_mm"]
    assert m["penetration_mm"] == pytest.approx(-fit["offset"], rel=0.05)


def test_press_fit_three_times_interference_fails(make_peg):
    model = make_peg(40.0, "press", depth=20.0, interference_scale=3.0)
    i = -model.mates[0].fit["offset"]
    codes, m, res = _run(model)
    f = codes["mate-penetration"]
    assert f.value == pytest.approx(3 * i, rel=0.05)
    assert f.limit == pytest.approx(i + TOL.penetration_slack_mm)
    assert "mate-registration" not in codes


def test_measurements_are_cached(make_peg):
    model = make_peg(10.0)
    _, res1 = mate_gate(model)
    _, res2 = mate_gate(model)
    assert res1.measured == res2.measured


def test_kinematic_mates_are_not_gated(make_peg):
    model = make_peg(10.0, lift=5.0)
    model.mates[0].kind = "kinematic"
    findings, res = mate_gate(model)
    assert findings == [] and res.measured == {}


def test_mate_on_a_missing_part_is_reported_not_raised(make_peg):
    model = make_peg(10.0)
    model.parts = model.parts[:1]  # the post failed to compile
    findings, res = mate_gate(model)
    assert [f.code for f in findings] == ["mate-unmeasured"] and findings[0].severity == "warning"
    assert res.passed and res.measured == {}
