"""The exporters take an Articulation and write exactly it: base, wheels, drives, limits.

Each test hands the exporters an articulation that differs from what :func:`articulate` would
derive (a free base on a wheel-less lamp, a welded one, a velocity drive on a limited joint, a
flagged wheel, changed limits and effort), so an exporter that re-derives any of them fails.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from procedura_brep.articulation import Articulation, articulate
from procedura_brep.export.mjcf import build_mjcf
from procedura_brep.export.urdf import urdf_text
from procedura_brep.export.usd import usd_stage

LAMP = "arm_pivot"


@pytest.fixture(scope="module")
def lamp(worker):
    from tests.articulation.models import compile_lamp
    model = compile_lamp(worker)
    assert model.ok, model.findings
    return model


def _with_joint(art: Articulation, name: str, **changes) -> Articulation:
    joints = [dataclasses.replace(j, **changes) if j.name == name else j for j in art.joints]
    return dataclasses.replace(art, joints=joints)


def _mj_free(build) -> bool:
    import mujoco
    m = build.spec.compile()
    return any(int(m.jnt_type[i]) == int(mujoco.mjtJoint.mjJNT_FREE) for i in range(m.njnt))


def _usd_fixed(model, art) -> list[str]:
    from pxr import UsdPhysics
    stage = usd_stage(model, art=art)
    return [p.GetName() for p in stage.Traverse() if p.IsA(UsdPhysics.FixedJoint)]


def test_derived_lamp_is_welded(lamp):
    art = articulate(lamp)
    assert art.base == "welded" and art.wheels == []
    assert art.joint(LAMP).drive == "position"
    assert not _mj_free(build_mjcf(lamp, art=art))
    assert _usd_fixed(lamp, art) == [f"{art.root.name}__world"]


def test_a_free_base_given_is_written_free(lamp):
    """The lamp has no wheels; handed base="free", MJCF gets a free root and USD no world weld."""
    art = dataclasses.replace(articulate(lamp), base="free")
    b = build_mjcf(lamp, art=art)
    assert b.free_root and _mj_free(b)
    assert _usd_fixed(lamp, art) == []


def test_a_welded_base_given_is_written_welded(lamp):
    """A flagged wheel with base="welded": the exporters keep the base welded (no free joint,
    a USD world weld) and report the wheel as given."""
    art = articulate(lamp)
    art = dataclasses.replace(art, wheels=[LAMP], base="welded")
    b = build_mjcf(lamp, art=art)
    assert b.wheels == [LAMP] and not b.free_root and not _mj_free(b)
    assert _usd_fixed(lamp, art) == [f"{art.root.name}__world"]
    assert art.wheel_links == ["arm"]


def test_a_velocity_drive_given_is_a_velocity_servo(lamp):
    import mujoco
    from pxr import UsdPhysics
    art = _with_joint(articulate(lamp), LAMP, drive="velocity")
    m = build_mjcf(lamp, art=art).spec.compile()
    a = m.actuator(LAMP)
    # a velocity servo has no position feedback (biasprm[1] = 0) and damping -kv (biasprm[2])
    assert a.biasprm[1] == 0.0 and a.biasprm[2] < 0.0
    assert tuple(a.ctrlrange) == pytest.approx((-art.joint(LAMP).velocity, art.joint(LAMP).velocity))
    jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, LAMP)
    assert bool(m.jnt_limited[jid])  # the limits stay
    stage = usd_stage(lamp, art=art)  # keep the stage alive while its prims are read
    prim = stage.GetPrimAtPath(f"/lamp/joints/{LAMP}")
    drive = UsdPhysics.DriveAPI(prim, "angular")
    assert drive.GetTargetVelocityAttr().HasAuthoredValue()
    assert not drive.GetTargetPositionAttr().HasAuthoredValue()
    # and the derived (position) drive is a position servo with a target position
    m0 = build_mjcf(lamp, art=articulate(lamp)).spec.compile()
    assert m0.actuator(LAMP).biasprm[1] < 0.0
    stage0 = usd_stage(lamp, art=articulate(lamp))
    prim0 = stage0.GetPrimAtPath(f"/lamp/joints/{LAMP}")
    assert UsdPhysics.DriveAPI(prim0, "angular").GetTargetPositionAttr().HasAuthoredValue()


def test_limits_and_effort_given_are_written(lamp):
    art = _with_joint(articulate(lamp), LAMP, lower=-0.25, upper=0.5, effort=7.5, velocity=1.25)
    robot = ET.fromstring(urdf_text(lamp, art=art))
    lim = robot.find(f"joint[@name='{LAMP}']/limit")
    assert {k: float(v) for k, v in lim.attrib.items()} == {
        "lower": -0.25, "upper": 0.5, "effort": 7.5, "velocity": 1.25}
    import mujoco
    m = build_mjcf(lamp, art=art).spec.compile()
    jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, LAMP)
    assert tuple(m.jnt_range[jid]) == pytest.approx((-0.25, 0.5))
    assert tuple(m.actuator(LAMP).forcerange) == pytest.approx((-7.5, 7.5))
    from pxr import UsdPhysics
    stage = usd_stage(lamp, art=art)
    j = UsdPhysics.RevoluteJoint(stage.GetPrimAtPath(f"/lamp/joints/{LAMP}"))
    assert j.GetUpperLimitAttr().Get() == pytest.approx(np.degrees(0.5))


def test_a_position_drive_without_limits_is_refused(lamp):
    from procedura_brep.articulation import ArticulationError
    art = _with_joint(articulate(lamp), LAMP, type="continuous", lower=None, upper=None)
    with pytest.raises(ArticulationError, match="position drive but no limits"):
        build_mjcf(lamp, art=art)


def test_the_battery_takes_the_articulation_it_is_given(lamp, tmp_path):
    """Handed a lamp articulation with its arm flagged as a wheel on a free base, the battery
    exports that (a free root in model.xml) and drives that wheel in B4 (not skipped)."""
    import mujoco

    from procedura_brep.sim import run_battery
    art = dataclasses.replace(articulate(lamp), wheels=[LAMP], base="free")
    report = run_battery(lamp, out_dir=tmp_path, checks=["B4"], frames=False, art=art)
    b4 = report.check("B4")
    assert not b4.skipped and b4.measured["wheels"] == 1
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "model.xml"))
    assert any(int(m.jnt_type[i]) == int(mujoco.mjtJoint.mjJNT_FREE) for i in range(m.njnt))
