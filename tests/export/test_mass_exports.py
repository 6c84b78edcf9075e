"""URDF, MJCF and USD carry the masses a program declares (``@part(mass=...)``, ``hollow=``),
each file written through the one bundle, read back with its own reader."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from procedura_brep import kernel
from procedura_brep.articulation.mass import part_mass, part_mass_detail
from procedura_brep.export.bundle import write_bundle
from procedura_brep.testing.models import compiled

LAMP = (Path(__file__).resolve().parents[1] / "program" / "lamp.py").read_text()
ARM_KG = 0.75


@pytest.fixture(scope="module")
def lamp(worker):
    src = (LAMP.replace('material="painted_aluminium", ', 'material="painted_aluminium", mass=arm_kg, ')
           .replace('material="cast_iron", ', 'material="cast_iron", hollow=base_wall, ')
           .replace("# === params ===\n", "# === params ===\narm_kg = 0.75  # kg\nbase_wall = 2.0  # mm\n"))
    return compiled(src, worker=worker, name="lamp")


@pytest.fixture(scope="module")
def out(lamp, tmp_path_factory):
    root = tmp_path_factory.mktemp("lamp_masses")
    write_bundle(lamp, root, formats="urdf,mjcf,usd")
    return root


def test_the_declarations_change_the_masses(lamp):
    arm, base = part_mass_detail(lamp, "arm"), part_mass_detail(lamp, "base")
    assert (arm.method, arm.props.mass) == ("declared", pytest.approx(ARM_KG, rel=1e-12))
    assert base.method in ("shell-exact", "shell-approx")
    solid_kg = kernel.volume(lamp.part("base").local_shape()) * base.density * 1e-9
    assert base.props.mass < 0.5 * solid_kg  # a 2 mm shell of a 12 mm plate


def base_link_kg(lamp) -> float:
    return part_mass(lamp, "base").mass + part_mass(lamp, "post").mass  # post is static on base


def test_urdf_carries_the_declared_and_shell_masses(lamp, out):
    for name in ("robot.urdf", "robot.mujoco.urdf"):
        root = ET.parse(out / "urdf" / name).getroot()
        mass = {lk.get("name"): float(lk.find("inertial/mass").get("value"))
                for lk in root.iter("link") if lk.find("inertial/mass") is not None}
        assert mass["arm"] == pytest.approx(ARM_KG, rel=1e-9), name
        assert mass["base"] == pytest.approx(base_link_kg(lamp), rel=1e-9), name


def test_mjcf_carries_the_declared_and_shell_masses(lamp, out):
    root = ET.parse(out / "model.xml").getroot()
    mass = {b.get("name"): float(b.find("inertial").get("mass")) for b in root.iter("body")
            if b.find("inertial") is not None}
    assert mass["arm"] == pytest.approx(ARM_KG, rel=1e-9)
    assert mass["base"] == pytest.approx(base_link_kg(lamp), rel=1e-5)  # MuJoCo writes 6 digits


def test_usd_carries_the_declared_and_shell_masses(lamp, out):
    from pxr import Usd, UsdPhysics
    stage = Usd.Stage.Open(str(out / "model.usda"))
    mass = {p.GetName(): UsdPhysics.MassAPI(p).GetMassAttr().Get() for p in stage.Traverse()
            if p.HasAPI(UsdPhysics.MassAPI) and p.HasAPI(UsdPhysics.RigidBodyAPI)}
    assert mass["arm"] == pytest.approx(ARM_KG, rel=1e-6)
    assert mass["base"] == pytest.approx(base_link_kg(lamp), rel=1e-6)


def test_model_xml_balances_inertia_when_loaded_on_its_own(out):
    """The written file keeps the compiler's balanceinertia (MjSpec.to_xml drops it), so a
    moment its 6 digits tipped past A + B >= C is balanced by any loader, not refused."""
    root = ET.parse(out / "model.xml").getroot()
    assert root.find("compiler").get("balanceinertia") == "true"
