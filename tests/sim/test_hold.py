"""B1 checks the pose it holds; B2 says why a joint falls short of its range.

Small programs in the program format: a steel base plate with a post, and a square steel arm on
a horizontal revolute at the post top (a 400 mm arm carries about 9 N m of gravity torque); a
forearm on a second revolute for a collision the MuJoCo sweep can see (the arm's pin sits in the
post's bore, so the exporter excludes arm-base contacts, whose hulls overlap at rest; the
forearm touches nothing at rest, so it collides with the base); a cube on a vertical slide; an
arm on a ball joint.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from procedura_brep.articulation import articulate
from procedura_brep.articulation.mass import part_mass
from procedura_brep.config import TOL
from procedura_brep.sim import run_battery
from procedura_brep.sim.dynamics import SWEEP_HOLD_S, SWEEP_RAMP_S, Stop, reach_why
from procedura_brep.testing.models import compiled
from procedura_brep.testing.programs import program_text

G = 9.81

BASE_PARAMS = ("base_t = 20.0  # mm, base thickness",
               "post_d = 40.0  # mm, post diameter",
               "spigot_d = 20.0  # mm, spigot under the post: the nominal of its peg_socket",
               "pin_d = 12.0  # mm, hinge pins: the nominal of the revolutes",
               "arm_s = 40.0  # mm, arm section side")
BASE_PART = ('@part(detail="silhouette", material="steel", description="square base plate")\n'
             "def base():\n"
             "    return Box(base_w, base_w, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))\n")
POST_PART = ('@part(detail="major", material="steel", description="vertical post at the base centre")\n'
             "def post():\n"
             "    return Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))\n")


def _bar(name: str, length: str, what: str) -> str:
    return (f'@part(detail="major", material="steel", description="{what}")\n'
            f"def {name}():\n"
            f"    return Box({length}, arm_s, arm_s, align=(Align.MIN, Align.CENTER, Align.CENTER))\n")


def arm_program(*, effort: float, limits: tuple[float, float] = (-30, 30), arm_l: float = 400.0,
                post_h: float = 500.0, base_w: float = 300.0, velocity: float = 3.0,
                forearm: tuple[float, tuple[float, float]] | None = None) -> str:
    """A base plate and post, and a steel arm ``arm_l`` long on the revolute ``arm_pivot`` (axis
    horizontal, the arm horizontal at home: positive angles swing it down); with ``forearm``
    = (length, limits), a forearm on ``forearm_pivot`` at the arm's far end (effort 100 N m)."""
    params = [*BASE_PARAMS, f"base_w = {base_w!r}  # mm, square base side",
              f"post_h = {post_h!r}  # mm, post height", f"arm_l = {arm_l!r}  # mm, arm length"]
    parts = [BASE_PART, POST_PART, _bar("arm", "arm_l", "square steel arm on a pin at the post top")]
    frames = ['frames("base", top=Location((0, 0, base_t)))',
              'frames("post", foot=Location((0, 0, 0)), '
              'head=Location((0, post_d / 2, post_h - arm_s), (-90, 0, 0)))',
              'frames("arm", pivot=Location((arm_s / 2, -arm_s / 2, 0), (-90, 0, 0)), '
              'elbow=Location((arm_l - arm_s / 2, arm_s / 2, 0), (-90, 0, 0)))']
    mates = ['mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")',
             f'mate("arm.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", '
             f'limits={tuple(limits)!r}, effort={effort!r}, velocity={velocity!r})']
    if forearm:
        length, flimits = forearm
        params.append(f"fore_l = {length!r}  # mm, forearm length")
        parts.append(_bar("forearm", "fore_l", "square steel forearm on a pin at the arm end"))
        frames.append('frames("forearm", pivot=Location((arm_s / 2, -arm_s / 2, 0), (-90, 0, 0)))')
        mates.append(f'mate("forearm.pivot", "arm.elbow", "revolute", nominal="pin_d", '
                     f'fit="clearance", limits={tuple(flimits)!r}, effort=100.0)')
    return program_text(doc="Base, post and a steel arm on a horizontal revolute (hold tests).",
                        params=params, parts=parts, frames=frames, mates=mates)


