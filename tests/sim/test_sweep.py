"""B2's exact-solid sweep: sampled ranges catch a part passing through another between the
extremes; spherical joints are tilted around their cone; seeded golden faults fail B2."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.articulation.tree import Joint
from procedura_brep.config import TOL
from procedura_brep.mates.placement import rigid_inverse, rot_x, spherical_tilt_deg, trans
from procedura_brep.sim import run_battery
from procedura_brep.sim.sweep import SPHERE_DIRECTIONS, SweepScene, samples

GOLDEN = Path(__file__).resolve().parents[2] / "golden"
FRAME = trans(10.0, 20.0, 30.0) @ rot_x(35.0)


def _joint(jtype: str, lower: float | None, upper: float | None) -> Joint:
    return Joint(name="j", type=jtype, parent="p", child="c", frame=FRAME, lower=lower,
                 upper=upper, effort=1.0, velocity=1.0, mate=None)  # type: ignore[arg-type]


def test_revolute_samples_move_no_point_more_than_the_step():
    radius = 140.0
    s = samples(_joint("revolute", math.radians(-135), math.radians(135)), radius_mm=radius)
    q = np.array([x.value for x in s])
    assert q[0] == pytest.approx(math.radians(-135)) and q[-1] == pytest.approx(math.radians(135))
    assert np.diff(q).max() * radius <= TOL.sweep_step_mm + 1e-9
    assert TOL.sweep_step_mm <= 1.0
    # the motion is a rotation about the joint axis through the anchor
    m = s[0].motion
    assert np.allclose(m @ FRAME[:, 3], FRAME[:, 3]) and np.allclose(m[:3, :3] @ FRAME[:3, 2], FRAME[:3, 2])


def test_prismatic_samples_step_the_travel():
    q = np.array([x.value for x in samples(_joint("prismatic", -0.02, 0.05))])
    assert q[0] == pytest.approx(-0.02) and q[-1] == pytest.approx(0.05)
    assert np.diff(q).max() * 1000.0 <= TOL.sweep_step_mm + 1e-9


def test_spherical_samples_tilt_half_and_full_cone_in_8_directions():
    cone = math.radians(25.0)
    s = samples(_joint("spherical", 0.0, cone))
    assert len(s) == 2 * SPHERE_DIRECTIONS
    tilts, dirs = [], set()
    for x in s:
        local = rigid_inverse(FRAME) @ x.motion @ FRAME  # the delta in the joint frame
        assert np.allclose(local[:3, 3], 0.0, atol=1e-9)  # about the ball centre
        tilts.append(spherical_tilt_deg(local))
        dirs.add(round(x.value[0]))
        axis = np.array([math.cos(math.radians(x.value[0])), math.sin(math.radians(x.value[0])), 0])
        assert np.allclose(local[:3, :3] @ axis, axis, atol=1e-9)  # tilt axis in the XY plane
    assert sorted(set(np.round(tilts, 9))) == pytest.approx([12.5, 25.0])
    assert dirs == {0, 45, 90, 135, 180, 225, 270, 315}


def test_continuous_joints_are_sampled_over_a_full_turn():
    s = samples(_joint("continuous", None, None), radius_mm=60.0)
    q = np.array([x.value for x in s])
    assert q[0] == 0.0 and q[-1] < 2 * math.pi and (2 * math.pi - q[-1]) * 60.0 <= TOL.sweep_step_mm + 1e-9
    assert np.diff(q).max() * 60.0 <= TOL.sweep_step_mm + 1e-9


FIN_ANGLES = (7.3, 21.9, -33.4, 48.1)


@pytest.fixture(scope="module")
def fins(worker):
    from .fin import program as fin_program
    return {phi: _compile("fin", fin_program(phi), worker) for phi in (None, *FIN_ANGLES)}


@pytest.mark.parametrize("phi", FIN_ANGLES)
def test_a_1mm_fin_in_the_path_is_hit_wherever_it_stands(fins, phi):
    model = fins[phi]
    art = articulate(model)
    hit = SweepScene(model, art).sweep(art.joint("blade_pivot"))
    assert hit.pair == ("blade", "fin") and hit.depth > TOL.sim_penetration_mm
    assert abs(math.degrees(hit.value) - phi) < 2.0, hit.at


def test_without_the_fin_the_blade_sweeps_clear(fins):
    model = fins[None]
    art = articulate(model)
    hit = SweepScene(model, art).sweep(art.joint("blade_pivot"))
    assert hit.depth <= TOL.sim_penetration_mm and hit.pair is None


def test_a_coarse_step_steps_over_a_fin(fins, monkeypatch):
    """The planted fault: with an 8 degree step at the fin (20 mm at 140 mm) some fin is missed,
    so the fin tests above depend on the geometric spacing."""
    import dataclasses

    from procedura_brep.sim import sweep
    monkeypatch.setattr(sweep, "TOL", dataclasses.replace(TOL, sweep_step_mm=20.0))
    missed = []
    for phi in FIN_ANGLES:
        art = articulate(fins[phi])
        if SweepScene(fins[phi], art).sweep(art.joint("blade_pivot")).depth <= TOL.sim_penetration_mm:
            missed.append(phi)
    assert missed


@pytest.mark.slow
def test_a_fin_fails_b2_in_the_battery(fins, tmp_path):
    report = run_battery(fins[FIN_ANGLES[1]], out_dir=tmp_path, checks=["B2"], frames=False)
    b2 = report.check("B2")
    assert not b2.passed and "'blade_pivot' drives 'blade'" in b2.message and "'fin'" in b2.message


def _compile(name: str, source: str, worker):
    from procedura_brep.program import compile_source
    return compile_source(source, name=name, worker=worker)


def _golden(name: str) -> str:
    path = GOLDEN / name / "program.py"
    if not path.exists():
        pytest.skip(f"golden/{name} not present")
    return path.read_text()


@pytest.fixture(scope="module")
def arm_wide_elbow(worker):
    src = _golden("arm")
    assert src.count("limits=(-65, 135)") == 1, "golden/arm's elbow limits changed; update the seed"
    return _compile("arm", src.replace("limits=(-65, 135)", "limits=(-135, 135)"), worker)


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_elbow_through_the_turret_is_found_between_the_extremes(arm_wide_elbow):
    art = articulate(arm_wide_elbow)
    elbow = art.joint("forearm_elbow")
    scene = SweepScene(arm_wide_elbow, art)
    hit = scene.sweep(elbow)
    assert hit.depth > TOL.sim_penetration_mm and "turret" in hit.pair
    assert -110.0 <= math.degrees(hit.value) <= -70.0, hit.at  # inside the range, not at an end
    # at both ends of the range the moved parts are clear of the turret again
    for q in (elbow.lower, elbow.upper):
        end = scene.sweep(Joint(**{**elbow.__dict__, "lower": q, "upper": q}))
        assert end.pair is None or "turret" not in end.pair or end.depth <= TOL.sim_penetration_mm


@pytest.mark.slow
def test_arm_elbow_limits_into_the_turret_fail_b2(arm_wide_elbow, tmp_path):
    report = run_battery(arm_wide_elbow, out_dir=tmp_path, checks=["B2"])
    b2 = report.check("B2")
    assert not b2.passed and "'forearm_elbow' drives" in b2.message and "mm into 'turret'" in b2.message
    assert b2.measured["joints"]["forearm_elbow"]["new_penetration_mm"] > TOL.sim_penetration_mm
    if b2.frames:
        assert len(b2.frames) <= 8 and all((tmp_path / f).exists() for f in b2.frames)
    else:
        assert any("B2" in n for n in report.notes)


def test_vise_neck_wider_than_the_cup_fails_b2_on_the_ball(worker, tmp_path):
    from procedura_brep.program.edit import set_params
    model = _compile("vise", set_params(_golden("vise"), {"neck_d": 60.0}), worker)
    report = run_battery(model, out_dir=tmp_path, checks=["B2"])
    b2 = report.check("B2")
    ball = next(j for j in articulate(model).joints if j.type == "spherical")
    assert not b2.passed and f"spherical joint {ball.name!r} drives" in b2.message
    row = b2.measured["joints"][ball.name]
    assert row["new_penetration_mm"] > TOL.sim_penetration_mm and row["samples"] == 16
    assert row["worst_direction_deg"] in [45.0 * k for k in range(8)]
    assert row["worst_tilt_deg"] == pytest.approx(row["cone_deg"]) or \
        row["worst_tilt_deg"] == pytest.approx(row["cone_deg"] / 2)
    if b2.frames:  # rendering is best effort
        assert len(b2.frames) <= 8 and all((tmp_path / f).exists() for f in b2.frames)
    else:
        assert any("B2" in n for n in report.notes)


def test_every_part_of_the_moved_link_meets_every_part_of_the_parent_link(worker):
    """The blade's link has a second part (a tip weight) and the post's link a second part (a
    raised fin): the tip hits the fin, though neither is the joint's own child or parent part;
    without the tip the blade passes under the fin."""
    from .fin import program as fin_program
    with_tip = _compile("fin", fin_program(21.9, fin_z=33.0, tip=True), worker)
    art = articulate(with_tip)
    assert art.part_link["tip"] == art.part_link["blade"] and art.part_link["fin"] == art.part_link["post"]
    hit = SweepScene(with_tip, art).sweep(art.joint("blade_pivot"))
    assert hit.pair == ("tip", "fin") and hit.depth > TOL.sim_penetration_mm
    bare = _compile("fin", fin_program(21.9, fin_z=33.0), worker)
    art = articulate(bare)
    assert SweepScene(bare, art).sweep(art.joint("blade_pivot")).depth <= TOL.sim_penetration_mm


def test_a_sweep_that_spends_its_boolean_budget_stops_and_says_where(fins, monkeypatch):
    """A joint whose sweep needs more exact booleans than ``TOL.sweep_max_booleans`` stops at
    the budget (issue 10: a part overlapping its neighbours at every pose ran for minutes) and
    names the pair and the pose it reached; under the budget the same sweep is unchanged."""
    import dataclasses

    from procedura_brep.sim import sweep
    model = fins[FIN_ANGLES[1]]
    art = articulate(model)
    full = SweepScene(model, art).sweep(art.joint("blade_pivot"))
    assert full.booleans > 2 and not full.stopped
    monkeypatch.setattr(sweep, "TOL", dataclasses.replace(TOL, sweep_max_booleans=full.booleans - 1))
    cut = SweepScene(model, art).sweep(art.joint("blade_pivot"))
    assert cut.booleans == full.booleans - 1
    assert cut.stopped.startswith("'blade' against '") and " at " in cut.stopped, cut.stopped
    assert cut.as_dict()["not_verified"] == cut.stopped
    monkeypatch.setattr(sweep, "TOL", dataclasses.replace(TOL, sweep_max_booleans=full.booleans))
    same = SweepScene(model, art).sweep(art.joint("blade_pivot"))
    assert not same.stopped and same.depth == full.depth and same.pair == full.pair


def test_a_stopped_sweep_is_not_verified_never_a_failure(fins, monkeypatch, tmp_path):
    """A sweep that spends its boolean budget says which pair and pose stopped it and leaves
    the rest *not verified*: not a B2 failure (the parts may merely touch), not a pass."""
    import dataclasses

    from procedura_brep.sim import battery, sweep
    from procedura_brep.sim.battery import failures
    small = dataclasses.replace(TOL, sweep_max_booleans=1)
    monkeypatch.setattr(sweep, "TOL", small)
    monkeypatch.setattr(battery, "TOL", small)
    report = run_battery(fins[FIN_ANGLES[1]], out_dir=tmp_path, checks=["B2"], frames=False)
    b2 = report.check("B2")
    assert b2.status == "not verified" and not report.verified
    assert "joint 'blade_pivot': the exact sweep spent its budget of 1 booleans" in b2.unverified
    assert "not verified" in b2.message and "separate the parts" not in b2.message
    assert b2.measured["joints"]["blade_pivot"]["not_verified"]
    (f,) = [f for f in failures(report) if f.code == "not-verified"]
    assert f.severity == "warning" and "battery B2 not verified" in f.message


def _reaches(scene, joint, a: str, b: str) -> bool:
    """Whether ``a``'s swept envelope over the joint's range reaches ``b``'s box (grown by the
    slack), written out pair by pair and independently of ``SweepScene``'s batched test."""
    frame_inv = rigid_inverse(joint.frame)

    def corners(name: str) -> np.ndarray:
        lo, hi = scene.model.part(name).local_box()
        t = frame_inv @ scene.model.part(name).placement
        return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                         for z in (lo[2], hi[2])]) @ t[:3, :3].T + t[:3, 3]
    ca, cb = corners(a), corners(b)
    blo, bhi = cb.min(axis=0) - TOL.sweep_box_slack_mm, cb.max(axis=0) + TOL.sweep_box_slack_mm
    if joint.kind.slides:  # the box swept along the slide's axis (the frame's Z), in mm
        lo, hi = ca.min(axis=0), ca.max(axis=0)
        lo[2] += 1000.0 * min(0.0, float(joint.lower))
        hi[2] += 1000.0 * max(0.0, float(joint.upper))
        return bool(np.all(lo <= bhi) and np.all(blo <= hi))
    near = np.clip(0.0, blo, bhi)  # b's box point nearest the axis (or the ball's centre)
    if joint.kind.ball:
        return float(np.linalg.norm(near)) <= float(np.linalg.norm(ca, axis=1).max())
    reach = float(np.linalg.norm(ca[:, :2], axis=1).max())
    return bool(ca[:, 2].min() <= bhi[2] and blo[2] <= ca[:, 2].max()
                and float(np.linalg.norm(near[:2])) <= reach)


