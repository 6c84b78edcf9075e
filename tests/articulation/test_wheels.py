"""Wheels by evidence (round about the axis, reaching the floor) and one drive sign."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.config import TOL

HUB = '''"""A round hub on a continuous joint, {where}. Hand-written test program."""
from procedura_brep.program import *

# === params ===
post_h = {post_h}  # mm, height of the hub axis
hub_r = 40.0  # mm
axle_d = 8.0  # mm

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base block on the floor")
def base():
    return Box(200, 200, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="post carrying the hub axle")
def post():
    return Box(20, 20, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="rubber", description="round hub, axis horizontal")
def hub():
    return Cylinder(hub_r, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("base", top=Location((0, 0, 20)))
frames("post", foot=Location((0, 0, 0)), side=Location((0, 10, post_h - 20), (-90, 0, 0)))
frames("hub", axle=Location((0, 0, 1)))

# === assembly ===
mate("post.foot", "base.top", "peg_socket", nominal="axle_d", fit="location", features=False)
mate("hub.axle", "post.side", "revolute", nominal="axle_d", fit="clearance", limits=None, features=False)
'''


def _hub(worker, post_h: float):
    from procedura_brep.program import compile_source
    where = f"axis {post_h:g} mm up the post"
    m = compile_source(HUB.format(where=where, post_h=post_h), name="hub", worker=worker)
    assert m.ok, m.findings
    return m


def test_a_feed_hub_high_above_the_floor_is_not_a_wheel(worker):
    model = _hub(worker, 700.0)
    art = articulate(model)
    assert art.joint("hub_axle").type == "continuous"
    assert art.wheels == []
    from procedura_brep.export.mjcf import build_mjcf
    assert build_mjcf(model, art=art).free_root is False  # a spinning joint: the base stays welded


def test_articulating_tessellates_no_part_off_the_floor(worker):
    """Issue 24: whether a continuous joint's subtree reaches the floor is read from the parts'
    exact boxes, before the roundness test that needs the child's mesh: a 207-turn lead screw
    high above the floor took 25 s to tessellate just to be turned down."""
    from procedura_brep.program import model as model_mod
    model = _hub(worker, 700.0)
    model_mod._MESHES.clear()
    assert articulate(model).wheels == []
    assert model.part("hub").digest not in model_mod._MESHES
    assert not model_mod._MESHES  # nor any other part


def test_the_same_hub_reaching_the_floor_is_a_wheel(worker):
    # the hub axis 40 mm up: the hub (r = 40) reaches z = 0, the floor
    model = _hub(worker, 40.0)
    low = min(p.mesh().vertices[:, 2].min() for p in model.parts)
    assert model.part("hub").mesh().vertices[:, 2].min() - low <= TOL.wheel_ground_mm
    art = articulate(model)
    assert art.wheels == ["hub_axle"]


def test_a_box_on_a_continuous_joint_at_the_floor_is_not_a_wheel(worker):
    from procedura_brep.program import compile_source
    src = HUB.format(where="a box", post_h=40.0).replace(
        "return Cylinder(hub_r, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))",
        "return Box(2 * hub_r, 30, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))")
    model = compile_source(src, name="hub", worker=worker)
    assert model.ok, model.findings
    assert articulate(model).wheels == []


def test_a_vertical_spindle_reaching_the_floor_is_not_a_wheel(worker):
    """A round part on a continuous joint whose axis is vertical (a turntable, a gearbox's
    journal through its floor) touches the floor but does not roll on it (issue 27: a gearbox's
    shafts were taken for wheels, and B4 drove them)."""
    from procedura_brep.program import compile_source
    src = HUB.format(where="a vertical spindle beside the base", post_h=40.0).replace(
        'frames("base", top=Location((0, 0, 20)))',
        'frames("base", top=Location((0, 0, 20)), edge=Location((150, 0, 0)))').replace(
        'mate("hub.axle", "post.side"', 'mate("hub.axle", "base.edge"')
    model = compile_source(src, name="hub", worker=worker)
    assert model.ok, model.findings
    low = min(p.mesh().vertices[:, 2].min() for p in model.parts)
    assert model.part("hub").mesh().vertices[:, 2].min() - low <= TOL.wheel_ground_mm  # at the floor
    art = articulate(model)
    assert art.joint("hub_axle").type == "continuous" and abs(art.joint("hub_axle").axis[2]) > 0.99
    assert art.wheels == []


def test_continuous_spinning_hub_is_swept(worker):
    from procedura_brep.sim.sweep import SweepScene
    model = _hub(worker, 700.0)
    art = articulate(model)
    hit = SweepScene(model, art).sweep(art.joint("hub_axle"))
    assert hit.samples == 0 or hit.samples >= 4  # swept over a full turn where it nears the post
    assert hit.depth <= TOL.sim_penetration_mm


@pytest.fixture(scope="module")
def rover(worker):
    from pathlib import Path

    from procedura_brep.program import compile_source
    path = Path(__file__).resolve().parents[2] / "golden" / "rover" / "program.py"
    return compile_source(path.read_text(), name="rover", worker=worker)


def test_rover_wheels_share_one_drive_sign(rover):
    from procedura_brep.articulation.wheels import forward, rolling_direction
    art = articulate(rover)
    assert len(art.wheels) == 6
    ahead = forward(art.root.frame, art.joint(art.wheels[0]).axis)
    rolls = [rolling_direction(art.joint(w).axis) for w in art.wheels]
    assert all(float(r @ ahead) > 0.99 for r in rolls)
    flipped = sorted(w for w in art.wheels if art.joint(w).flipped)
    assert flipped == ["wheel_fr_hub", "wheel_mr_hub", "wheel_rr_hub"]  # the right side
    for w in art.wheels:  # the flip turns the frame about its X: same anchor, axis reversed
        j = art.joint(w)
        mate_z = np.asarray(j.mate.world_frame)[:3, 2]
        assert np.allclose(j.axis, -mate_z if j.flipped else mate_z, atol=1e-12)
        assert np.allclose(j.frame[:3, 3], np.asarray(j.mate.world_frame)[:3, 3])


@pytest.mark.slow
def test_rover_drives_straight_on_one_command_and_fails_without_the_flip(rover, tmp_path, monkeypatch):
    from procedura_brep.sim import run_battery
    b4 = run_battery(rover, out_dir=tmp_path / "ok", checks=["B4"], frames=False).check("B4")
    assert b4.passed, b4.message
    assert abs(b4.measured["yaw_deg"]) <= TOL.drive_max_yaw_deg == b4.limits["yaw_deg"]
    # the planted fault: no flip, so left and right wheels turn against each other
    from procedura_brep.articulation import wheels
    monkeypatch.setattr(wheels, "flip", lambda frame: frame)
    bad = run_battery(rover, out_dir=tmp_path / "bad", checks=["B4"], frames=False).check("B4")
    assert not bad.passed and "one drive sign" in bad.message
    assert abs(bad.measured["yaw_deg"]) > TOL.drive_max_yaw_deg
