"""The coupling gate (gates/coupling.py) on real teeth (tests/gates/drive.py): a clean drive
passes with its measured teeth and centre distances; each planted fault fails with the pair and
the numbers: a wrong centre distance, a ratio typed against the teeth, a mis-phased pair, a
wrong sign (only the sweep over one pitch sees it), a rack off its pitch line, a nut off its
screw's axis."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from procedura_brep.config import TOL
from procedura_brep.gates import coupling as gate
from procedura_brep.gates.coupling import coupling_gate
from procedura_brep.program.edit import set_params

pytestmark = pytest.mark.slow

SRC = (Path(__file__).parent / "drive.py").read_text()
GEAR = "wheel_hub__pinion_hub"
RACK = "rack_bar_slide__pinion_hub"
RING = "ring_hub__planet_hub"
SCREW = "nut_slide__screw_hub"
_MODELS: dict[str, object] = {}


def _model(worker, src: str = SRC):
    if src not in _MODELS:
        model = worker.compile(src)
        assert [f.message for f in model.findings if f.severity == "error"] == []
        _MODELS[src] = model
    return _MODELS[src]


def _edited(**values: float) -> str:
    return set_params(SRC, values)


def _errors(findings, code: str) -> list[str]:
    return [f.message for f in findings if f.code == code and f.severity == "error"]


def test_a_clean_drive_passes_with_measured_teeth(worker):
    findings, res = coupling_gate(_model(worker))
    assert findings == [] and res.passed
    rows = res.measured["couplings"]
    assert rows[GEAR]["teeth"] == {"pinion": 15, "wheel": 30}
    assert rows[GEAR]["module_mm"] == {"pinion": pytest.approx(1.5), "wheel": pytest.approx(1.5)}
    assert rows[GEAR]["centre_mm"]["measured"] == pytest.approx(1.5 * (15 + 30) / 2, abs=1e-6)
    assert rows[RING]["teeth"] == {"planet": 12, "ring": 36}
    assert rows[RING]["centre_mm"]["expected"] == pytest.approx(1.5 * (36 - 12) / 2)
    assert rows[RACK]["pitch_line_mm"]["measured"] == pytest.approx(1.5 * 15 / 2, abs=1e-6)
    assert rows[SCREW]["axis_offset_mm"] == pytest.approx(0, abs=1e-9)
    for name in (GEAR, RACK, RING):  # every pose of one pitch ran, none overlaps
        sweep = rows[name]["sweep"]
        assert sweep["samples"] == sweep["of"] == TOL.coupling_samples
        assert sweep["max_depth_mm"] <= TOL.penetration_slack_mm


def test_check_model_runs_the_coupling_gate(worker):
    from procedura_brep.gates import check_model
    report = check_model(_model(worker)).as_dict()
    assert report["verdicts"]["coupling"] is True  # (its gears float 1 mm over the plate)
    assert "coupling" in report["timings"]
    assert set(report["coupling"]["couplings"]) == {GEAR, RACK, RING, SCREW}


def test_wrong_centre_distance_fails(worker):
    findings, res = coupling_gate(_model(worker, _edited(spread=0.4)))
    msgs = _errors(findings, "coupling-centre")
    assert len(msgs) == 1 and not res.passed
    assert "couple('wheel_hub', 'pinion_hub')" in msgs[0]
    assert "34.15 mm apart" in msgs[0] and "= 33.75 mm" in msgs[0]


def test_ratio_typed_against_the_teeth_fails(worker):
    src = SRC.replace('driven_teeth="z_wheel")', 'driven_teeth="z_ring")')  # 36 teeth declared
    assert src != SRC
    findings, _ = coupling_gate(_model(worker, src))
    msgs = _errors(findings, "coupling-teeth")
    assert len(msgs) == 1
    assert "wheel has 30 teeth" in msgs[0] and "driven_teeth = z_ring = 36" in msgs[0]


def test_mis_phased_pair_fails_at_rest(worker):
    findings, _ = coupling_gate(_model(worker, _edited(wheel_phase=0.0)))
    msgs = _errors(findings, "coupling-interference")
    assert len(msgs) == 1
    assert "the teeth of pinion and wheel interpenetrate" in msgs[0] and "at rest" in msgs[0]


def test_wrong_sign_is_caught_by_the_sweep_over_one_pitch(worker):
    model = _model(worker)
    flipped = [dataclasses.replace(c, ratio=-c.ratio) if c.name == GEAR else c
               for c in model.couplings]
    findings, res = coupling_gate(dataclasses.replace(model, couplings=flipped))
    msgs = _errors(findings, "coupling-interference")
    assert len(msgs) == 1 and "pinion_hub at" in msgs[0] and "at rest" not in msgs[0]
    assert res.measured["couplings"][GEAR]["sweep"]["max_depth_mm"] > TOL.penetration_slack_mm


def test_rack_off_its_pitch_line_fails(worker):
    findings, _ = coupling_gate(_model(worker, _edited(rack_gap=0.3)))
    msgs = _errors(findings, "coupling-rack")
    assert len(msgs) == 1 and "11.55 mm from the pitch line of rack_bar" in msgs[0]
    assert "m z / 2 = 1.5 x 15 / 2 = 11.25 mm" in msgs[0]


def test_nut_off_the_screw_axis_fails(worker):
    findings, _ = coupling_gate(_model(worker, _edited(nut_off=0.5)))
    msgs = _errors(findings, "coupling-screw")
    assert len(msgs) == 1 and "0.5 mm off the screw axis of screw_hub" in msgs[0]


def test_the_time_bound_reports_not_verified_never_a_pass(worker, monkeypatch):
    monkeypatch.setattr(gate, "TOL", dataclasses.replace(TOL, coupling_time_s=0.0))
    findings, res = coupling_gate(_model(worker))
    warned = [f for f in findings if f.code == "coupling-not-verified"]
    assert {f.other for f in warned} == {"pinion", "planet"} and len(warned) == 3
    assert all(f.severity == "warning" for f in warned)
    assert res.measured["couplings"][GEAR]["sweep"]["samples"] == 0


def test_plain_discs_are_unmeasured_not_passed_as_checked(worker):
    src = (Path(__file__).parents[1] / "program" / "transmission.py").read_text()
    findings, res = coupling_gate(_model(worker, src))
    unmeasured = [f for f in findings if f.code == "coupling-unmeasured"]
    assert unmeasured and all(f.severity == "warning" for f in unmeasured)
    assert res.measured["couplings"]["wheel_hub__pinion_hub"]["measured"] is False
