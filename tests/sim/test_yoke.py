"""B2 on a head turning in a yoke (issue 24.1): the head's fillets cross the cheek's end faces in
the plane where the head's side touches the cheek, pose after pose. Every such crossing lies in
that plane, so the common can only be a sheet there: the pair costs no exact boolean past its
start pose; a rib standing into the head's slab is still found."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.config import TOL
from procedura_brep.sim import sweep
from procedura_brep.sim.sweep import SweepScene, _orbit_boxes, _thin_union
from procedura_brep.testing.models import compiled

from .yoke import program


@pytest.fixture(scope="module")
def yokes():
    return {rib: compiled(program(rib), name=f"yoke_{'rib' if rib else 'clean'}") for rib in (False, True)}


def _sweep(model):
    art = articulate(model)
    return SweepScene(model, art).sweep(art.joint("head_tilt"))


def test_the_head_touching_its_cheek_costs_no_boolean_per_pose(yokes, monkeypatch):
    hit = _sweep(yokes[False])
    assert hit.contact == [("head", "yoke")] and hit.depth == 0.0 and not hit.stopped
    assert hit.booleans <= 3, hit.booleans
    # planted: the curved faces' triangles widened by their whole deviation, as before
    monkeypatch.setattr(sweep.SweepScene, "_face_heights",
                        lambda self, name, ids, devs, d, lo, hi: (lo, hi))
    old = _sweep(yokes[False])
    assert old.booleans >= 20 and old.depth == 0.0


def test_a_rib_in_the_heads_slab_is_found(yokes):
    hit = _sweep(yokes[True])
    assert ("head", "yoke") in hit.contact  # clear at the start: swept on the faces that can start an overlap
    assert hit.pair == ("head", "yoke") and hit.depth > TOL.sim_penetration_mm, hit.as_dict()
    assert hit.point is not None and hit.point[0] >= 30.0  # on the rib, beside the head


def test_a_union_of_slabs_is_thin_only_when_every_piece_is():
    t = TOL.sim_penetration_mm
    assert _thin_union(np.array([]), np.array([]), t)
    assert _thin_union(np.array([0.0, 5.0, 5.02]), np.array([0.0, 5.05, 5.06]), t)
    assert _thin_union(np.array([0.0, 3.0]), np.array([-1.0, 3.0]), t)  # an empty interval is left out
    # pieces that touch or overlap are one piece: 0.12 thick
    assert not _thin_union(np.array([0.0, 0.06]), np.array([0.06, 0.12]), t)
    assert not _thin_union(np.array([0.0, 0.01]), np.array([0.09, 0.11]), t)


def test_a_long_triangle_keeps_its_least_distance_from_the_axis():
    tri = np.array([[[40.0, -100.0, 0.0], [40.0, 100.0, 0.0], [60.0, 0.0, 5.0]]])
    lo, hi = _orbit_boxes(tri, np.eye(4), slides=False)
    assert lo[0, 0] == pytest.approx(40.0) and hi[0, 0] == pytest.approx(np.hypot(40.0, 100.0))
    assert (lo[0, 1], hi[0, 1]) == (0.0, 5.0)