def slide_program(*, effort: float, across: bool = False) -> str:
    """A 100 mm steel cube (7.85 kg) on a vertical slide ``cube_foot``, held 25 mm above the
    base plate at home (limits 0 to 50 mm); ``across``: the slide runs along X instead, the cube
    30 mm above the plate, so it never comes near it."""
    if across:  # both frames turned so that the slide's +Z is the world +X
        frames = ['frames("base", top=Location((0, 0, base_t + 80), (0, 90, 0)))',
                  'frames("cube", foot=Location((0, 0, cube_s / 2), (0, 90, 0)))']
    else:
        frames = ['frames("base", top=Location((0, 0, base_t)))',
                  'frames("cube", foot=Location((0, 0, 0)))']
    return program_text(
        doc="A steel cube on a slide above a base plate (hold tests).",
        params=[*BASE_PARAMS, "base_w = 300.0  # mm, square base side",
                "cube_s = 100.0  # mm, cube side", "guide_d = 10.0  # mm, the slide's nominal"],
        parts=[BASE_PART,
               '@part(detail="major", material="steel", description="steel cube on the slide")\n'
               "def cube():\n"
               "    return Box(cube_s, cube_s, cube_s, align=(Align.CENTER, Align.CENTER, Align.MIN))\n"],
        frames=frames,
        mates=[f'mate("cube.foot", "base.top", "prismatic", nominal="guide_d", fit="clearance", '
               f'features=False, limits=(0, 50), home=25, effort={effort!r})'])


def ball_program(*, effort: float) -> str:
    """A 200 mm steel arm on a ball joint ``arm_ball`` at the post top (cone 30 deg), its ball
    under one end and 30 mm below it (the arm clears the post when it tilts), so gravity tilts
    it about the post."""
    return program_text(
        doc="A steel arm on a ball joint at the top of a post (hold tests).",
        params=[*BASE_PARAMS, "base_w = 300.0  # mm, square base side",
                "post_h = 300.0  # mm, post height", "arm_l = 200.0  # mm, arm length",
                "ball_d = 20.0  # mm, the ball joint's nominal"],
        parts=[BASE_PART, POST_PART, _bar("arm", "arm_l", "square steel arm on a ball at the post top")],
        frames=['frames("base", top=Location((0, 0, base_t)))',
                'frames("post", foot=Location((0, 0, 0)), head=Location((0, 0, post_h)))',
                'frames("arm", ball=Location((arm_s / 2, 0, -arm_s / 2 - 30)))'],
        mates=['mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")',
               f'mate("arm.ball", "post.head", "spherical", nominal="ball_d", fit="clearance", '
               f'features=False, cone=30, effort={effort!r})'])


def _gravity_torque(model, joint: str, part: str) -> float:
    """|gravity torque| of ``part`` about ``joint``'s axis at home, N m, from the exact part
    mass (OCCT volume x density), independently of MuJoCo."""
    j = articulate(model).joint(joint)
    mp = part_mass(model, part)
    return abs(float(np.cross(mp.com - j.anchor_m, [0.0, 0.0, -mp.mass * G]) @ j.axis))


@pytest.fixture(scope="module")
def weak_arm(worker):
    """The 400 mm arm with effort 1 N m: it falls onto its +30 deg limit and rests there, at
    zero speed (the speed-only B1 passed it: 'settled within 2.0 s')."""
    return compiled(arm_program(effort=1.0), worker=worker, name="weak_arm")


def test_weak_arm_fails_b1_naming_joint_drift_torque_and_effort(weak_arm):
    report = run_battery(weak_arm, checks=["B1"], frames=False)
    b1 = report.check("B1")
    row = b1.measured["joints"]["arm_pivot"]
    torque = _gravity_torque(weak_arm, "arm_pivot", "arm")
    assert 8.0 < torque < 10.0  # 5 kg of steel, its centre 180 mm out
    assert row["gravity_torque_Nm"] == pytest.approx(torque, rel=0.02)
    assert row["effort_Nm"] == 1.0 and row["saturated"]
    assert 29.0 < row["drift_deg"] < 31.0  # on its 30 deg limit
    # its far corner is 380 mm from the axis: a 30 deg turn moves it 2 r sin(15 deg)
    assert row["tip_mm"] == pytest.approx(2 * 380.0 * math.sin(math.radians(15)), rel=0.02)
    assert b1.measured["max_joint_speed"] <= TOL.settle_joint_speed  # at rest: only the hold fails
    assert not b1.passed
    need = 1.2 * row["gravity_torque_Nm"]
    assert (f"joint 'arm_pivot' sags {row['drift_deg']:.3g} deg from home (its far end moves "
            f"{row['tip_mm']:.3g} mm) under {row['gravity_torque_Nm']:.3g} N m of gravity torque; "
            f"its effort is 1 N m: raise effort to at least ~") in b1.message
    suggested = float(b1.message.split("at least ~")[1].split(" N m")[0])
    assert need <= suggested <= 1.1 * need
    assert b1.limits["max_drift_deg"] == TOL.hold_drift_deg
    assert b1.measured["max_drift_deg"] == row["drift_deg"]


