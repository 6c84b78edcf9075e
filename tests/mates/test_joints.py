"""build123d joints for mates: placement and motion agree with the closed form."""

from __future__ import annotations

import numpy as np
import pytest

build123d = pytest.importorskip("build123d")
from build123d import Box, Location  # noqa: E402 - after the importorskip above

from procedura_brep.errors import RangeError  # noqa: E402 - after the importorskip above
from procedura_brep.mates import placement as pl  # noqa: E402 - after the importorskip above
from procedura_brep.mates.joints import kinematic, rigid_place  # noqa: E402 - after the importorskip above
from procedura_brep.program.runtime import loc_matrix  # noqa: E402 - after the importorskip above

FP = Location((5, 2, 10), (0, 90, 30))   # a tilted parent frame: the axis is not Z
FC = Location((1, -2, -5), (15, 0, 0))


@pytest.fixture
def pair():
    parent, child = Box(50, 50, 20), Box(10, 10, 10)
    parent.locate(Location((3, 4, 5), (10, 20, 30)))
    return parent, child


def close(child, parent, mtype, value) -> tuple[float, float]:
    expect = pl.solve(loc_matrix(parent.location), loc_matrix(FP), loc_matrix(FC), pl.delta(mtype, value))
    return pl.residual(loc_matrix(child.location), expect)


def test_rigid_joint_places_the_child(pair):
    parent, child = pair
    rigid_place(parent, child, FP, FC, "m")
    d, a = close(child, parent, "seat_face", None)
    assert d < 1e-9 and a < 1e-12


@pytest.mark.parametrize("mtype, values", [
    ("revolute", [-45.0, 0.0, 30.0, 60.0]),
    ("prismatic", [-5.0, 0.0, 7.5, 60.0]),
    ("spherical", [(0, 0, 0), (10, 0, 0), (0, -20, 0), (10, -5, 30)]),
])
def test_kinematic_joints_follow_the_closed_form(pair, mtype, values):
    parent, child = pair
    j = kinematic(mtype, parent, child, FP, FC, "m", limits=(-50.0, 60.0), cone=40.0)
    for v in values:
        j.move(v)
        d, a = close(child, parent, mtype, v)
        assert d < 1e-9 and a < 1e-12, (v, d, a)


def test_revolute_motion_is_a_rotation_about_the_axis(pair):
    parent, child = pair
    j = kinematic("revolute", parent, child, FP, FC, "m", limits=None)  # continuous
    axis_frame = loc_matrix(parent.location) @ loc_matrix(FP)
    j.move(0.0)
    a0 = loc_matrix(child.location)
    j.move(400.0)  # continuous: beyond a full turn is allowed
    rel = pl.rigid_inverse(axis_frame) @ loc_matrix(child.location) @ pl.rigid_inverse(a0) @ axis_frame
    assert np.allclose(rel, pl.rot_z(40.0), atol=1e-9)


@pytest.mark.parametrize("mtype, bad, message", [
    ("revolute", 61.0, r"m \(revolute\) position = 61 deg is outside the allowed range \[-50, 60\] deg"),
    ("prismatic", -51.0, r"m \(prismatic\) position = -51 mm is outside the allowed range \[-50, 60\] mm"),
    ("spherical", (45.0, 0.0, 0.0), r"m \(spherical\) tilt = 45 deg is outside the allowed range \[0, 40\] deg"),
])
def test_out_of_range_is_refused_naming_value_and_range(pair, mtype, bad, message):
    parent, child = pair
    j = kinematic(mtype, parent, child, FP, FC, "m", limits=(-50.0, 60.0), cone=40.0)
    before = loc_matrix(child.location)
    with pytest.raises(RangeError, match=message):
        j.move(bad)
    assert np.array_equal(loc_matrix(child.location), before)  # nothing moved


def test_cylindrical_follows_the_closed_form_to_the_limits_of_its_range(pair):
    """Slide and turn together, up to both ends of both ranges, on a tilted parent frame."""
    parent, child = pair
    j = kinematic("cylindrical", parent, child, FP, FC, "m", limits=(-50.0, 60.0),
                  angle_limits=(-90.0, 135.0))
    for v in [(0.0, 0.0), (-50.0, -90.0), (60.0, 135.0), (-50.0, 135.0), (60.0, -90.0), (7.5, 33.0)]:
        j.move(v)
        d, a = close(child, parent, "cylindrical", v)
        assert d < 1e-9 and a < 1e-12, (v, d, a)
    before = loc_matrix(child.location)
    with pytest.raises(RangeError, match=r"m \(cylindrical\) position = 61 mm is outside the allowed range \[-50, 60\] mm"):
        j.move((61.0, 0.0))
    with pytest.raises(RangeError, match=r"m \(cylindrical\) angle = 136 deg is outside the allowed range \[-90, 135\] deg"):
        j.move((0.0, 136.0))
    assert np.array_equal(loc_matrix(child.location), before)  # nothing moved


def test_cylindrical_free_turn_goes_past_a_full_turn(pair):
    parent, child = pair
    j = kinematic("cylindrical", parent, child, FP, FC, "m", limits=(-50.0, 60.0))
    j.move((10.0, 400.0))
    d, a = close(child, parent, "cylindrical", (10.0, 400.0))
    assert d < 1e-9 and a < 1e-12
