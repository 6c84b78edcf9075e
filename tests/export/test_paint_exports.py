"""A colour block (``@paint``) shows with its own material in every export, in its painted
part's link (issue 13, item 6): each file is read back, not compared as bytes."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from procedura_brep.export.bundle import write_bundle
from procedura_brep.export.step import read_step_parts
from procedura_brep.materials import MATERIALS

from ..program.painted import painted_lamp

RUBBER = MATERIALS["rubber"].rgb
ALU = MATERIALS["painted_aluminium"].rgb


@pytest.fixture(scope="module")
def lamp(worker):
    from procedura_brep.program import compile_source
    model = compile_source(painted_lamp(), name="lamp", worker=worker)
    assert model.ok, [f.message for f in model.findings]
    return model


@pytest.fixture(scope="module")
def bundle(lamp, tmp_path_factory):
    out = tmp_path_factory.mktemp("paint")
    write_bundle(lamp, out)
    return out


def test_step_has_the_block_as_a_product_with_its_colour(bundle):
    got = {p.name: p.rgb for p in read_step_parts((bundle / "model.step").read_bytes())}
    assert list(got) == ["base", "post", "arm", "arm_tip"]
    assert np.allclose(got["arm_tip"], RUBBER, atol=1 / 255)
    assert np.allclose(got["arm"], ALU, atol=1 / 255)


def test_obj_has_a_group_with_the_block_material(bundle):
    from procedura_brep.export.obj import read_obj_groups
    groups = read_obj_groups((bundle / "model.obj").read_text())
    assert groups["arm_tip"] > 0 and groups["arm"] > 0
    obj = (bundle / "model.obj").read_text()
    assert "g arm_tip\nusemtl arm_tip_rubber\n" in obj
    mtl = (bundle / "model.mtl").read_text().split("newmtl arm_tip_rubber\n")[1].split("\n\n")[0]
    assert "Kd " + " ".join(f"{c:.6f}" for c in RUBBER) in mtl


def test_glb_has_a_mesh_with_the_block_pbr_material(bundle):
    from procedura_brep.export.glb import srgb_to_linear
    from procedura_brep.testing.exports import glb_json, glb_node_material
    mat = glb_node_material(glb_json(bundle / "model.glb"), "arm_tip")
    assert mat["name"] == "arm_tip_rubber"
    assert mat["pbrMetallicRoughness"]["baseColorFactor"] == pytest.approx(
        [*srgb_to_linear(np.array(RUBBER)), 1.0], abs=1e-9)


def test_usd_has_the_block_prim_in_its_part_body_with_its_material(bundle):
    from pxr import Usd, UsdShade
    stage = Usd.Stage.Open(str(bundle / "model.usda"))
    prim = stage.GetPrimAtPath("/lamp/arm/arm_tip")
    assert prim.IsValid() and prim.GetTypeName() == "Mesh"
    bound = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
    assert bound.GetPath().name == "rubber"


def test_urdf_and_mjcf_show_the_block_as_a_visual_of_the_part_link(bundle):
    robot = ET.parse(bundle / "urdf" / "robot.urdf").getroot()
    link = next(lk for lk in robot.findall("link") if lk.get("name") == "arm")
    visuals = {v.get("name"): v.find("material").get("name") for v in link.findall("visual")}
    assert visuals == {"arm": "painted_aluminium", "arm_tip": "rubber"}
    assert "arm_tip" not in {lk.get("name") for lk in robot.findall("link")}
    mj = ET.parse(bundle / "model.xml").getroot()
    body = next(b for b in mj.iter("body") if b.get("name") == "arm")
    geom = next(g for g in body.findall("geom") if g.get("name") == "arm_tip")
    assert [float(x) for x in geom.get("rgba").split()] == pytest.approx([*RUBBER, 1.0], abs=1e-6)


def test_mates_json_and_the_part_rows_name_each_block_s_part(lamp):
    """A block joins its part by no mate: mates.json says which part it belongs to, and so do
    report.json's part rows (a reader would otherwise see an unmated part)."""
    from procedura_brep.export.records import mates_json, part_rows
    graph = mates_json(lamp)
    assert graph["blocks"] == {"arm_tip": "arm"}
    rows = {r["name"]: r for r in part_rows(lamp)}
    assert rows["arm_tip"]["block_of"] == "arm" and "block_of" not in rows["arm"]