def test_strong_arm_holds_its_pose(worker):
    """Effort 50 N m against the same ~9 N m: the servo carries the load and the arm stays at
    home (a proportional servo alone droops 0.87 deg here, 5.8 mm at the far end)."""
    model = compiled(arm_program(effort=50.0), worker=worker, name="strong_arm")
    b1 = run_battery(model, checks=["B1"], frames=False).check("B1")
    assert b1.passed, b1.message
    row = b1.measured["joints"]["arm_pivot"]
    assert row["drift_deg"] < 1e-3 and row["tip_mm"] < 1e-2 and not row["saturated"]
    assert abs(row["actuator_torque_Nm"]) == pytest.approx(row["gravity_torque_Nm"], rel=1e-3)
    assert row["gravity_torque_Nm"] == pytest.approx(_gravity_torque(model, "arm_pivot", "arm"),
                                                     rel=0.02)


def test_short_arm_within_its_effort_does_not_droop(worker):
    """An 80 mm arm with 10 N m for 0.2 N m: the exported proportional servo alone would let it
    droop about 4 deg (the recorded robot arm's wrist drooped 4.3 deg so); held with the integral
    term it stays at home."""
    model = compiled(arm_program(effort=10.0, arm_l=80.0), worker=worker, name="short_arm")
    b1 = run_battery(model, checks=["B1"], frames=False).check("B1")
    assert b1.passed, b1.message
    row = b1.measured["joints"]["arm_pivot"]
    assert 0.1 < row["gravity_torque_Nm"] < 0.5
    assert row["drift_deg"] < 1e-3 and row["tip_mm"] < 1e-2


def test_weak_slide_sags_in_mm_under_its_gravity_force(worker):
    model = compiled(slide_program(effort=10.0), worker=worker, name="weak_slide")
    b1 = run_battery(model, checks=["B1"], frames=False).check("B1")
    row = b1.measured["joints"]["cube_foot"]
    weight = part_mass(model, "cube").mass * G
    assert row["gravity_force_N"] == pytest.approx(weight, rel=0.02)  # ~77 N
    assert row["drift_mm"] == pytest.approx(25.0, abs=0.5)  # down onto its lower limit
    assert not b1.passed
    assert (f"joint 'cube_foot' sags {row['drift_mm']:.3g} mm from home (its far end moves "
            f"{row['tip_mm']:.3g} mm) under {weight:.3g} N of gravity force; its effort is 10 N: "
            f"raise effort to at least ~") in b1.message
    strong = compiled(slide_program(effort=200.0), worker=worker, name="strong_slide")
    b1 = run_battery(strong, checks=["B1"], frames=False).check("B1")
    assert b1.passed, b1.message
    assert b1.measured["joints"]["cube_foot"]["drift_mm"] < 1e-3


def test_weak_ball_sags_by_its_rotation_angle(worker):
    model = compiled(ball_program(effort=0.2), worker=worker, name="weak_ball")
    b1 = run_battery(model, checks=["B1"], frames=False).check("B1")
    row = b1.measured["joints"]["arm_ball"]
    assert 1.5 < row["gravity_torque_Nm"] < 2.5 and row["saturated"]  # 2.5 kg 80 mm out
    assert row["drift_deg"] > 20.0 and row["tip_mm"] > 50.0
    assert not b1.passed and "joint 'arm_ball' sags" in b1.message
    assert (f"sags {row['drift_deg']:.3g} deg from home (its far end moves {row['tip_mm']:.3g} mm) "
            f"under {row['gravity_torque_Nm']:.3g} N m of gravity torque; its effort is 0.2 N m: "
            f"raise effort") in b1.message
    strong = compiled(ball_program(effort=20.0), worker=worker, name="strong_ball")
    b1 = run_battery(strong, checks=["B1"], frames=False).check("B1")
    assert b1.passed, b1.message
    assert b1.measured["joints"]["arm_ball"]["drift_deg"] < 1e-3


@pytest.mark.slow
def test_b2_shortfall_from_too_little_effort_says_so(worker):
    """0.05 N m cannot swing the arm's 0.23 kg m^2 over 180 deg in the 3 s ramp (gravity off in
    B2): the row and the message say the actuator saturated and how long that effort needs."""
    model = compiled(arm_program(effort=0.05, limits=(-90, 90)), worker=worker, name="slow_arm")
    b2 = run_battery(model, checks=["B2"], frames=False).check("B2")
    row = b2.measured["joints"]["arm_pivot"]
    assert row["reach"] < TOL.sweep_reach and row["cause"] == "effort"
    assert "too little effort" in row["why"] and "saturated at its effort 0.05 N m" in row["why"]
    need = float(row["why"].split("takes at least ")[1].split(" s")[0])
    assert need > 2 * SWEEP_RAMP_S + SWEEP_HOLD_S  # the effort could not make it in time
    assert (f"joint 'arm_pivot' reached {100 * row['reach']:.1f}% of its range (needs 97%): "
            f"towards 90 deg: too little effort") in b2.message
    assert row["ramp_s"] == 2 * SWEEP_RAMP_S
    assert row["ramp_needed_s"] == pytest.approx(math.pi / 3.0)  # 180 deg at 3 rad/s


