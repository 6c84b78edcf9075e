"""B2 on sliding contact (issue 23.2): bearing blocks that touch their rails along the whole
travel cost the exact sweep nothing, while a stop block in their path is found, named, and
placed at the pose where the moved part meets it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.config import TOL
from procedura_brep.sim.cells import side_of_motion
from procedura_brep.sim.sweep import SweepScene
from procedura_brep.testing.models import compiled

from .slide import STOP_MEETS_MM, program


@pytest.fixture(scope="module")
def axes():
    return {stop: compiled(program(stop), name=f"slide_{stop}") for stop in (False, True)}


def _sweep(model):
    art = articulate(model)
    return SweepScene(model, art).sweep(art.joint("carriage_slide"))


def test_blocks_touching_their_rails_over_760_mm_pass_with_few_booleans(axes):
    hit = _sweep(axes[False])
    assert not hit.stopped and hit.pair is None and hit.depth == 0.0
    # every block touches its rail on three faces at every pose, yet the sweep needs no more
    # exact booleans than pairs (the old sweep spent its 1500 on the first pair and failed)
    assert {("block_lf", "rail_l"), ("block_rb", "rail_r")} <= set(hit.contact)
    assert hit.booleans <= 20, hit.booleans


def test_a_stop_block_in_the_path_is_named_with_the_pose_where_it_meets(axes):
    hit = _sweep(axes[True])
    assert not hit.stopped
    assert hit.pair == ("block_lf", "stop") and hit.depth > TOL.sim_penetration_mm
    first = float(hit.first_at.split()[0])
    assert first == pytest.approx(STOP_MEETS_MM, abs=TOL.sweep_step_mm + 0.5)
    assert hit.volume > 0 and len(hit.point) == 3
    # the point lies in the stop (world: on the left rail's top, near x = 100)
    assert hit.point[1] == pytest.approx(-60.0, abs=10.0) and 90.0 <= hit.point[0] <= 130.0
    assert hit.booleans < 300


def test_without_the_leading_face_rule_the_contact_exhausts_the_budget(axes, monkeypatch):
    """Plants the old behaviour (every face of both parts in the covers): the touching blocks
    then need an exact boolean at almost every pose and the sweep stops at its budget."""
    from procedura_brep.sim import sweep

    monkeypatch.setattr(sweep.SweepScene, "clear_start", lambda self, joint, a, b: 0)
    monkeypatch.setattr(sweep, "TOL", dataclasses.replace(TOL, sweep_max_booleans=400))
    hit = _sweep(axes[False])
    assert hit.stopped and "block_lf" in hit.stopped


def test_faces_along_the_motion_neither_lead_nor_oppose():
    from build123d import Box, Cylinder, Rot, Sphere

    from procedura_brep.kernel import _ocp

    o = _ocp()
    u = np.array([1.0, 0.0, 0.0])

    def sides(shape):
        out = []
        exp = o["TopExp"].TopExp_Explorer(shape.wrapped, o["TopAbs"].TopAbs_FACE)
        while exp.More():
            out.append(side_of_motion(o["TopoDS"].TopoDS.Face(exp.Current()), u, o))
            exp.Next()
        return out

    box = sides(Box(10, 10, 10))
    assert sorted(box) == sorted([(True, False), (False, True)] + [(False, False)] * 4)
    rod = sides(Rot(0, 90, 0) * Cylinder(5, 20))  # a rod along X: its side slides in itself
    assert sorted(rod) == sorted([(False, False), (True, False), (False, True)])
    assert sides(Sphere(5)) == [(True, True)]  # curved: assumed to do both (conservative)


def test_b2_names_the_stop_and_where_the_parts_meet(axes, tmp_path):
    from procedura_brep.sim import run_battery

    report = run_battery(axes[True], out_dir=tmp_path, checks=["B2"], frames=False)
    b2 = report.check("B2")
    assert b2.status == "fail" and report.verified
    assert "drives 'block_lf'" in b2.message and "into 'stop'" in b2.message
    assert "they meet at 39" in b2.message and "mm^3" in b2.message
    clean = run_battery(axes[False], out_dir=tmp_path / "clean", checks=["B2"], frames=False)
    assert clean.check("B2").status == "pass", clean.check("B2").message


def test_a_flap_turning_beside_its_post_costs_no_boolean_per_pose(monkeypatch):
    """Issue 24.1: a flap turns on a pin beside the face of its post, the two touching only
    across the plane normal to the pin. The faces that can start an overlap (those the turn
    does not move within themselves) lie on either side of that plane, so the pair is dropped
    after its start pose; planted: the whole range needs an exact boolean at almost every pose."""
    from procedura_brep.sim import sweep
    from procedura_brep.testing.programs import hinge_row

    model = compiled(hinge_row(3), name="hinge")
    art = articulate(model)
    hit = SweepScene(model, art).sweep(art.joint("flap_0_pivot"))
    assert hit.contact == [("flap_0", "post_0")] and hit.depth == 0.0
    assert hit.booleans <= 3, hit.booleans
    monkeypatch.setattr(sweep.SweepScene, "_moving_faces_apart", lambda self, j, a, b, side: False)
    old = SweepScene(model, art).sweep(art.joint("flap_0_pivot"))
    assert old.booleans >= 20 and old.depth == 0.0


def test_b3_says_not_verified_for_a_pair_it_could_not_decide(axes, monkeypatch, tmp_path):
    """A rest pair whose exact common is over the bound is B3 'not verified', not a pass."""
    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches
    from procedura_brep.sim import run_battery

    monkeypatch.setattr(common_mod, "TOL", dataclasses.replace(TOL, boolean_pair_budget=1))
    clear_caches()
    try:
        b3 = run_battery(axes[False], out_dir=tmp_path, checks=["B3"], frames=False).check("B3")
    finally:
        clear_caches()
    assert b3.passed and b3.status == "not verified"
    assert "over the budget of 1" in b3.unverified
