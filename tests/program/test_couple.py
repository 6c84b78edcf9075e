"""``couple(...)``: the statement's checks, the ratio and its sign from the params and the two
joints' world axes, and the coupling carried from the sandbox child into ``mates.json``."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from procedura_brep.export.records import mates_json
from procedura_brep.program.model import to_json
from procedura_brep.program.trust import ResultError, model_from_json

SRC = (Path(__file__).parent / "transmission.py").read_text()
GEAR = 'couple("wheel_hub", "pinion_hub", "gear", driver_teeth="z_pinion", driven_teeth="z_wheel")'
RACK = 'couple("rack_slide", "pinion_hub", "rack_pinion", pinion_teeth="z_pinion", module="gear_m")'
SCREW = 'couple("nut_slide", "screw_hub", "screw", lead="screw_lead", hand="right")'


def _compile(worker, src: str):
    return worker.compile(src)


def _errors(model) -> list[str]:
    return [f.message for f in model.findings if f.severity == "error"]


def test_ratios_and_signs_follow_the_params_and_axes(worker):
    m = _compile(worker, SRC)
    assert not _errors(m)
    got = {c.name: c.ratio for c in m.couplings}
    # external mesh, parallel axes: the wheel turns the other way, 12/36 as fast
    assert got["wheel_hub__pinion_hub"] == pytest.approx(-12 / 36)
    # the pinion's pitch point under its axis moves +X for +theta about +Z: +r mm per rad
    assert got["rack_slide__pinion_hub"] == pytest.approx(2.0 * 12 / 2)
    # a right-hand screw turning +theta about +X pulls a nut that cannot turn back along -X
    assert got["nut_slide__screw_hub"] == pytest.approx(-4.0 / (2 * math.pi))
    assert [c.mesh for c in m.couplings] == [("wheel", "pinion"), ("rack", "pinion"), ("screw", "nut")]
    gear = next(c for c in m.couplings if c.type == "gear")
    assert gear.inputs["driver_teeth"] == "z_pinion" and gear.values["driven_teeth"] == 36.0


def test_one_edit_changes_the_ratio(worker):
    m = _compile(worker, SRC.replace("z_wheel = 36", "z_wheel = 48"))
    assert {c.name: c.ratio for c in m.couplings}["wheel_hub__pinion_hub"] == pytest.approx(-12 / 48)


def test_opposed_axes_keep_the_sense_of_an_external_mesh(worker):
    """The wheel's joint axis turned to -Z (same wheel, same place): its positive sense is the
    pinion's negative one, so the external mesh now reads +12/36."""
    src = (SRC.replace("w_axis=Location((-24, gear_m * (z_pinion + z_wheel) / 2, base_t + 1))",
                       "w_axis=Location((-24, gear_m * (z_pinion + z_wheel) / 2, base_t + 1 + gear_w), (180, 0, 0))")
           .replace('frames("wheel", hub=Location((0, 0, 0)))',
                    'frames("wheel", hub=Location((0, 0, gear_w), (180, 0, 0)))'))
    m = _compile(worker, src)
    assert not _errors(m)
    assert m.part("wheel").placement[:3, 3] == pytest.approx([-24, 48, 11])
    assert m.part("wheel").placement[:3, 2] == pytest.approx([0, 0, 1])  # the wheel did not move
    assert {c.name: c.ratio for c in m.couplings}["wheel_hub__pinion_hub"] == pytest.approx(12 / 36)


def test_internal_mesh_and_left_hand_keep_and_flip_the_sense(worker):
    src = (SRC.replace(GEAR, GEAR[:-1] + ", internal=True)")
           .replace('hand="right"', 'hand="left"'))
    got = {c.name: c.ratio for c in _compile(worker, src).couplings}
    assert got["wheel_hub__pinion_hub"] == pytest.approx(12 / 36)
    assert got["nut_slide__screw_hub"] == pytest.approx(4.0 / (2 * math.pi))


