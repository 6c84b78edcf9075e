"""ISO 286 / ISO 273 fit tables."""

from __future__ import annotations

import pytest

from procedura_brep.errors import RangeError
from procedura_brep.mates.fits import iso273, iso286


@pytest.mark.parametrize("d, fit, hole, shaft", [
    # ISO 286-2 limits at 10 mm (band 6-10): H7 0/+15, g6 -5/-14, k6 +1/+10, p6 +15/+24 (um)
    (10.0, "clearance", (10.000, 10.015), (9.986, 9.995)),
    (10.0, "location", (10.000, 10.015), (10.001, 10.010)),
    (10.0, "press", (10.000, 10.015), (10.015, 10.024)),
    # 25 mm (band 18-30): H7 0/+21, g6 -7/-20, p6 +22/+35
    (25.0, "clearance", (25.000, 25.021), (24.980, 24.993)),
    (25.0, "press", (25.000, 25.021), (25.022, 25.035)),
])
def test_iso286_limits(d, fit, hole, shaft):
    f = iso286(d, fit)
    assert f.hole_limits == pytest.approx(hole, abs=1e-9)
    assert f.shaft_limits == pytest.approx(shaft, abs=1e-9)
    assert f.offset == pytest.approx(((hole[0] + hole[1]) - (shaft[0] + shaft[1])) / 4, abs=1e-12)


def test_fit_signs():
    assert iso286(40, "clearance").offset > 0
    assert iso286(40, "press").offset < 0
    assert iso286(40, "snap").interference > iso286(40, "press").interference


def test_iso273_medium_and_fine():
    assert iso273(6, "clearance").hole == 6.6
    assert iso273(6, "location").hole == 6.4
    assert iso273(10, "clearance").offset == pytest.approx(0.5)
    with pytest.raises(ValueError, match="not in ISO 273"):
        iso273(7, "clearance")


def test_out_of_range_nominal_names_value_and_range():
    with pytest.raises(RangeError, match=r"nominal size = 600 mm is outside the allowed range \[0, 500\]"):
        iso286(600, "clearance")