@pytest.mark.parametrize("program", ["hinges", "transmission", "rover"])
def test_the_batched_envelope_test_keeps_the_pairs_the_pairwise_one_keeps(program, worker):
    """``SweepScene.pairs`` tests every moved part's swept envelope against all the fixed
    parts' boxes at once; what it keeps is what the envelope test pair by pair (written out
    here) and the rest of ``_may_collide`` keep, pair for pair and in order, on every joint
    (revolute rows of hinges, a lead screw's slide and turns, the rover's wheels and arm)."""
    from procedura_brep.testing.programs import hinge_row
    root = Path(__file__).resolve().parents[2]
    src = {"hinges": lambda: hinge_row(12),
           "transmission": lambda: (root / "tests" / "program" / "transmission.py").read_text(),
           "rover": lambda: (root / "golden" / "rover" / "program.py").read_text()}[program]()
    model = worker.compile(src)
    assert model.ok
    art = articulate(model)
    scene = SweepScene(model, art)
    reached = pruned = 0
    for joint in art.joints:
        swept, _ = scene.pairs(joint)
        moving = [p for lk in art.subtree(joint.child) for p in art.link(lk).parts]
        meshed = scene._meshed({joint.name})
        one_by_one = []
        for a in moving:
            for b in (p.name for p in model.parts if p.name not in moving):
                if frozenset((a, b)) in meshed:
                    continue
                if not _reaches(scene, joint, a, b):
                    pruned += 1
                    continue
                reached += 1
                if scene._may_collide(joint, a, b, envelope=False):
                    one_by_one.append((a, b))
        assert swept == one_by_one, joint.name
    assert reached and pruned  # both outcomes of the envelope test were exercised