def test_a_rack_on_the_other_side_reverses_and_the_rack_may_drive(worker):
    src = (SRC.replace("-gear_m * z_pinion / 2, base_t)", "gear_m * z_pinion / 2, base_t)")
           .replace("align=(Align.CENTER, Align.MAX, Align.MIN)", "align=(Align.CENTER, Align.MIN, Align.MIN)")
           .replace(RACK, 'couple("pinion_hub", "rack_slide", "rack_pinion", pinion_teeth="z_pinion", '
                          'module="gear_m")').replace(GEAR + "\n", ""))
    m = _compile(worker, src)
    assert not _errors(m)
    assert {c.name: c.ratio for c in m.couplings}["pinion_hub__rack_slide"] == pytest.approx(-1 / 12)


@pytest.mark.parametrize("edit, expected", [
    # wrong kinds: one line naming both mates and their kinds
    (lambda s: s.replace(RACK, 'couple("rack_slide", "pinion_hub", "gear", driver_teeth="z_pinion", '
                               'driven_teeth="z_wheel")'),
     "couple('rack_slide', 'pinion_hub'): gear joins driven revolute, driver revolute; rack_slide is "
     "prismatic and pinion_hub is revolute"),
    (lambda s: s.replace(SCREW, 'couple("screw_hub", "nut_slide", "screw", lead="screw_lead")'),
     "screw joins driven prismatic, driver revolute; screw_hub is revolute and nut_slide is prismatic"),
    # a ratio input typed as a number
    (lambda s: s.replace('driver_teeth="z_pinion"', "driver_teeth=12"),
     "driver_teeth must be the NAME of a param (a string such as 'z_pinion'), not the literal 12"),
    # an unknown param: did you mean
    (lambda s: s.replace('driver_teeth="z_pinion"', 'driver_teeth="z_pinon"'),
     "driver_teeth='z_pinon' is not a param (did you mean 'z_pinion'?)"),
    (lambda s: s.replace('"wheel_hub", "pinion_hub"', '"wheel_hub", "pinion_hb"'),
     "driver mate 'pinion_hb' is not a mate of the program (did you mean 'pinion_hub'?)"),
    (lambda s: s.replace('"gear", driver_teeth', '"gears", driver_teeth'),
     "type 'gears' is not one of gear, rack_pinion, screw, belt, linkage (did you mean 'gear'?)"),
    (lambda s: s.replace('hand="right"', 'hand="rigth"'), "hand='rigth' is not one of 'right', 'left'"),
    (lambda s: s.replace("z_pinion = 12", "z_pinion = 12.5"),
     "driver_teeth: param z_pinion = 12.5 must be a whole number of teeth"),
    (lambda s: s + 'couple("wheel_hub", "pinion_hub", "belt", driver_diameter="screw_d", '
                   'driven_diameter="gear_w")\n',
     "joint wheel_hub is already driven by pinion_hub (line 66); a joint has one driver"),
    (lambda s: s + 'couple("pinion_hub", "wheel_hub", "gear", driver_teeth="z_wheel", '
                   'driven_teeth="z_pinion")\n',
     "the couplings form a cycle (wheel_hub <- pinion_hub <- wheel_hub)"),
    (lambda s: s + 'couple("screw_hub", "wheel_hub", "belt", driver_teeth="z_wheel", '
                   'driven_teeth="z_pinion")\n',
     "a belt needs parallel axes; wheel_hub and screw_hub are 90 deg apart"),
])
def test_a_bad_coupling_is_one_line_naming_it(worker, edit, expected):
    m = _compile(worker, edit(SRC))
    errors = _errors(m)
    assert any(expected in e for e in errors), errors
    assert all("\n" not in e for e in errors)
    assert not any(f.code == "module-exception" for f in m.findings)


def test_the_coupling_reaches_mates_json_and_survives_the_trust_check(worker):
    m = _compile(worker, SRC)
    rows = mates_json(m)["couplings"]
    assert [(r["driven"], r["driver"], r["type"]) for r in rows] == [
        ("wheel_hub", "pinion_hub", "gear"), ("rack_slide", "pinion_hub", "rack_pinion"),
        ("nut_slide", "screw_hub", "screw")]
    back = model_from_json(to_json(m))
    assert back.couplings == m.couplings
    bad = to_json(m)
    bad["couplings"][0]["driven"] = "base"
    with pytest.raises(ResultError, match=r"couplings\[0\]\.driven"):
        model_from_json(bad)
    bad = to_json(m)
    bad["couplings"][1]["ratio"] = float("inf")
    with pytest.raises(ResultError, match=r"couplings\[1\]\.ratio"):
        model_from_json(bad)


