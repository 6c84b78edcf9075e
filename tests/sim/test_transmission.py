"""Battery B8 "transmission": each coupling's driven joint follows its driver in MuJoCo at the
declared ratio; an equality written against the teeth fails; B1, B2 and B7 cope with coupled
joints (a driven joint has no servo and is not commanded)."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep.articulation import articulate
from procedura_brep.config import TOL
from procedura_brep.export.mjcf import build_mjcf
from procedura_brep.sim.battery import run_battery
from procedura_brep.sim.transmission import check_b8, head_range

SRC = (Path(__file__).parents[1] / "program" / "transmission.py").read_text()


@pytest.fixture(scope="module")
def model(worker):
    return worker.compile(SRC)


def test_b8_measures_every_ratio_and_sign(model):
    art = articulate(model)
    m = build_mjcf(model, art=art).spec.compile()
    res, _ = check_b8(m, art)
    assert res.passed, res.message
    rows = res.measured["couplings"]
    assert set(rows) == {"wheel_hub__pinion_hub", "rack_slide__pinion_hub", "nut_slide__screw_hub"}
    for name, declared in (("wheel_hub__pinion_hub", -12 / 36), ("rack_slide__pinion_hub", 0.012),
                           ("nut_slide__screw_hub", -0.004 / (2 * 3.141592653589793))):
        r = rows[name]
        assert r["declared"] == pytest.approx(declared)
        assert r["measured"] == pytest.approx(declared, rel=TOL.coupling_ratio_rel)
        assert r["driver_travel"] >= 0.5 * r["commanded_travel"] > 0
        assert not r["warnings"]
    assert m.opt.gravity[2] < 0  # the model is left as it was


def test_the_range_keeps_the_chain_inside_its_limits(model):
    art = articulate(model)
    # the rack (+-40 mm at 12 mm/rad) allows +-3.33 rad of the pinion; the pinion's own +-pi is less
    lo, hi = head_range(art, "pinion_hub", [c for c in art.couplings if c.driver == "pinion_hub"])
    assert (lo, hi) == (pytest.approx(-0.9 * 3.141592653589793), pytest.approx(0.9 * 3.141592653589793))
    # the nut's +-40 mm at 0.637 mm/rad bounds the continuous screw
    lo, hi = head_range(art, "screw_hub", [c for c in art.couplings if c.driver == "screw_hub"])
    assert hi == pytest.approx(0.9 * 0.040 / (0.004 / (2 * 3.141592653589793)))


@pytest.mark.parametrize("coupling, factor", [("rack_slide__pinion_hub", 1.03),
                                              ("wheel_hub__pinion_hub", -1.0)])
def test_an_equality_typed_against_the_teeth_fails_b8(model, coupling, factor):
    """The scene's equality written with another ratio (3 % off; or the wrong sense) than
    the teeth declare: B8 names the coupling and the numbers."""
    art = articulate(model)
    m = build_mjcf(model, art=art).spec.compile()
    import mujoco
    eid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, coupling)
    m.eq_data[eid, 1] *= factor
    res, traj = check_b8(m, art)
    assert not res.passed
    assert f"coupling {coupling} (" in res.message
    assert ("turns the wrong way" if factor < 0 else "% off the declared") in res.message
    assert traj  # frames of the failing run


def test_b1_b2_b7_b8_pass_with_coupled_joints(model, tmp_path):
    rep = run_battery(model, out_dir=tmp_path, checks=("B1", "B2", "B7", "B8"), frames=False)
    by = {c.id: c for c in rep.checks}
    assert all(c.passed for c in rep.checks), [c.message for c in rep.checks if not c.passed]
    joints = by["B2"].measured["joints"]
    assert joints["wheel_hub"]["driven_by"] == "pinion_hub"  # swept with its driver, no servo
    assert "reach" in joints["pinion_hub"]
    assert "B8" in rep.timings


FOURBAR = (Path(__file__).parents[1] / "program" / "fourbar.py").read_text()


def test_b8_keeps_a_four_bar_closed_and_fails_without_its_connect(worker):
    import mujoco
    m4 = worker.compile(FOURBAR)
    art = articulate(m4)
    m = build_mjcf(m4, art=art).spec.compile()
    res, _ = check_b8(m, art)
    assert res.passed, res.message
    row = res.measured["couplings"]["rocker_base__crank_base"]
    assert row["max_cut_gap_mm"] <= TOL.coupling_cut_mm
    # a parallelogram: the rocker turns as far as the crank
    assert row["driven_travel"] == pytest.approx(row["driver_travel"], rel=0.01)
    assert row["driver_travel"] >= 0.9 * row["commanded_travel"]
    m.eq_active0[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "loop_pin")] = 0  # the loop left open
    res, traj = check_b8(m, art)
    assert not res.passed and traj
    assert "linkage rocker_base__crank_base: " in res.message and "the cut joint 'loop_pin' opened by" in res.message


def test_b2_sweeps_a_coupled_link_against_all_but_the_meshing_part(worker):
    """B2 leaves out only the two parts a coupling meshes (the nut on its screw: the coupling
    gate checks them), not their whole links: a collar fixed on the screw, in the nut's travel,
    is still hit by the sliding nut (it was skipped with the screw's link before)."""
    from procedura_brep.sim.sweep import SweepScene
    src = SRC.replace('frames("screw", hub=Location((0, 0, 0)))',
                      'frames("screw", hub=Location((0, 0, 0)), collar=Location((0, 0, 125)))')
    src = src.replace("# === frames ===", '''@part(detail="sub", material="steel", description="collar on the screw, in the nut's path")
def collar():
    return Cylinder(12, 10, align=(Align.CENTER, Align.CENTER, Align.MIN)) - Cylinder(screw_d / 2, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("collar", seat=Location((0, 0, 0)))''')
    src += '\nmate("collar.seat", "screw.collar", "peg_socket", nominal="screw_d", fit="location", features=False)\n'
    model = worker.compile(src)
    assert model.ok, [f.message for f in model.findings]
    art = articulate(model)
    assert art.part_link["collar"] == art.part_link["screw"]
    scene = SweepScene(model, art)
    joint = art.joint("nut_slide")
    swept, _ = scene.pairs(joint)
    assert ("nut", "screw") not in swept and ("nut", "collar") in swept
    hit = scene.sweep(joint)
    assert hit.depth > 1.0 and hit.pair and "collar" in hit.pair, hit
