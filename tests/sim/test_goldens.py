"""Every golden program: the battery passes, every export agrees on every joint (mates.json
frames vs URDF both profiles, USD, MJCF; <= 1e-6 m / rad) and STEP products are the parts."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from procedura_brep.articulation import articulate
from procedura_brep.export.bundle import write_bundle
from procedura_brep.program.model import to_json
from procedura_brep.sim import run_battery
from procedura_brep.sim.battery import ALL_CHECKS

from .agreement import assert_joints_agree

GOLDEN = Path(__file__).resolve().parents[2] / "golden"
PROGRAMS = ("rover", "arm", "vise")
#: Goldens whose battery failure is in the model itself (not the exporter/battery): name -> why.
MODEL_FAILURES: dict[str, str] = {}

_BUILT: dict[str, tuple] = {}


def _built(name: str, worker, tmp_path_factory):
    """(model, bundle dir) of a golden program, compiled and exported once per session."""
    if name not in _BUILT:
        from procedura_brep.program import compile_source
        path = GOLDEN / name / "program.py"
        if not path.exists():
            pytest.skip(f"golden/{name} not present")
        model = compile_source(path.read_text(), name=name, worker=worker)
        out = tmp_path_factory.mktemp(name)
        write_bundle(model, out)
        (out / "mates.json").write_text(json.dumps(to_json(model)["mates"]))
        _BUILT[name] = (model, out)
    return _BUILT[name]


@pytest.mark.slow
@pytest.mark.parametrize("name", PROGRAMS)
def test_golden_battery_passes(name, worker, tmp_path_factory):
    if name in MODEL_FAILURES:
        pytest.skip(f"golden/{name}: {MODEL_FAILURES[name]}")
    model, out = _built(name, worker, tmp_path_factory)
    report = run_battery(model, out_dir=out, frames=False)
    assert report.passed, [c.message for c in report.checks if not c.passed]
    assert [c.id for c in report.checks] == list(ALL_CHECKS)
    if name == "rover":
        assert not report.check("B4").skipped and report.check("B4").measured["wheels"] >= 4


@pytest.mark.slow
@pytest.mark.parametrize("name", PROGRAMS)
def test_golden_joints_agree_across_formats(name, worker, tmp_path_factory):
    model, out = _built(name, worker, tmp_path_factory)
    art = articulate(model)
    assert art.joints, f"golden/{name} has no joints"
    assert_joints_agree(out, art)


@pytest.mark.slow
@pytest.mark.parametrize("name", PROGRAMS)
def test_golden_step_products_are_part_names(name, worker, tmp_path_factory):
    model, out = _built(name, worker, tmp_path_factory)
    text = (out / "model.step").read_text(errors="replace")
    products = re.findall(r"PRODUCT\(\s*'([^']*)'", text)
    assert sorted(set(products) - {model.name}) == sorted(p.name for p in model.parts)


@pytest.mark.parametrize("name", PROGRAMS)
def test_golden_usd_base_matches_mjcf(name, worker, tmp_path_factory):
    """A wheel-less golden's USD root is welded to the world by one FixedJoint (as model.xml
    welds it); the rover's base is free in both."""
    from pxr import Usd, UsdPhysics
    model, out = _built(name, worker, tmp_path_factory)
    art = articulate(model)
    stage = Usd.Stage.Open(str(out / "model.usda"))
    fixed = [p for p in stage.Traverse() if p.IsA(UsdPhysics.FixedJoint)]
    import mujoco
    m = mujoco.MjModel.from_xml_path(str(out / "model.xml"))
    free_in_mjcf = any(m.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE for i in range(m.njnt))
    assert art.free == bool(art.wheels)
    if art.free:
        assert not fixed and free_in_mjcf
    else:
        assert [p.GetName() for p in fixed] == [f"{art.root.name}__world"] and not free_in_mjcf
        j = UsdPhysics.FixedJoint(fixed[0])
        assert j.GetBody0Rel().GetTargets() == []
        assert [t.name for t in j.GetBody1Rel().GetTargets()] == [art.root.name]


def test_rocker_touching_the_chassis_costs_the_turn_sweep_no_boolean_per_pose(worker, tmp_path_factory,
                                                                               monkeypatch):
    """Issue 23.2 / 24.1: the rover's rocker turns against the chassis face it bears on (planes
    normal to its pivot, a hub about it). Clear at the range's start, the pair is swept without
    the faces the turn moves within themselves, on both parts: a handful of exact booleans where
    the old sweep ran one at every pose (plant: every pose again with the reduction off)."""
    from procedura_brep.sim.sweep import SweepScene

    model, _ = _built("rover", worker, tmp_path_factory)
    art = articulate(model)
    joint = art.joint("rocker_l_pivot")
    hit = SweepScene(model, art).sweep(joint)
    assert ("rocker_l", "chassis") in hit.contact and hit.depth == 0.0
    assert hit.booleans <= 5, hit.booleans
    monkeypatch.setattr(SweepScene, "clear_start", lambda self, j, a, b: 0)
    old = SweepScene(model, art).sweep(joint)
    assert old.booleans >= 4 * hit.booleans and old.depth == 0.0
