"""The coupling gate's belt and screw checks (gates/coupling.py, gates/drive_shapes.py): a belt's
pulleys are measured against its teeth or diameters and must share a plane (tests/gates/belt.py);
a lead screw's thread, and its nut's, against the coupling's lead and hand (tests/gates/drive.py,
its screw coupling alone: the gear sweeps are test_coupling.py's). Each planted fault fails with
the part and the numbers; the clean programs pass."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.gates import coupling as gate
from procedura_brep.gates.coupling import coupling_gate
from procedura_brep.program.edit import set_params

pytestmark = pytest.mark.slow

HERE = Path(__file__).parent
BELT = (HERE / "belt.py").read_text()
DRIVE = (HERE / "drive.py").read_text()
TIMING = "follow_pulley_hub__drive_shaft_hub"
FLAT = "big_roller_hub__roller_shaft_hub"
SCREW = "nut_slide__screw_hub"
_MODELS: dict[str, object] = {}


def _model(worker, src: str, only: str | None = None):
    if src not in _MODELS:
        model = worker.compile(src)
        assert [f.message for f in model.findings if f.severity == "error"] == []
        _MODELS[src] = model
    model = _MODELS[src]
    if only is not None:  # one coupling: the drive's gear sweeps take seconds
        model = dataclasses.replace(model, couplings=[c for c in model.couplings if c.name == only])
    return model


def _errors(findings, code: str) -> list[str]:
    return [f.message for f in findings if f.code == code and f.severity == "error"]


# -- belt ----------------------------------------------------------------------------------------
def test_clean_belts_pass_with_measured_pulleys(worker):
    findings, res = coupling_gate(_model(worker, BELT))
    assert findings == [] and res.passed
    rows = res.measured["couplings"]
    # the drive pulley is fused to its shaft: the seat is the rim between its flanges
    assert rows[TIMING]["teeth"] == {"drive_shaft": 20, "follow_pulley": 24}
    assert rows[TIMING]["overlap_mm"] == pytest.approx(6.0)
    # the small roller is bolted to its shaft (the shaft's rigid link): found, not the shaft
    assert rows[FLAT]["pair"] == ["small_roller", "big_roller"]
    assert rows[FLAT]["diameter_mm"]["small_roller"] == {"expected": 20.0, "measured": 20.0}
    assert rows[FLAT]["diameter_mm"]["big_roller"]["measured"] == pytest.approx(40.0)


def test_pulley_with_other_teeth_than_the_param_fails(worker):
    src = BELT.replace("teeth=z_follow,", "teeth=20,")  # 20 grooves, z_follow = 24 declared
    assert src != BELT
    findings, res = coupling_gate(_model(worker, src))
    msgs = _errors(findings, "coupling-teeth")
    assert len(msgs) == 1 and not res.passed
    assert msgs[0].startswith("couple('follow_pulley_hub', 'drive_shaft_hub'): ")
    assert "follow_pulley has 20 teeth" in msgs[0] and "driven_teeth = z_follow = 24" in msgs[0]


def test_pulley_of_the_wrong_diameter_fails(worker):
    src = BELT.replace("diameter=d_big,", "diameter=38,")  # a 38 mm roller, d_big = 40 declared
    assert src != BELT
    findings, res = coupling_gate(_model(worker, src))
    msgs = _errors(findings, "coupling-pulley")
    assert len(msgs) == 1 and not res.passed
    assert "big_roller has a belt seat 38 mm across" in msgs[0]
    assert "driven_diameter = d_big = 40 mm (allowed +-0.1 mm)" in msgs[0]


def test_pulleys_in_different_planes_fail(worker):
    findings, res = coupling_gate(_model(worker, set_params(BELT, {"follow_shift": 8.5})))
    msgs = _errors(findings, "coupling-belt")
    assert len(msgs) == 1 and not res.passed
    assert "drive_shaft (17 .. 23 mm along the axis of drive_shaft_hub)" in msgs[0]
    assert "follow_pulley (25.5 .. 31.5 mm) do not overlap (2.5 mm apart)" in msgs[0]
    # still overlapping by half a millimetre: one plane
    findings, _ = coupling_gate(_model(worker, set_params(BELT, {"follow_shift": 5.5})))
    assert _errors(findings, "coupling-belt") == []


def test_timing_pulleys_typed_by_pitch_diameter(worker):
    src = BELT.replace('driver_teeth="z_drive", driven_teeth="z_follow"',
                       'driver_diameter="pd_drive", driven_diameter="pd_follow"')
    assert src != BELT
    findings, res = coupling_gate(_model(worker, src, TIMING))
    assert findings == []
    got = res.measured["couplings"][TIMING]["diameter_mm"]
    assert got["drive_shaft"]["measured"] == pytest.approx(20 * 2 / math.pi, abs=1e-6)
    # the tip diameter (0.508 mm smaller) is not the pitch diameter the param names
    findings, _ = coupling_gate(_model(worker, set_params(src, {"pd_follow": 15.279 - 0.508}),
                                       TIMING))
    msgs = _errors(findings, "coupling-pulley")
    assert len(msgs) == 1 and "24 grooves and tips 14.77 mm across" in msgs[0]


@pytest.mark.parametrize(("teeth", "pitch"), [(12, 2.0), (20, 2.0), (37, 3.0), (60, 5.0)])
def test_pitch_diameter_from_tips_matches_what_pulley_builds(teeth, pitch):
    from procedura_brep.gates.drive_shapes import belt_seat
    from procedura_brep.program.gearing import pulley

    line = gate.Line(np.zeros(3), np.array([0.0, 0.0, 1.0]))
    shape = pulley(6.0, teeth=teeth, pitch=pitch).wrapped
    seat = belt_seat(shape, line)
    assert seat is not None and seat.flanged and (seat.lo, seat.hi) == pytest.approx((-3, 3))
    teeth_read = gate.teeth_levels(shape, line, internal=False, tip=seat.radius)
    assert {lv: t.count for lv, t in teeth_read} == {-3.0: teeth, 3.0: teeth}
    found = gate.Pulley(None, line, seat, teeth_read[0][1])  # type: ignore[arg-type]
    assert found.pitch_diameter == pytest.approx(teeth * pitch / math.pi, abs=1e-9)


# -- screw ---------------------------------------------------------------------------------------
def test_clean_screw_passes_with_measured_leads(worker):
    findings, res = coupling_gate(_model(worker, DRIVE, SCREW))
    assert findings == []
    assert res.measured["couplings"][SCREW]["lead_mm"] == {"screw": pytest.approx(2.5, abs=1e-4),
                                                           "nut": pytest.approx(2.5, abs=1e-4)}


def test_screw_thread_of_another_lead_fails(worker):
    src = DRIVE.replace("lead_screw(screw_d, lead, screw_l)", "lead_screw(screw_d, 2.0, screw_l)")
    assert src != DRIVE
    findings, res = coupling_gate(_model(worker, src, SCREW))
    msgs = _errors(findings, "coupling-lead")
    assert len(msgs) == 1 and not res.passed
    assert msgs[0].startswith("couple('nut_slide', 'screw_hub'): the thread of screw (the screw) "
                              "advances 2 mm per turn")
    assert "lead = lead = 2.5 mm (allowed +-1 %)" in msgs[0]


def test_nut_thread_of_another_lead_fails(worker):
    src = DRIVE.replace("lead_nut(screw_d, lead, nut_l)", "lead_nut(screw_d, 3.0, nut_l)")
    assert src != DRIVE
    findings, _ = coupling_gate(_model(worker, src, SCREW))
    msgs = _errors(findings, "coupling-lead")
    assert len(msgs) == 1 and "the thread of nut (the nut) advances 3 mm per turn" in msgs[0]


def test_thread_of_the_other_hand_fails(worker):
    src = DRIVE.replace('lead="lead", hand="right")', 'lead="lead", hand="left")')
    assert src != DRIVE
    findings, _ = coupling_gate(_model(worker, src, SCREW))
    msgs = _errors(findings, "coupling-lead")
    assert len(msgs) == 2 and all("right-handed, but the coupling says hand='left'" in m
                                  for m in msgs)


def test_plain_screw_is_unmeasured_not_passed(worker):
    plain = "Cylinder(screw_d / 2, screw_l, align=(Align.CENTER, Align.CENTER, Align.MIN))"
    src = DRIVE.replace("lead_screw(screw_d, lead, screw_l)", plain)
    findings, res = coupling_gate(_model(worker, src, SCREW))
    assert [(f.code, f.severity, f.part) for f in findings] == [
        ("coupling-unmeasured", "warning", "screw")]
    assert res.passed and res.measured["couplings"][SCREW]["measured"] is False
    assert res.measured["couplings"][SCREW]["lead_mm"] == {"nut": pytest.approx(2.5, abs=1e-4)}
