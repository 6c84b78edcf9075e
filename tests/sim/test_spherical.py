"""A spherical mate end to end: MJCF ball, strict URDF as three revolutes, MuJoCo-profile URDF
ball, USD SphericalJoint; the battery passes and every format agrees on the anchor."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.export.bundle import write_bundle
from procedura_brep.mates.placement import rot_x, trans
from procedura_brep.program.model import CompiledModel
from procedura_brep.sim import run_battery

from ..articulation.models import mate, part
from .agreement import TOL_M, TOL_RAD, assert_joints_agree

CONE_DEG = 30.0
ANCHOR_MM = np.array([10.0, -5.0, 35.0])


@pytest.fixture(scope="module")
def ball_model() -> CompiledModel:
    """A plate and a post on a ball 3 mm above it; the joint axis tilted 20 deg about X."""
    import build123d as bd
    base = bd.Box(120, 120, 20, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN))
    post = bd.Sphere(12) + bd.Cylinder(8, 80, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN))
    frame = trans(*ANCHOR_MM) @ rot_x(20.0)
    return CompiledModel(
        name="ball", params={},
        parts=[part("base", base), part("post", post, placement=frame, material="aluminium")],
        mates=[mate("post_ball", "post", "base", kind="kinematic", mtype="spherical", frame=frame,
                    options={"cone": CONE_DEG, "effort": 5.0, "velocity": 2.0})])


@pytest.fixture(scope="module")
def bundle(ball_model, tmp_path_factory):
    out = tmp_path_factory.mktemp("ball")
    write_bundle(ball_model, out, formats=("urdf", "usd", "mjcf"))
    return out


def test_mjcf_ball_joint_at_the_anchor(bundle):
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(bundle / "model.xml"))
    j = m.joint("post_ball")
    assert int(j.type[0]) == mujoco.mjtJoint.mjJNT_BALL
    assert bool(m.jnt_limited[j.id]) and m.jnt_range[j.id] == pytest.approx([0, np.radians(CONE_DEG)])
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    assert np.linalg.norm(d.xanchor[j.id] - ANCHOR_MM / 1000) <= TOL_M
    # three hold servos on the ball, force-limited by the mate's effort, within +-cone
    names = sorted(m.actuator(i).name for i in range(m.nu))
    assert names == ["post_ball__x", "post_ball__y", "post_ball__z"]
    assert np.allclose(m.actuator_forcerange, [[-5.0, 5.0]] * 3)
    assert np.allclose(m.actuator_ctrlrange, [[-np.radians(CONE_DEG), np.radians(CONE_DEG)]] * 3)


def test_strict_urdf_three_orthogonal_revolutes_at_the_anchor(ball_model, bundle):
    import yourdfpy
    u = yourdfpy.URDF.load(str(bundle / "urdf" / "robot.urdf"), load_meshes=False)
    assert u.validate()
    names = [f"post_ball__{a}" for a in "xyz"]
    assert sorted(u.joint_map) == names
    frame = articulate(ball_model).joint("post_ball").frame
    axes = []
    for k, name in enumerate(names):
        j = u.joint_map[name]
        assert j.type == "revolute"
        assert (j.limit.lower, j.limit.upper) == pytest.approx(
            (-np.radians(CONE_DEG), np.radians(CONE_DEG)))
        assert j.limit.effort == 5.0 and j.limit.velocity == 2.0
        t = u.get_transform(j.child, u.base_link)
        assert np.linalg.norm(t[:3, 3] - ANCHOR_MM / 1000) <= TOL_M
        axes.append(t[:3, :3] @ j.axis)
        assert np.allclose(axes[-1], frame[:3, k], atol=TOL_RAD)
    assert np.allclose(np.array(axes) @ np.array(axes).T, np.eye(3), atol=1e-12)
    for helper in ("post_ball__x", "post_ball__y"):
        assert 0 < u.link_map[helper].inertial.mass <= 1e-6


def test_mujoco_urdf_keeps_a_limited_ball(bundle):
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(bundle / "urdf" / "robot.mujoco.urdf"))
    j = m.joint("post_ball")
    assert int(j.type[0]) == mujoco.mjtJoint.mjJNT_BALL
    assert bool(m.jnt_limited[j.id]) and m.jnt_range[j.id] == pytest.approx([0, np.radians(CONE_DEG)])


def test_usd_spherical_joint_with_cone_limits(bundle):
    from pxr import Usd, UsdPhysics

    from procedura_brep.export.usd import usd_joint_frames
    stage = Usd.Stage.Open(str(bundle / "model.usda"))
    prim = stage.GetPrimAtPath("/ball/joints/post_ball")
    assert prim.IsA(UsdPhysics.SphericalJoint)
    sj = UsdPhysics.SphericalJoint(prim)
    assert sj.GetAxisAttr().Get() == "X"
    assert sj.GetConeAngle0LimitAttr().Get() == pytest.approx(CONE_DEG)
    assert sj.GetConeAngle1LimitAttr().Get() == pytest.approx(CONE_DEG)
    anchor, axis = usd_joint_frames(stage)["post_ball"]
    assert np.linalg.norm(anchor - ANCHOR_MM / 1000) <= TOL_M
    assert np.allclose(axis, [0, -np.sin(np.radians(20)), np.cos(np.radians(20))], atol=TOL_RAD)


def test_every_format_agrees_on_the_anchor(ball_model, bundle):
    assert_joints_agree(bundle, articulate(ball_model))


def test_battery_passes(ball_model, tmp_path):
    report = run_battery(ball_model, out_dir=tmp_path, frames=False)
    assert report.passed, [c.message for c in report.checks if not c.passed]
    for cid in ("B0", "B5", "B6"):
        c = report.check(cid)
        assert not c.skipped and c.measured["anchor_err_m"] <= TOL_M, cid
    assert report.check("B1").measured["max_joint_speed"] <= report.check("B1").limits["max_joint_speed"]
