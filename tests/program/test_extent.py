"""Exact extents of placed parts (issue 24.1, the battery's speed): a part's extent along a
world direction is its local shape's along that direction turned into its frame, plus its
offset; twins turned alike pay for one exact box."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.mates.placement import rot_x, rot_z, trans
from procedura_brep.program import model as model_module
from procedura_brep.program.model import CompiledPart


@pytest.fixture
def wheels():
    import build123d as bd
    brep = kernel.write_brep(bd.Cylinder(30, 12).wrapped)  # axis Z, centred
    model_module.clear_mesh_cache()
    yield [CompiledPart(name=n, brep=brep, placement=pl, material="rubber") for n, pl in (
        ("a", trans(100, 0, 30)), ("b", trans(-100, 50, 30)), ("c", trans(0, 0, 30) @ rot_x(90)))]
    model_module.clear_mesh_cache()


def test_extent_is_the_placed_shapes(wheels, monkeypatch):
    """Against the world shape's own optimal box (Z, X) and the cylinder's geometry (any
    direction: its cap circles' extreme points)."""
    for p in wheels:
        lo, hi = kernel.bbox(p.shape(), optimal=True)
        assert p.extent(np.array([0, 0, 1.0])) == pytest.approx((lo[2], hi[2]), abs=1e-9)
        assert p.extent(np.array([1.0, 0, 0])) == pytest.approx((lo[0], hi[0]), abs=1e-9)
    d = np.array([1.0, 2.0, 2.0]) / 3.0
    a = wheels[0]
    axis, centre = a.placement[:3, 2], a.placement[:3, 3]
    reach = 30 * np.sqrt(1 - (axis @ d) ** 2) + 6 * abs(axis @ d)  # radius across, half-height along
    assert a.extent(d) == pytest.approx((centre @ d - reach, centre @ d + reach), abs=1e-6)
    lo, hi = a.local_box()
    assert lo == pytest.approx([-30, -30, -6]) and hi == pytest.approx([30, 30, 6])
    import build123d as bd  # an off-centre block, turned about two axes: no symmetry to hide in
    block = bd.Box(40, 10, 20, align=(bd.Align.MIN, bd.Align.MIN, bd.Align.MIN)).wrapped
    turned = CompiledPart(name="block", brep=kernel.write_brep(block), material="steel",
                          placement=trans(5, -7, 11) @ rot_z(30) @ rot_x(40))
    lo, hi = kernel.bbox(turned.shape(), optimal=True)
    for k, d in enumerate(np.eye(3)):
        assert turned.extent(d) == pytest.approx((lo[k], hi[k]), abs=1e-9), k


def test_twins_turned_alike_share_one_exact_box(wheels, monkeypatch):
    calls = []
    real = kernel.bbox

    def counted(shape, *, optimal=True):
        calls.append(optimal)
        return real(shape, optimal=optimal)
    monkeypatch.setattr(kernel, "bbox", counted)
    up = np.array([0, 0, 1.0])
    a, b, c = wheels
    assert a.extent(up) == pytest.approx((24, 36)) and b.extent(up) == pytest.approx((24, 36))
    assert len(calls) == 1  # b is a turned like a: a's box, moved
    assert c.extent(up) == pytest.approx((0, 60))
    assert len(calls) == 2  # c is turned: its own
    a.local_box(), b.local_box(), c.local_box()
    assert len(calls) == 3  # one local box for the three
