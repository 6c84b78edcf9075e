"""A program's own materials reach every export, the PBR render and the masses (issue 12.5):
each format is read back and compared with the declared entry, not with the built-in table."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.export.bundle import write_bundle
from procedura_brep.export.step import read_step_parts
from procedura_brep.testing.exports import glb_json

LAMP = (Path(__file__).resolve().parents[1] / "program" / "lamp.py").read_text()
RED = (0.8, 0.1, 0.1)
TEAL = (0.05, 0.6, 0.55)
DECLS = ('material("lamp_red", base="painted_aluminium", rgb=(0.8, 0.1, 0.1), roughness=0.35, '
         'metalness=0.2, wear=0.25)\n'
         'material("teal_resin", rgb=(0.05, 0.6, 0.55), roughness=0.7, metalness=0.0, density=1234, '
         'material_class="polymer")\n\n')


def lamp_source(decls: str = DECLS) -> str:
    return (LAMP.replace("# === parts ===\n", "# === parts ===\n" + decls)
            .replace('material="painted_aluminium"', 'material="lamp_red"')
            .replace('material="brushed_steel"', 'material="teal_resin"'))


@pytest.fixture(scope="module")
def lamp(worker):
    from procedura_brep.program import compile_source
    return compile_source(lamp_source(), name="lamp", worker=worker)


@pytest.fixture(scope="module")
def bundle(lamp, tmp_path_factory):
    out = tmp_path_factory.mktemp("matlib")
    write_bundle(lamp, out)
    return out


def test_the_compiled_model_carries_the_declared_library(lamp):
    assert lamp.ok, [f.message for f in lamp.findings]
    assert list(lamp.declared_materials) == ["lamp_red", "teal_resin"]
    red = lamp.material_of(lamp.part("arm"))
    assert (red.rgb, red.roughness, red.metalness, red.wear) == (RED, 0.35, 0.2, 0.25)
    assert red.density == 2700 and red.material_class == "metal"  # from the base
    assert lamp.material_of(lamp.part("base")).name == "cast_iron"  # built-ins stay the default


def test_the_library_survives_the_sandbox_json_boundary(lamp):
    from procedura_brep.program.model import to_json
    from procedura_brep.program.trust import model_from_json as from_json
    back = from_json(json.loads(json.dumps(to_json(lamp))))
    assert back.materials == lamp.materials


def test_step_colours(lamp, bundle):
    got = {p.name: p.rgb for p in read_step_parts((bundle / "model.step").read_bytes())}
    assert np.allclose(got["arm"], RED, atol=1 / 255) and np.allclose(got["post"], TEAL, atol=1 / 255)


def test_obj_mtl(bundle):
    mtl = (bundle / "model.mtl").read_text()
    block = mtl.split("newmtl arm_lamp_red\n")[1].split("\n\n")[0]
    assert "Kd 0.800000 0.100000 0.100000" in block and "Pr 0.350000" in block and "Pm 0.200000" in block
    assert "Kd 0.050000 0.600000 0.550000" in mtl.split("newmtl post_teal_resin\n")[1]


def test_glb_pbr(bundle):
    from procedura_brep.export.glb import srgb_to_linear
    tree = glb_json(bundle / "model.glb")
    mats = {m["name"]: m["pbrMetallicRoughness"] for m in tree["materials"]}
    pbr = mats["arm_lamp_red"]
    assert pbr["baseColorFactor"] == pytest.approx([*srgb_to_linear(RED), 1.0], abs=1e-9)
    assert pbr["metallicFactor"] == pytest.approx(0.2) and pbr["roughnessFactor"] == pytest.approx(0.35)


def test_usd_preview_surface(bundle):
    from pxr import Usd, UsdShade
    stage = Usd.Stage.Open(str(bundle / "model.usda"))
    sh = UsdShade.Shader(stage.GetPrimAtPath("/lamp/Looks/teal_resin/PreviewSurface"))
    from procedura_brep.export.glb import srgb_to_linear  # UsdPreviewSurface colours are linear
    assert tuple(sh.GetInput("diffuseColor").Get()) == pytest.approx(tuple(srgb_to_linear(TEAL)), abs=1e-6)
    assert sh.GetInput("roughness").Get() == pytest.approx(0.7)


def test_urdf_and_mjcf_colours(bundle):
    robot = ET.parse(bundle / "urdf" / "robot.urdf").getroot()
    rgba = {m.get("name"): m.find("color").get("rgba") for m in robot.findall("material")}
    assert [float(x) for x in rgba["lamp_red"].split()] == pytest.approx([*RED, 1.0])
    mj = ET.parse(bundle / "model.xml").getroot()
    geom = next(g for g in mj.iter("geom") if g.get("name") == "post")
    assert [float(x) for x in geom.get("rgba").split()] == pytest.approx([*TEAL, 1.0], abs=1e-6)


def test_masses_use_the_declared_density(lamp):
    from procedura_brep.articulation.mass import part_mass
    post = lamp.part("post")
    vol = kernel.volume(post.local_shape())
    assert part_mass(lamp, "post").mass == pytest.approx(vol * 1234e-9, rel=1e-9)


def test_pbr_render_and_its_cache_key_follow_the_library(lamp, worker):
    from procedura_brep.program import compile_source
    from procedura_brep.render.api import render_images
    from procedura_brep.render.cache import geometry_key, image_key
    blue = compile_source(lamp_source(DECLS.replace("rgb=(0.8, 0.1, 0.1)", "rgb=(0.1, 0.1, 0.8)")),
                          name="lamp", worker=worker)
    assert geometry_key(blue) == geometry_key(lamp)  # paint does not change the geometry
    s = {"mode": "pbr", "size": 64, "view": "iso_se"}
    assert image_key(blue, geometry_key(blue), s) != image_key(lamp, geometry_key(lamp), s)
    a = np.asarray(render_images(lamp, ["iso_se"], mode="pbr", size=96)["iso_se"], float)
    b = np.asarray(render_images(blue, ["iso_se"], mode="pbr", size=96)["iso_se"], float)
    changed = np.abs(a - b).sum(axis=2) > 30
    assert changed.any()
    assert (a[changed][:, 0] - a[changed][:, 2]).mean() > 0 > (b[changed][:, 0] - b[changed][:, 2]).mean()


def test_paint_keeps_every_part_cached(worker, tmp_path):
    """A material edit does not change any part key: every part is loaded, none rebuilt."""
    from procedura_brep.program import compile_source
    first = compile_source(lamp_source(), name="lamp", worker=worker)
    again = compile_source(lamp_source(DECLS.replace("wear=0.25", "wear=0.9")), name="lamp", worker=worker)
    assert [p.cache_key for p in again.parts] == [p.cache_key for p in first.parts]
    assert again.material_of(again.part("arm")).wear == 0.9


def test_the_parent_checks_the_library_the_child_returns(lamp):
    """The sandbox child is untrusted: a declared entry out of range, or one that redefines a
    built-in, or a part naming a material outside the library, is a ResultError."""
    from procedura_brep.program.model import to_json
    from procedura_brep.program.trust import ResultError
    from procedura_brep.program.trust import model_from_json as from_json
    good = json.loads(json.dumps(to_json(lamp)))
    for mutate, message in (
            (lambda d: d["materials"][0].update(roughness=7), "roughness = 7 is outside"),
            (lambda d: d["materials"][0].update(name="steel"), "redeclare the built-in material"),
            (lambda d: d["parts"][2].update(material="lamp_blue"), "is not a library material")):
        bad = json.loads(json.dumps(good))
        mutate(bad)
        with pytest.raises(ResultError, match=message):
            from_json(bad)
