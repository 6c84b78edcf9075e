"""The cylindrical mate end to end: a table collar on a column slides and turns; every export
maps it (MJCF slide + hinge, URDF prismatic + revolute through a carrier, USD D6 joint); B0-B7
pass; a stop in the way of either DOF fails B2."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.articulation import articulate
from procedura_brep.config import TOL
from procedura_brep.export.bundle import write_bundle
from procedura_brep.sim import run_battery
from procedura_brep.sim.sweep import SweepScene

from .agreement import assert_joints_agree
from .collar import program


def _compile(worker, **kw):
    from procedura_brep.program import compile_source
    m = compile_source(program(**kw), name="collar", worker=worker)
    assert m.ok, [f.message for f in m.findings]
    return m


@pytest.fixture(scope="module")
def collar(worker):
    return _compile(worker)


def test_the_column_is_not_cut_and_the_collar_is_bored(collar):
    import math
    column = kernel.volume(collar.part("column").local_shape())
    assert column >= math.pi * 20.0**2 * 400.0 - 1e-3  # male="parent": nothing cut from it


def test_articulation_has_slide_and_turn_on_one_axis(collar):
    art = articulate(collar)
    j = art.joint("collar_bore")
    assert j.type == "cylindrical"
    assert (j.lower, j.upper) == pytest.approx((-0.1, 0.12))
    assert (j.turn_lower, j.turn_upper) == pytest.approx((np.radians(-120), np.radians(120)))
    slide, turn = j.dofs()
    assert (slide.name, slide.type, turn.name, turn.type) == (
        "collar_bore__slide", "prismatic", "collar_bore__turn", "revolute")


def test_free_turn_is_continuous(worker):
    art = articulate(_compile(worker, angle_limits="None"))
    assert art.joint("collar_bore").dofs()[1].type == "continuous"


def test_exports_agree_on_both_dof(collar, tmp_path):
    import mujoco
    art = articulate(collar)
    write_bundle(collar, tmp_path, formats=("urdf", "usd", "mjcf"))
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "model.xml"))
    body = m.body("collar")
    names = {m.joint(i).name: int(m.jnt_type[i]) for i in range(m.njnt) if m.jnt_bodyid[i] == body.id}
    assert names == {"collar_bore__slide": int(mujoco.mjtJoint.mjJNT_SLIDE),
                     "collar_bore__turn": int(mujoco.mjtJoint.mjJNT_HINGE)}
    urdf = (tmp_path / "urdf" / "robot.urdf").read_text()
    assert '<joint name="collar_bore__slide" type="prismatic">' in urdf
    assert '<joint name="collar_bore__turn" type="revolute">' in urdf
    assert '<link name="collar_bore__slide">' in urdf  # the tiny-mass carrier
    usda = (tmp_path / "model.usda").read_text()
    assert 'def PhysicsJoint "collar_bore"' in usda and "PhysicsLimitAPI:rotY" in usda
    assert_joints_agree(tmp_path, art)


@pytest.mark.slow
def test_collar_passes_the_battery(collar, tmp_path):
    report = run_battery(collar, out_dir=tmp_path, frames=False)
    assert report.passed, [c.message for c in report.checks if not c.passed]
    rows = report.check("B2").measured["joints"]
    assert rows["collar_bore__slide"]["reach"] >= TOL.sweep_reach
    assert rows["collar_bore__turn"]["reach"] >= TOL.sweep_reach


@pytest.mark.parametrize("dof", ["turn", "slide"])
def test_a_stop_in_the_way_of_either_dof_is_hit(worker, dof):
    model = _compile(worker, stop=dof)
    art = articulate(model)
    hit = SweepScene(model, art).sweep(art.joint("collar_bore"))
    assert hit.depth > TOL.sim_penetration_mm and hit.pair == ("collar", "stop"), hit
    assert hit.at.startswith(dof)


def test_without_the_stop_both_dof_sweep_clear(collar):
    art = articulate(collar)
    hit = SweepScene(collar, art).sweep(art.joint("collar_bore"))
    assert hit.depth <= TOL.sim_penetration_mm and hit.samples > 0
