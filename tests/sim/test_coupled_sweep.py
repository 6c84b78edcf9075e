"""B2's exact sweep moves coupled joints together (issue 27 item 4): a driver is swept with
every joint it drives at ``ratio * q``, over the range that keeps them inside their limits; a
driven joint is not swept on its own. And every joint's sweep is bounded in time
(``TOL.sweep_time_s``): a stopped sweep is *not verified*, never a pass, never a failure."""

from __future__ import annotations

import dataclasses
import math
import re

import pytest

from procedura_brep.articulation import articulate
from procedura_brep.config import TOL
from procedura_brep.sim import run_battery
from procedura_brep.sim.sweep import SweepScene, sweep_all

from .gearpair import program as gear_program
from .leadscrew import meets_mm
from .leadscrew import program as screw_program

STOP_IN_PATH, STOP_BEYOND = 0.0, 70.0  # the carriage travels 0..100 mm; the block meets a stop
# at x = 0 after 50 mm, one at x = 70 never (120 mm)


def _compile(source: str, worker, name: str = "coupled"):
    from procedura_brep.program import compile_source
    model = compile_source(source, name=name, worker=worker)
    assert model.ok, [f.message for f in model.findings if f.severity == "error"]
    return model


@pytest.fixture(scope="module")
def screws(worker):
    return {x: _compile(screw_program(x), worker) for x in (STOP_IN_PATH, STOP_BEYOND)}


def test_the_screw_drives_the_carriage_block_into_the_stop(screws):
    """The block is on the carriage, which only the screw moves: the screw's sweep carries it
    (at the screw's ratio, 4 mm per turn) into the stop, first at 50 mm of travel, 12.5 turns;
    the carriage's own joint is not swept again."""
    model = screws[STOP_IN_PATH]
    art = articulate(model)
    hits, _ = sweep_all(model, art, list(art.joints), parallel=False)
    hit = hits["screw_hub"]
    assert hit.pair == ("block", "stop") and hit.depth > TOL.sim_penetration_mm, hit
    travel, turn = re.fullmatch(r"carriage_slide ([-\d.]+) mm \(screw_hub ([-\d.]+) deg\)", hit.first_at).groups()
    assert meets_mm(STOP_IN_PATH) <= float(travel) <= meets_mm(STOP_IN_PATH) + TOL.sweep_step_mm
    ratio = art.joint("carriage_slide").coupling.ratio  # m/rad
    assert float(turn) == pytest.approx(math.degrees(float(travel) / 1000.0 / ratio), rel=1e-3)
    assert abs(float(turn)) / 360.0 == pytest.approx(meets_mm(STOP_IN_PATH) / 4.0, abs=0.3)
    follower = hits["carriage_slide"]
    assert follower.swept_with == "screw_hub" and follower.samples == 0 and follower.pair is None


def test_b2_fails_on_the_screw_and_the_carriage_row_says_it_went_with_it(screws, tmp_path):
    report = run_battery(screws[STOP_IN_PATH], out_dir=tmp_path, checks=["B2"], frames=False)
    b2 = report.check("B2")
    assert not b2.passed and b2.status == "fail"
    assert "joint 'screw_hub' drives 'block'" in b2.message and "mm into 'stop' at carriage_slide" in b2.message
    row = b2.measured["joints"]["carriage_slide"]
    assert row["driven_by"] == "screw_hub" and row["swept_with"] == "screw_hub"
    assert "samples_why" not in row and "carriage_slide'" not in b2.message


def test_the_stop_beyond_the_travel_passes(screws, tmp_path):
    report = run_battery(screws[STOP_BEYOND], out_dir=tmp_path, checks=["B2"], frames=False)
    b2 = report.check("B2")
    assert b2.passed and b2.status == "pass", b2.message
    # nothing needed a pose: the block's travel ends short of the stop, and the block (20 mm
    # and more from the screw axis) never meets the screw (5 mm at most) as both move
    assert "samples_why" in b2.measured["joints"]["screw_hub"], b2.measured["joints"]["screw_hub"]


def test_a_collar_on_the_screw_meets_the_carriage_as_both_move(worker):
    """A part on the turning screw against one on the sliding carriage (a compound pair: their
    relative motion is a screw motion, neither joint alone): the carriage runs into a collar
    110 mm along the screw (x = 10..16) when its front face (x = -50 at rest) has travelled 60 mm;
    one at 160 mm is beyond the travel (100 mm)."""
    hits = {}
    for z in (110.0, 160.0):
        model = _compile(screw_program(STOP_BEYOND, collar_z=z), worker)
        art = articulate(model)
        hits[z] = SweepScene(model, art).sweep(art.joint("screw_hub"))
    hit = hits[110.0]
    assert hit.pair == ("carriage", "collar") and hit.depth > TOL.sim_penetration_mm and not hit.stopped
    turn = float(re.fullmatch(r"screw_hub ([-\d.]+) deg", hit.first_at).group(1))
    travel = math.radians(turn) * 4.0 / (2 * math.pi)  # a left-hand screw: +lead per turn
    assert 60.0 <= travel <= 60.0 + TOL.sweep_step_mm, hit.first_at
    assert hits[160.0].pair is None and ("carriage", "collar") in hits[160.0].contact