def test_the_program_builds_with_its_couplings_in_mates_json(tmp_path):
    """Through the CLI: the gates pass (every part touches) and the run's mates.json carries
    the couplings with their params."""
    import json

    from typer.testing import CliRunner

    from procedura_brep.cli import app
    prog = tmp_path / "transmission.py"
    prog.write_text(SRC)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["build", str(prog), "-o", str(out), "--formats", "step"])
    assert res.exit_code == 0, res.output
    rows = json.loads((out / "mates.json").read_text())["couplings"]
    assert {r["name"]: (r["inputs"], r["mesh"]) for r in rows}["nut_slide__screw_hub"] == (
        {"lead": "screw_lead", "hand": "right"}, ["screw", "nut"])


def test_a_failed_meshing_part_is_a_finding_not_a_broken_result(worker):
    """The wheel's solid fails: its mates and coupling still come back (naming it), and the
    parent reads the child's result (a coupling may name a part the result lacks)."""
    m = _compile(worker, SRC.replace("gear_m * z_wheel / 2 - 1, gear_w", "0, gear_w"))
    assert any(f.code == "part-exception" and f.part == "wheel" for f in m.findings)
    assert "wheel" not in [p.name for p in m.parts]
    assert {c.name: c.mesh for c in m.couplings}["wheel_hub__pinion_hub"] == ("wheel", "pinion")


CARRIAGE = (SRC
            .replace('''@part(detail="major", material="steel", description="nut block on the base, the screw through its bore")
def nut():
    return Box(20, 20, 20) - Cylinder(screw_d / 2, 20)''',
                     '''@part(detail="major", material="steel", description="carriage, the screw through a clearance bore")
def carriage():
    return Box(20, 20, 20) - Cylinder(screw_d / 2 + 1, 20)

@part(detail="major", material="brass", description="threaded nut bolted to the carriage's end")
def nut():
    return Box(20, 20, 10) - Cylinder(screw_d / 2, 10)''')
            .replace('frames("nut", slide=Location((0, 0, 0)))',
                     'frames("carriage", slide=Location((0, 0, 0)), face=Location((0, 0, 10)))\n'
                     'frames("nut", seat=Location((0, 0, -5)))')
            .replace('mate("nut.slide", "base.n_rail"', 'mate("carriage.slide", "base.n_rail"')
            .replace(SCREW, 'mate("nut.seat", "carriage.face", "seat_face", nominal="screw_d", features=False)\n'
                            'couple("carriage_slide", "screw_hub", "screw", lead="screw_lead")'))


def test_the_screw_meshes_with_the_nut_bolted_to_the_carriage_not_the_carriage(worker):
    """A screw's engaging part is the nut on the slide's side (the smallest part there that the
    screw axis passes through), not the slide's child it is bolted to: B2 would otherwise sweep
    the threaded screw through its threaded nut (a recorded run spent 17 minutes there)."""
    assert CARRIAGE != SRC and "def carriage" in CARRIAGE and 'carriage_slide"' in CARRIAGE
    m = _compile(worker, CARRIAGE)
    assert not [e for e in _errors(m) if "coupl" in e], _errors(m)
    assert {c.name: c.mesh for c in m.couplings}["carriage_slide__screw_hub"] == ("screw", "nut")
    named = _compile(worker, CARRIAGE.replace('lead="screw_lead")', 'lead="screw_lead", nut="carriage")'))
    assert {c.name: c.mesh for c in named.couplings}["carriage_slide__screw_hub"] == ("screw", "carriage")
    typo = _compile(worker, CARRIAGE.replace('lead="screw_lead")', 'lead="screw_lead", nut="nutt")'))
    assert any("nut='nutt' is not a part" in e and "nut" in e for e in _errors(typo)), _errors(typo)
    base = _compile(worker, CARRIAGE.replace('lead="screw_lead")', 'lead="screw_lead", nut="base")'))
    assert any("nut='base' does not move with carriage" in e for e in _errors(base)), _errors(base)
