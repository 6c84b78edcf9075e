"""Couplings in every export: URDF ``<mimic>`` (both profiles valid, a gear train named by its
head), MJCF ``<equality><joint>`` with the declared polycoef and no servo on the driven joint,
USD attributes in our namespace with no drive on the driven joint (validators clean), and
battery B5 failing when a mimic is missing from the written URDF."""

from __future__ import annotations

import math
import shutil
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

from procedura_brep.articulation import articulate, link_masses
from procedura_brep.export.mjcf import build_mjcf, equality_form
from procedura_brep.export.urdf import urdf_files, urdf_text
from procedura_brep.export.usd import COUPLING_NS, usda_text
from procedura_brep.sim.fidelity import check_b5, check_b6

SRC = (Path(__file__).parents[1] / "program" / "transmission.py").read_text()
RACK = 'couple("rack_slide", "pinion_hub", "rack_pinion", pinion_teeth="z_pinion", module="gear_m")'
#: The rack driven by the wheel instead (a gear train: pinion -> wheel -> rack).
TRAIN = SRC.replace(RACK, 'couple("rack_slide", "wheel_hub", "rack_pinion", pinion_teeth="z_wheel", '
                          'module="gear_m")')


@pytest.fixture(scope="module")
def model(worker):
    m = worker.compile(SRC)
    assert not [f for f in m.findings if f.severity == "error"]
    return m


def _mimics(text: str) -> dict[str, dict[str, str]]:
    root = ET.fromstring(text)
    return {j.get("name"): j.find("mimic").attrib for j in root.iter("joint") if j.find("mimic") is not None}


def test_urdf_mimics_in_si_in_both_profiles(model):
    for profile in ("strict", "mujoco"):
        got = _mimics(urdf_text(model, profile=profile))
        assert set(got) == {"wheel_hub", "rack_slide", "nut_slide"}
        assert got["wheel_hub"]["joint"] == "pinion_hub"
        assert float(got["wheel_hub"]["multiplier"]) == pytest.approx(-12 / 36, rel=1e-11)
        assert float(got["rack_slide"]["multiplier"]) == pytest.approx(0.012, rel=1e-11)  # m/rad
        assert got["nut_slide"]["joint"] == "screw_hub"
        assert float(got["nut_slide"]["multiplier"]) == pytest.approx(-0.004 / (2 * math.pi), rel=1e-11)


def test_a_gear_train_mimics_its_head_with_the_product(worker):
    m = worker.compile(TRAIN)
    art = articulate(m)
    assert art.root_driver("rack_slide") == ("pinion_hub", pytest.approx(-0.012), 0.0)
    got = _mimics(urdf_text(m, art=art))
    assert got["rack_slide"]["joint"] == "pinion_hub"  # URDF consumers resolve one level only
    assert float(got["rack_slide"]["multiplier"]) == pytest.approx(36e-3 * -12 / 36, rel=1e-11)
    # MJCF keeps the chain: the rack follows the wheel
    spec = build_mjcf(m, art=art).spec
    eq = {e.name: (e.name1, e.name2) for e in spec.equalities}
    assert eq["rack_slide__wheel_hub"] == ("wheel_hub", "rack_slide")


def test_urdf_stays_valid_for_yourdfpy_and_check_urdf(model, tmp_path):
    import yourdfpy
    for rel, data in urdf_files(model).items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    u = yourdfpy.URDF.load(str(tmp_path / "robot.urdf"), build_scene_graph=True, load_meshes=False)
    assert u.validate()
    assert u.actuated_joint_names == ["pinion_hub", "screw_hub"]  # the driven joints mimic
    tool = shutil.which("check_urdf")
    if tool:
        assert subprocess.run([tool, str(tmp_path / "robot.urdf")], capture_output=True).returncode == 0
    # MuJoCo's URDF importer turns each mimic into a joint equality
    assert mujoco.MjModel.from_xml_path(str(tmp_path / "robot.mujoco.urdf")).neq == 3


def test_b5_fails_when_a_mimic_is_missing(model, tmp_path):
    art = articulate(model)
    for rel, data in urdf_files(model, art=art).items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    masses = link_masses(model, art)
    assert check_b5(art, masses, tmp_path).passed
    strict = tmp_path / "robot.urdf"
    text = strict.read_text()
    line = next(ln for ln in text.splitlines() if '<mimic joint="screw_hub"' in ln)
    strict.write_text(text.replace(line + "\n", ""))
    res = check_b5(art, masses, tmp_path)
    assert not res.passed
    assert "URDF joint 'nut_slide': mimic None where the couplings say ('screw_hub'" in res.message


