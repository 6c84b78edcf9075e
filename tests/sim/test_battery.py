"""The MuJoCo battery: the lamp passes; seeded faults fail the right check."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.export.bundle import write_bundle
from procedura_brep.sim import run_battery

from ..articulation.models import compile_lamp, lamp_source

ROOT = Path(__file__).resolve().parents[2]


def _bundle(model, out: Path, source: str) -> Path:
    write_bundle(model, out, formats=("urdf", "usd", "mjcf"))
    (out / "program.py").write_text(source)
    return out


@pytest.fixture(scope="module")
def lamp(worker):
    return compile_lamp(worker)


def test_lamp_passes_every_check(lamp, tmp_path):
    report = run_battery(lamp, out_dir=tmp_path)
    assert [c.id for c in report.checks] == [f"B{i}" for i in range(9)]
    assert report.passed, [c.message for c in report.checks if not c.passed]
    doc = json.loads(json.dumps(report.as_dict()))
    b2 = next(c for c in doc["checks"] if c["id"] == "B2")
    assert b2["measured"]["min_reach"] >= b2["limits"]["min_reach"] == 0.97
    assert report.check("B4").skipped  # no wheels on a lamp
    assert report.check("B8").skipped  # and no couplings


def test_axis_rotated_30_degrees_fails_b0(lamp, tmp_path):
    import mujoco
    out = _bundle(lamp, tmp_path, lamp_source())
    spec = mujoco.MjSpec.from_file(str(out / "model.xml"))
    spec.joint("arm_pivot").axis = [0.0, np.sin(np.radians(30)), np.cos(np.radians(30))]
    (out / "model.xml").write_text(spec.to_xml())
    report = run_battery(out, checks=["B0"], frames=False)
    b0 = report.check("B0")
    assert not b0.passed and "arm_pivot" in b0.message
    assert b0.measured["axis_err_rad"] == pytest.approx(np.radians(30), rel=1e-3)


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_limits_into_the_base_fail_b2(worker, tmp_path):
    model = compile_lamp(worker, limits=(-100, 100))
    report = run_battery(model, out_dir=tmp_path, checks=["B2", "B3"])
    b2 = report.check("B2")
    assert not b2.passed and "arm_pivot" in b2.message and "'base'" in b2.message
    assert b2.measured["max_new_penetration_mm"] > b2.limits["max_new_penetration_mm"]
    if b2.frames:  # rendering is best effort (no GL context -> a note instead)
        assert all((tmp_path / f).exists() for f in b2.frames) and len(b2.frames) <= 8
    else:
        assert any("B2" in n for n in report.notes)


def test_wrong_urdf_joint_type_fails_b5(lamp, tmp_path):
    out = _bundle(lamp, tmp_path, lamp_source())
    urdf = out / "urdf" / "robot.urdf"
    urdf.write_text(urdf.read_text().replace('type="revolute"', 'type="prismatic"'))
    report = run_battery(out, checks=["B5"], frames=False)
    b5 = report.check("B5")
    assert not b5.passed and "arm_pivot" in b5.message and "prismatic" in b5.message


@pytest.fixture(scope="module")
def rover(worker):
    from procedura_brep.program import compile_source
    path = ROOT / "golden" / "rover" / "program.py"
    if not path.exists():
        pytest.skip("golden/rover not present")
    return compile_source(path.read_text(), name="rover", worker=worker)


@pytest.mark.slow
def test_rover_wheels_lifted_off_the_ground_are_not_wheels(rover, tmp_path):
    from procedura_brep.articulation import articulate
    from procedura_brep.program.model import to_json
    from procedura_brep.program.trust import model_from_json as from_json
    lifted = from_json(to_json(rover))
    art = articulate(lifted)
    up = np.eye(4)
    up[2, 3] = 80.0
    wheel_parts = {p for w in art.wheels for lk in art.subtree(art.joint(w).child)
                   for p in art.link(lk).parts}
    assert len(wheel_parts) >= 4
    for p in lifted.parts:
        if p.name in wheel_parts:
            p.placement = up @ p.placement
    for m in lifted.mates:
        if m.child in wheel_parts:
            m.world_frame = up @ m.world_frame
    # lifted 80 mm, they no longer reach the floor: by evidence they are spinning joints, not
    # wheels, so the base is welded and B4 has nothing to drive
    art2 = articulate(lifted)
    assert art2.wheels == []
    report = run_battery(lifted, out_dir=tmp_path, checks=["B4"], frames=False)
    b4 = report.check("B4")
    assert b4.skipped


def test_no_out_dir_leaves_no_temp_dir(lamp):
    """Without out_dir the bundle goes to a temp dir that is removed afterwards (and the report
    says that no frames could be kept)."""
    import tempfile

    from procedura_brep.sim.battery import TEMP_PREFIX
    tmp = Path(tempfile.gettempdir())
    before = set(tmp.glob(f"{TEMP_PREFIX}*"))
    report = run_battery(lamp, checks=("B0",))
    assert report.check("B0").passed
    assert set(tmp.glob(f"{TEMP_PREFIX}*")) == before
    assert any("no failure frames" in n for n in report.notes)
