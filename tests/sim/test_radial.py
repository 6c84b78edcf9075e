"""The radial prefilter's bounds (:func:`procedura_brep.sim.cells.radial_range`): conservative
against the exact solids, and tight enough to tell a screw from the clearance bore around it."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.sim.cells import radial_apart, radial_range, surface


def _solid(kind: str):
    from build123d import Align, Box, Cylinder, Pos, Rot
    if kind == "screw":  # a shaft of radius 4 along X, with a flat and a cross hole
        s = Rot(0, 90, 0) * Cylinder(4, 100)
        return s - Pos(0, 0, 3.5) * Box(30, 10, 2) - Pos(20, 0, 0) * Cylinder(1, 20)
    if kind.startswith("carriage"):  # a block around X with a bore of the given radius
        r = float(kind.split(":")[1])
        return Box(40, 30, 30) - Rot(0, 90, 0) * Cylinder(r, 50)
    if kind == "plate":  # off the axis altogether
        return Pos(0, 0, 30) * Box(40, 30, 5, align=(Align.CENTER, Align.CENTER, Align.MIN))
    raise AssertionError(kind)


def _range(kind: str) -> tuple[float, float]:
    tris, devs, _, _ = surface(_solid(kind).wrapped)
    return radial_range(tris, devs, np.zeros(3), np.array([1.0, 0.0, 0.0]))


def test_bounds_contain_the_exact_radii():
    lo, hi = _range("screw")
    assert lo == 0.0  # the axis runs through the shaft's ends
    assert 4.0 <= hi <= 4.0 + 0.2
    lo, hi = _range("carriage:5")
    assert 5.0 - 0.2 <= lo <= 5.0  # the bore, lowered by the chords' deviation at most
    assert hi >= float(np.hypot(15, 15))
    lo, hi = _range("plate")
    assert lo == pytest.approx(30.0, abs=1e-9) and hi >= np.hypot(15, 35)


@pytest.mark.parametrize("bore, apart", [(5.0, True), (3.9, False), (4.0, False)])
def test_a_screw_in_a_clearance_bore_is_apart_and_in_a_tight_one_is_not(bore, apart):
    assert radial_apart(_range("screw"), _range(f"carriage:{bore}")) is apart


def test_random_triangles_get_bounds_both_safe_and_tight():
    """Against dense samples of each triangle: the bounds never cut into it, and miss its
    least and greatest radius by no more than the sampling's spacing (a triangle the line
    pierces included, whose least radius is 0 though its edges keep away)."""
    rng = np.random.default_rng(7)
    point, axis = np.array([0.5, -1.0, 2.0]), np.array([1.0, 2.0, 0.5])
    a = axis / np.linalg.norm(axis)
    e1 = np.cross(a, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    pierced = point + np.array([8 * e1 + 3 * a, -4 * e1 + 7 * e2, -4 * e1 - 7 * e2 - 5 * a])
    tris = np.concatenate([pierced[None], rng.uniform(-10, 10, (80, 3, 3))])
    w = rng.dirichlet(np.ones(3), 20000)
    for t in tris:
        lo, hi = radial_range(t[None], np.zeros(1), point, axis)
        pts = w @ t - point
        r = np.linalg.norm(pts - np.outer(pts @ a, a), axis=1)
        assert lo - 1e-9 <= r.min() <= lo + 0.3 and hi - 0.3 <= r.max() <= hi + 1e-9
    assert radial_range(tris[:1], np.zeros(1), point, axis)[0] == 0.0
    lo, hi = radial_range(tris, np.full(len(tris), 0.25), point, axis)
    assert lo == 0.0 and hi == pytest.approx(max(radial_range(t[None], np.zeros(1), point, axis)[1]
                                                 for t in tris) + 0.25)
