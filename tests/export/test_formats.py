"""Every format of the bundle: names, materials, and cross-format joint agreement (<= 1e-6)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.articulation import articulate, link_masses
from procedura_brep.export.bundle import FORMATS, parse_formats, write_bundle
from procedura_brep.export.obj import read_obj_groups
from procedura_brep.sim.fidelity import angle, expected_frames, mj_joint_frames

LAMP = Path(__file__).resolve().parents[1] / "program" / "lamp.py"


def compile_lamp(worker):
    """The test lamp with arm limits (-45, 45) (its own (-60, 60) drives the arm into the base)."""
    from procedura_brep.program import compile_source
    src = LAMP.read_text().replace("limits=(-60, 60)", "limits=(-45, 45)")
    return compile_source(src, name="lamp", worker=worker)

TOL_M = 1e-6
TOL_RAD = 1e-6


@pytest.fixture(scope="module")
def lamp(worker):
    return compile_lamp(worker)


@pytest.fixture(scope="module")
def bundle(lamp, tmp_path_factory):
    out = tmp_path_factory.mktemp("lamp")
    return out, write_bundle(lamp, out)


def test_bundle_files(bundle):
    out, files = bundle
    for rel in ("model.step", "model.obj", "model.mtl", "model.glb", "model.usda", "model.xml",
                "urdf/robot.urdf", "urdf/robot.mujoco.urdf", "urdf/meshes/arm.stl"):
        assert rel in files and (out / rel).stat().st_size > 0, rel
    stems = [p.stem for p in (out / "urdf" / "meshes").iterdir()]
    assert len(stems) == len(set(stems))


def test_parse_formats():
    assert parse_formats(None) == FORMATS
    assert parse_formats("urdf, step") == ("step", "urdf")
    with pytest.raises(ValueError, match="unknown export format.*bogus"):
        parse_formats("step,bogus")


def test_formats_are_the_registry_rows_and_the_cli_lists_them():
    from typer.testing import CliRunner

    from procedura_brep.cli import app
    from procedura_brep.export.registry import REGISTRY
    assert FORMATS == tuple(REGISTRY) and all(parse_formats(f) == (f,) for f in FORMATS)
    out = CliRunner().invoke(app, ["export", "--help"], env={"COLUMNS": "400"}).output
    assert ",".join(FORMATS) in out


def test_each_registry_row_writes_exactly_its_declared_files(lamp):
    """A row's ``files`` column is what its writer returns: every declared file is written and
    nothing outside its declared files and folders."""
    from procedura_brep.export.bundle import bundle_bytes
    from procedura_brep.export.registry import REGISTRY
    for row in REGISTRY.values():
        declared = [f.strip() for f in row.files.split(",")]
        got = set(bundle_bytes(lamp, formats=row.name))
        stray = sorted(p for p in got if not any(p == d or (d.endswith("/") and p.startswith(d))
                                                 for d in declared))
        missing = [d for d in declared if not any(p == d or p.startswith(d) for p in got)]
        assert not stray and not missing, (row.name, stray, missing)
        assert row.description and row.articulated == any(p.startswith("urdf/") or p == "model.usda"
                                                          for p in got)


def test_obj_groups_and_pbr_mtl(lamp, bundle):
    out, _ = bundle
    groups = read_obj_groups((out / "model.obj").read_text())
    assert list(groups) == [p.name for p in lamp.parts] and all(groups.values())
    mtl = (out / "model.mtl").read_text()
    assert mtl.count("newmtl ") == len(lamp.parts)
    assert "Pr 0.450000" in mtl and "Pm 1.000000" in mtl and "Kd " in mtl


def test_glb_named_nodes_and_materials(lamp, bundle):
    import trimesh
    out, _ = bundle
    scene = trimesh.load(io.BytesIO((out / "model.glb").read_bytes()), file_type="glb")
    assert sorted(scene.graph.nodes_geometry) == sorted(p.name for p in lamp.parts)
    mats = {k: g.visual.material for k, g in scene.geometry.items()}
    assert mats["base"].roughnessFactor == pytest.approx(0.7)
    assert mats["post"].metallicFactor == pytest.approx(1.0)


def test_step_product_names_are_part_names(lamp, bundle):
    from procedura_brep.export.step import read_step_parts
    out, _ = bundle
    names = sorted(p.name for p in read_step_parts((out / "model.step").read_bytes()))
    assert names == sorted(p.name for p in lamp.parts)


def test_joints_agree_across_formats(lamp, bundle):
    """mates.json world frames == MJCF == URDF (both profiles) == USD, <= 1e-6 m / rad."""
    import mujoco
    import yourdfpy
    from pxr import Usd

    from procedura_brep.export.usd import usd_joint_frames
    out, _ = bundle
    art = articulate(lamp)
    want = expected_frames(art)
    got = {"mjcf": mj_joint_frames(mujoco.MjModel.from_xml_path(str(out / "model.xml"))),
           "urdf-mujoco": mj_joint_frames(mujoco.MjModel.from_xml_path(
               str(out / "urdf" / "robot.mujoco.urdf"))),
           "usd": usd_joint_frames(Usd.Stage.Open(str(out / "model.usda")))}
    u = yourdfpy.URDF.load(str(out / "urdf" / "robot.urdf"), load_meshes=False)
    strict = {}
    for name, j in u.joint_map.items():
        t = u.get_transform(j.child, u.base_link)
        strict[name] = (t[:3, 3], t[:3, :3] @ np.asarray(j.axis))
    got["urdf-strict"] = strict
    for fmt, frames in got.items():
        assert set(frames) == set(want), fmt
        for name, (anchor, axis) in want.items():
            assert np.linalg.norm(frames[name][0] - anchor) <= TOL_M, (fmt, name)
            assert angle(frames[name][1], axis) <= TOL_RAD, (fmt, name)


def test_urdf_masses_and_limits(lamp, bundle):
    import yourdfpy
    out, _ = bundle
    art = articulate(lamp)
    masses = link_masses(lamp, art)
    u = yourdfpy.URDF.load(str(out / "urdf" / "robot.urdf"), load_meshes=False)
    assert u.validate()
    for name, link in u.link_map.items():
        assert link.inertial.mass == pytest.approx(masses[name].mass, rel=1e-9)
    lim = u.joint_map["arm_pivot"].limit
    assert (lim.lower, lim.upper) == pytest.approx((np.radians(-45), np.radians(45)))
    assert lim.effort > 0 and lim.velocity > 0
    text = (out / "urdf" / "robot.mujoco.urdf").read_text()
    assert '<compiler' in text and 'fusestatic="false"' in text and 'discardvisual="false"' in text
    assert "package://" not in text


def test_usd_units_axes_and_drives(bundle):
    from pxr import Usd, UsdGeom, UsdPhysics
    out, _ = bundle
    stage = Usd.Stage.Open(str(out / "model.usda"))
    assert UsdGeom.GetStageUpAxis(stage) == "Z" and UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    joint = UsdPhysics.RevoluteJoint(stage.GetPrimAtPath("/lamp/joints/arm_pivot"))
    assert joint.GetAxisAttr().Get() == "X"
    assert joint.GetLowerLimitAttr().Get() == pytest.approx(-45.0)
    assert joint.GetPrim().HasAPI(UsdPhysics.DriveAPI, "angular")
    bodies = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.RigidBodyAPI)]
    assert sorted(p.GetName() for p in bodies) == ["arm", "base"]
    assert all(p.HasAPI(UsdPhysics.MassAPI) for p in bodies)


def _rot(axis: str, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    r = np.eye(3)
    r[i, i] = r[j, j] = c
    r[i, j], r[j, i] = -s, s
    return r


def test_rpy_round_trips_random_rotations_without_warnings():
    import warnings

    from scipy.spatial.transform import Rotation

    from procedura_brep.export.urdf import rpy, rpy_matrix
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for r in Rotation.random(500, random_state=7).as_matrix():
            roll, pitch, yaw = rpy(r)
            assert np.abs(rpy_matrix(roll, pitch, yaw) - r).max() <= 1e-12
            assert abs(pitch) <= np.pi / 2
            assert np.allclose(_rot("z", yaw) @ _rot("y", pitch) @ _rot("x", roll), r, atol=1e-12)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
@pytest.mark.parametrize("other", [(0.0, 0.0), (0.4, -1.3)])
def test_rpy_exact_at_gimbal_lock(pitch, other):
    """The four gimbal cases (pitch +-90 deg, with and without roll/yaw): no warning, yaw = 0 by
    convention, the matrix reconstructed to 1e-12."""
    import warnings

    from procedura_brep.export.urdf import rpy, rpy_matrix
    roll0, yaw0 = other
    r = _rot("z", yaw0) @ _rot("y", pitch) @ _rot("x", roll0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        roll, p, yaw = rpy(r)
    assert p == pytest.approx(pitch, abs=1e-12) and yaw == 0.0
    assert np.abs(rpy_matrix(roll, p, yaw) - r).max() <= 1e-12


def test_glb_is_metres_y_up(lamp, bundle):
    """glTF 2.0: metres, +Y up. The GLB's bounds (node transforms applied) are the world box
    mapped (x, y, z) mm -> (x, z, -y) m."""
    import trimesh
    out, _ = bundle
    scene = trimesh.load(io.BytesIO((out / "model.glb").read_bytes()), file_type="glb")
    v = np.vstack([p.mesh().vertices for p in lamp.parts])
    lo, hi = v.min(axis=0), v.max(axis=0)
    want_lo = np.array([lo[0], lo[2], -hi[1]]) * 1e-3
    want_hi = np.array([hi[0], hi[2], -lo[1]]) * 1e-3
    assert np.abs(scene.bounds[0] - want_lo).max() <= 1e-6
    assert np.abs(scene.bounds[1] - want_hi).max() <= 1e-6


@pytest.mark.parametrize(("path", "name"), [("2vise/program.py", "model_2vise"),
                                            ("my-vise/program.py", "my_vise"),
                                            ("Grüne Zange.py", "grune_zange"),
                                            ("---/program.py", "model")])
def test_program_name_is_an_identifier(path, name):
    import re

    from procedura_brep.paths import program_name
    got = program_name(Path(path))
    assert got == name and re.fullmatch(r"[a-z_][a-z0-9_]*", got)


def test_usd_root_is_valid_for_any_model_name(lamp):
    """A name that is not a USD identifier (a leading digit, a dash) still exports."""
    import dataclasses

    from pxr import Sdf

    from procedura_brep.export.usd import usd_stage
    stage = usd_stage(dataclasses.replace(lamp, name="2-lamp"))
    root = stage.GetDefaultPrim()
    assert root and Sdf.Path.IsValidIdentifier(root.GetName())
    assert stage.GetPrimAtPath(f"/{root.GetName()}/joints/arm_pivot").IsValid()


def test_usd_wheelless_root_welded_to_world(bundle):
    """The lamp has no wheels: like model.xml, its USD root is welded (world FixedJoint), and the
    articulation root stays on an ancestor of that joint."""
    from pxr import Usd, UsdPhysics
    out, _ = bundle
    stage = Usd.Stage.Open(str(out / "model.usda"))
    j = UsdPhysics.FixedJoint(stage.GetPrimAtPath("/lamp/joints/base__world"))
    assert j and j.GetBody0Rel().GetTargets() == []
    assert [str(t) for t in j.GetBody1Rel().GetTargets()] == ["/lamp/base"]
    assert stage.GetPrimAtPath("/lamp").HasAPI(UsdPhysics.ArticulationRootAPI)


def test_usd_work_stays_on_the_calling_thread(tmp_path):
    """A process that made a stage must still fork safely (the build's children, a warm
    server's commands): USD's work runs on the calling thread, so no worker thread (TBB) is
    left for a forked child to wait on. Checked in a fresh process: making, writing, opening
    and validating a model's stage start no thread."""
    import subprocess
    import sys
    code = (
        "import os\n"
        "from pathlib import Path\n"
        "from procedura_brep.testing.models import compiled\n"
        "from procedura_brep.export.meshes import collision_pieces, part_mesh\n"
        "from procedura_brep.export.usd import usda_text\n"
        "from procedura_brep.sim.fidelity import _validator_names\n"
        "from pxr import Usd, UsdValidation\n"
        f"model = compiled(Path({str(LAMP)!r}).read_text(), name='lamp')\n"
        "for p in model.parts:\n"  # meshes and hulls first: numpy's and scipy's BLAS pools
        "    part_mesh(p), collision_pieces(p)\n"  # start with them (and survive a fork)
        "threads = len(os.listdir('/proc/self/task'))\n"
        f"path = Path({str(tmp_path / 'm.usda')!r})\n"
        "path.write_text(usda_text(model))\n"
        "names = _validator_names()\n"
        "ctx = UsdValidation.ValidationContext([UsdValidation.ValidationRegistry().GetOrLoadValidatorByName(n) for n in names])\n"
        "ctx.Validate(Usd.Stage.Open(str(path)))\n"
        "print(threads, len(os.listdir('/proc/self/task')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    before, after = map(int, out.stdout.split())
    assert after == before