def test_an_arm_on_the_driven_gear_hits_a_post_only_within_the_coupled_range(worker):
    """The driven disc follows the driver at -1/2: over the driver's +-170 deg it turns +-85
    deg, so its arm meets a post at 60 deg (when the driver has turned about -100 deg) and never
    one at 120 deg, which its own +-170 deg would reach (the driven joint swept alone failed it)."""
    out = {}
    for deg in (60.0, 120.0):
        model = _compile(gear_program(deg), worker, "gears")
        art = articulate(model)
        hits, _ = sweep_all(model, art, list(art.joints), parallel=False)
        out[deg] = hits
        assert hits["driven_hub"].swept_with == "driver_hub"
    hit = out[60.0]["driver_hub"]
    assert hit.pair == ("arm", "post") and hit.depth > TOL.sim_penetration_mm
    driven, driver = map(float, re.fullmatch(r"driven_hub ([-\d.]+) deg \(driver_hub ([-\d.]+) deg\)",
                                             hit.first_at).groups())
    assert driver == pytest.approx(-2 * driven, rel=1e-3) and 45.0 <= driven <= 60.0
    assert out[120.0]["driver_hub"].depth <= TOL.sim_penetration_mm and out[120.0]["driver_hub"].pair is None


@pytest.mark.parametrize("stop_x", [STOP_IN_PATH, STOP_BEYOND])
def test_a_sweep_past_its_time_bound_is_not_verified(screws, stop_x, monkeypatch, tmp_path, worker):
    """With a time bound that every sweep outlasts, B2 neither fails the stop in the path nor
    passes the clear model: both are *not verified*, naming the bound and its config key."""
    from procedura_brep.sim import battery, sweep
    from procedura_brep.sim.battery import failures
    tiny = dataclasses.replace(TOL, sweep_time_s=0.0)
    monkeypatch.setattr(sweep, "TOL", tiny)
    monkeypatch.setattr(battery, "TOL", tiny)
    # the clear model with a collar on the screw beyond the carriage's travel: its pair with the
    # carriage needs poses (the block alone never comes near anything: prefilters rule it out)
    model = screws[stop_x] if stop_x == STOP_IN_PATH else _compile(
        screw_program(stop_x, collar_z=160.0), worker)
    report = run_battery(model, out_dir=tmp_path, checks=["B2"], frames=False)
    b2 = report.check("B2")
    assert b2.status == "not verified" and not report.verified, b2.message
    assert "joint 'screw_hub': the exact sweep ran past its bound of 0 s" in b2.unverified
    assert "TOL.sweep_time_s" in b2.unverified and "drives" not in b2.message
    row = b2.measured["joints"]["screw_hub"]
    assert row["stopped_by"] == "time" and row["not_verified"]
    (f,) = [f for f in failures(report) if f.code == "not-verified"]
    assert f.severity == "warning"
    assert not [f for f in failures(report) if f.code == "battery-B2"]


def _sleeved(stop_x: float) -> str:
    """The lead screw program with a real (left-hand) thread on the screw and a sleeve bolted
    to the carriage's front around it, 1 mm clear of the thread's crest: a part on the sliding
    carriage against the turning screw whose helical faces no turn or slide maps onto
    themselves."""
    src = screw_program(stop_x).replace("screw_lead = 4.0", "screw_lead = 3.0")  # a third of 10 at most
    src = src.replace(
        "    return Cylinder(screw_d / 2, screw_l, align=(Align.CENTER, Align.CENTER, Align.MIN))",
        '    return make_lead_screw(screw_d, screw_lead, screw_l, hand="left")')
    src = src.replace('frames("carriage", slide=Location((0, 0, 0), (0, 90, 0)),',
                      'frames("carriage", slide=Location((0, 0, 0), (0, 90, 0)), '
                      'front=Location((10, 0, 0), (0, 90, 0)),')
    src = src.replace("# === frames ===", '''@part(detail="sub", material="steel", description="sleeve on the carriage's front, clear of the screw")
def sleeve():
    return Cylinder(12, 30, align=(Align.CENTER, Align.CENTER, Align.MIN)) - Cylinder(screw_d / 2 + 1, 30, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("sleeve", seat=Location((0, 0, 0)))''')
    src = src.replace('couple("carriage_slide"', 'mate("sleeve.seat", "carriage.front", "seat_face", '
                      'nominal="guide_w", features=False)\ncouple("carriage_slide"')
    assert src.count("sleeve") >= 4 and "make_lead_screw" in src
    return src


def test_a_sleeve_clear_of_the_thread_costs_no_boolean(worker):
    """The sleeve lies wholly outside a cylinder about the screw axis that the thread lies
    wholly inside: the screw motion of the pair keeps every distance from that axis, so the
    radial prefilter (:meth:`SweepScene.radially_apart`) rules the pair out before any pose; a
    thread's boolean costs about a second, and the carriage travels 100 mm."""
    model = _compile(_sleeved(STOP_BEYOND), worker)
    # the carriage's bore holds the thread: it is the nut, not the smaller sleeve around it
    assert [c.mesh for c in model.couplings] == [("screw", "carriage")]
    art = articulate(model)
    scene = SweepScene(model, art)
    axis = art.joint("screw_hub")
    assert scene.radially_apart("sleeve", "screw", axis.frame[:3, 3], axis.axis)
    assert not scene.radially_apart("carriage", "screw", axis.frame[:3, 3], axis.axis)  # its bore holds it
    hit = scene.sweep(axis)
    assert hit.pair is None and not hit.stopped, hit
    assert ("sleeve", "screw") not in hit.contact and ("screw", "sleeve") not in hit.contact
    assert hit.booleans <= 2, hit.booleans
