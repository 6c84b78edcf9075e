from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.config import TOL
from procedura_brep.gates.mate_gate import mate_gate, penetration_limit
from procedura_brep.testing.models import cpart


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


def _flipped(child_below: bool, parent_above: bool):
    """A 30 mm box child and a base block across the plane z = 0 of the mate frame; ``True``
    puts that part on the wrong side (what a frame whose +Z is flipped does)."""
    from build123d import Align, Box

    from procedura_brep.program.model import CompiledModel

    up, down = (Align.CENTER, Align.CENTER, Align.MIN), (Align.CENTER, Align.CENTER, Align.MAX)
    base = cpart("base", Box(100, 100, 20, align=up if parent_above else down), top=np.eye(4))
    post = cpart("post", Box(30, 30, 20, align=down if child_below else up), foot=np.eye(4))
    if parent_above and not child_below:  # both above: the child sits inside the base
        post = cpart("post", Box(30, 30, 20, align=up), foot=np.eye(4))
    mate = make_mate()
    return CompiledModel(name="flip", params={}, parts=[base, post], mates=[mate])


def make_mate():
    from procedura_brep.mates.fits import iso286
    from procedura_brep.program.model import CompiledMate
    return CompiledMate(name="post_on_base", type="seat_face", kind="static", child="post",
                        child_frame="foot", parent="base", parent_frame="top", nominal_name="d",
                        nominal=10.0, fit=iso286(10.0, "location").as_dict(),
                        options={"features": False}, dof={}, world_frame=np.eye(4), line=9)


@pytest.mark.parametrize("child_wrong,parent_wrong,blamed", [
    (True, False, ["flip post.foot"]),
    (False, True, ["flip base.top"]),
])
def test_flipped_frame_names_the_wrong_frame_and_directions(child_wrong, parent_wrong, blamed):
    findings, res = mate_gate(_flipped(child_wrong, parent_wrong))
    codes = {f.code: f for f in findings}
    assert {"mate-registration", "mate-penetration"} <= set(codes)
    msg = codes["mate-penetration"].message
    assert "must oppose" in msg and "+Z points world +Z" in msg
    for b in blamed:
        assert b in msg and b in codes["mate-registration"].message
    other = "flip base.top" if blamed == ["flip post.foot"] else "flip post.foot"
    assert other not in msg


def test_plain_gouge_keeps_the_plain_advice(make_peg):
    codes, _, _ = _run(make_peg(10.0, "clearance", lift=-2.0))
    assert "must oppose" not in codes["mate-penetration"].message