def test_mjcf_equality_polycoef_and_no_servo_on_driven_joints(model):
    art = articulate(model)
    spec = build_mjcf(model, art=art).spec
    m = spec.compile()
    assert sorted(m.actuator(i).name for i in range(m.nu)) == ["pinion_hub", "screw_hub"]
    eq = {e.name: e for e in spec.equalities}
    assert set(eq) == {"wheel_hub__pinion_hub", "rack_slide__pinion_hub", "nut_slide__screw_hub"}
    for c in art.couplings:  # q1 = a0 + a1 q2 with |a1| >= 1 (see export/mjcf.py)
        e = eq[c.name]
        a1 = e.data[1]
        assert e.type == mujoco.mjtEq.mjEQ_JOINT and abs(a1) >= 1
        if e.name1 == c.driven:
            assert (e.name2, a1) == (c.driver, pytest.approx(c.ratio, rel=1e-12))
        else:
            assert (e.name1, e.name2) == (c.driver, c.driven)
            assert a1 == pytest.approx(1 / c.ratio, rel=1e-12)
        assert np.all(e.data[2:] == 0) and e.data[0] == 0
    assert equality_form(art.couplings[0])[:2] == ("pinion_hub", "wheel_hub")  # |-1/3| < 1: flipped
    xml = spec.to_xml()
    assert '<joint name="wheel_hub__pinion_hub" joint1="pinion_hub" joint2="wheel_hub" polycoef="0 -3 0 0 0"' in xml


def test_usd_coupling_attributes_and_no_drive(model, tmp_path):
    from pxr import Usd, UsdPhysics
    art = articulate(model)
    path = tmp_path / "model.usda"
    path.write_text(usda_text(model, art=art))
    stage = Usd.Stage.Open(str(path))
    root = stage.GetDefaultPrim().GetPath()
    wheel = stage.GetPrimAtPath(f"{root}/joints/wheel_hub")
    rack = stage.GetPrimAtPath(f"{root}/joints/rack_slide")
    assert wheel.GetRelationship(f"{COUPLING_NS}:driver").GetTargets() == [root.AppendPath("joints/pinion_hub")]
    assert wheel.GetAttribute(f"{COUPLING_NS}:type").Get() == "gear"
    assert wheel.GetAttribute(f"{COUPLING_NS}:ratio").Get() == pytest.approx(-1 / 3)  # deg per deg
    assert rack.GetAttribute(f"{COUPLING_NS}:ratio").Get() == pytest.approx(0.012 / math.degrees(1))  # m/deg
    assert not wheel.HasAPI(UsdPhysics.DriveAPI, "angular")
    assert stage.GetPrimAtPath(f"{root}/joints/pinion_hub").HasAPI(UsdPhysics.DriveAPI, "angular")
    res = check_b6(art, path)
    assert res.passed, res.message


FOURBAR = (Path(__file__).parents[1] / "program" / "fourbar.py").read_text()


def test_a_linkage_is_a_tree_plus_a_cut_in_every_format(worker, tmp_path):
    import yourdfpy
    from pxr import Usd, UsdPhysics
    m = worker.compile(FOURBAR)
    art = articulate(m)
    # MJCF: a connect at the cut's anchor in the rocker's frame; only the crank has a servo
    spec = build_mjcf(m, art=art).spec
    (eq,) = spec.equalities
    assert (eq.name, eq.type, eq.name1, eq.name2) == ("loop_pin", mujoco.mjtEq.mjEQ_CONNECT, "rocker", "coupler")
    assert eq.data[:3] == pytest.approx([0.0, 0.09, 0.008])
    mj = spec.compile()
    assert [mj.actuator(i).name for i in range(mj.nu)] == ["crank_base"]
    assert mj.njnt == 3  # the cut is no joint
    # URDF: the tree, the cut named in a comment, no mimic; yourdfpy valid
    for rel, data in urdf_files(m, art=art).items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    text = (tmp_path / "robot.urdf").read_text()
    assert "<!-- loop closure: mate loop_pin (revolute) joins link coupler to link rocker" in text
    assert "<mimic" not in text and 'name="loop_pin"' not in text
    assert yourdfpy.URDF.load(str(tmp_path / "robot.urdf"), build_scene_graph=True, load_meshes=False).validate()
    assert check_b5(art, link_masses(m, art), tmp_path).passed
    # USD: the cut joint excluded from the articulation, undriven; validators clean
    path = tmp_path / "model.usda"
    path.write_text(usda_text(m, art=art))
    stage = Usd.Stage.Open(str(path))
    root = stage.GetDefaultPrim().GetPath()
    cut = UsdPhysics.Joint(stage.GetPrimAtPath(f"{root}/joints/loop_pin"))
    assert cut.GetExcludeFromArticulationAttr().Get() is True
    assert not cut.GetPrim().HasAPI(UsdPhysics.DriveAPI, "angular")
    rocker = stage.GetPrimAtPath(f"{root}/joints/rocker_base")
    assert rocker.GetAttribute(f"{COUPLING_NS}:type").Get() == "linkage"
    assert not rocker.HasAPI(UsdPhysics.DriveAPI, "angular")
    res = check_b6(art, path)
    assert res.passed, res.message