@pytest.mark.slow
def test_b2_shortfall_from_a_collision_names_the_pair_and_the_pose(worker):
    """The forearm swung down towards +90 deg meets the base plate (its grandparent) at about
    72 deg: the MuJoCo reach row names both parts and links and the angle where it stopped."""
    model = compiled(arm_program(effort=100.0, limits=(-10, 10), arm_l=200.0, post_h=300.0,
                                 base_w=500.0, forearm=(400.0, (-90, 90))),
                     worker=worker, name="blocked_arm")
    b2 = run_battery(model, checks=["B2"], frames=False).check("B2")
    row = b2.measured["joints"]["forearm_pivot"]
    assert row["reach"] < TOL.sweep_reach and row["cause"] == "collision"
    assert "'forearm' (link 'forearm') against 'base' (link 'base')" in row["why"]
    stopped = float(row["why"].split("it got to ")[1].split(" deg")[0])
    assert 60.0 < stopped < 85.0 and stopped == pytest.approx(math.degrees(row["qmax"]), abs=0.01)
    assert f"joint 'forearm_pivot' reached {100 * row['reach']:.1f}% of its range" in b2.message
    assert "a collision: it got to" in b2.message
    shoulder = b2.measured["joints"]["arm_pivot"]  # free to move: no reason to give
    assert shoulder["reach"] >= TOL.sweep_reach and shoulder["why"] is None
    assert shoulder["ramp_needed_s"] == pytest.approx(math.radians(20) / 3.0)


def test_b2_row_with_no_exact_samples_says_why(worker):
    """The cube slides along X 30 mm above the plate: no pose needs an exact check, and the
    row says so instead of a bare ``samples: 0``."""
    model = compiled(slide_program(effort=200.0, across=True), worker=worker, name="clear_slide")
    b2 = run_battery(model, checks=["B2"], frames=False).check("B2")
    assert b2.passed, b2.message
    row = b2.measured["joints"]["cube_foot"]
    assert row["samples"] == 0 and row["reach"] >= TOL.sweep_reach and row["why"] is None
    assert "no moved part comes within reach of a fixed one" in row["samples_why"]
    near = compiled(slide_program(effort=200.0), worker=worker, name="near_slide")
    row = run_battery(near, checks=["B2"], frames=False).check("B2").measured["joints"]["cube_foot"]
    assert row["samples"] > 0 and "samples_why" not in row  # it comes down onto the plate


def _dof(velocity: float, effort: float = 10.0):
    from procedura_brep.articulation.tree import JointDof
    return JointDof("hinge", "revolute", -math.pi / 2, math.pi / 2, effort, velocity)


def test_reach_why_blames_a_ramp_faster_than_the_velocity_limit():
    """A joint still on its way at the end of the hold, not saturated and touching nothing:
    the ramp asked for more than its velocity limit (180 deg at 0.5 rad/s takes 6.28 s)."""
    stop = Stop(target=math.pi / 2, distance=math.pi, ramp_s=2 * SWEEP_RAMP_S, reached=1.2,
                speed=0.4, force=3.0, load=0.0, inertia=0.2, contacts=())
    cause, why = reach_why(_dof(velocity=0.5), stop)
    assert cause == "ramp"
    assert why == ("the ramp was too short: it got to 68.75 deg of 90 deg, still moving at 0.4 "
                   "rad/s when the hold ended; 180 deg at its velocity limit 0.5 rad/s takes "
                   "6.28 s, the ramp gave 3 s")


def test_reach_why_orders_collision_before_effort_and_notes_a_slow_rating():
    pair = ("forearm", "forearm", "base", "base")
    stop = Stop(target=math.pi / 2, distance=math.pi, ramp_s=3.0, reached=1.2, speed=0.0,
                force=10.0, load=9.0, inertia=0.2, contacts=(pair,))
    cause, why = reach_why(_dof(velocity=0.5), stop)
    assert cause == "collision"
    assert why.startswith("a collision: it got to 68.75 deg of 90 deg, with 'forearm' (link "
                          "'forearm') against 'base' (link 'base') in contact")
    assert "(also, 180 deg at its velocity limit 0.5 rad/s takes 6.28 s, the ramp gave 3 s)" in why
    cause, why = reach_why(_dof(velocity=3.0), dataclasses.replace(stop, contacts=()))
    assert cause == "effort" and "saturated at its effort 10 N m against 9 N m" in why
    assert "also" not in why  # 3 rad/s covers 180 deg in 1.05 s: the ramp was not too fast
