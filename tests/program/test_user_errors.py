"""User mistakes caught by the compiler, end to end through the CLI: an unknown material and
a size param taken to zero or below (issues 9.7, 9.8, 11.8)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app

LAMP = (Path(__file__).parent / "lamp.py").read_text()
runner = CliRunner()


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "prog.py"
    p.write_text(text)
    return p


def test_unknown_material_fails_check_and_build_with_a_report(tmp_path):
    prog = _write(tmp_path, LAMP.replace('material="cast_iron"', 'material="unobtanium"'))
    res = runner.invoke(app, ["check", str(prog)])
    assert res.exit_code == 2, res.output
    assert "part base: unknown material 'unobtanium'" in res.output and "use one of: steel" in res.output
    out = tmp_path / "out"
    res = runner.invoke(app, ["build", str(prog), "-o", str(out), "--formats", "step"])
    assert res.exit_code in (1, 2) and "internal error" not in res.output, res.output
    report = json.loads((out / "report.json").read_text())
    f = report["findings"][0]
    assert f["code"] == "material" and f["part"] == "base" and "cast_iron" in f["message"]


def test_edit_to_a_negative_size_names_the_param(tmp_path):
    prog = _write(tmp_path, LAMP)
    res = runner.invoke(app, ["edit", str(prog), "--set", "pin_d=-5"])
    assert res.exit_code == 2, res.output
    assert "pin_d = -5 mm: pin_d is a size" in res.output and "must stay > 0" in res.output
    assert prog.read_text() == LAMP


def test_kernel_refusal_names_the_non_positive_param(tmp_path):
    """A size the edit check cannot know about (an expression) still gets explained."""
    prog = _write(tmp_path, LAMP.replace("base_w = 120.0", "base_w = 10.0 - 20.0"))
    res = runner.invoke(app, ["check", str(prog)])
    assert res.exit_code in (1, 2)
    assert "Standard_DomainError" in res.output and "base_w = -10: sizes must be > 0" in res.output


def test_a_part_named_like_a_param_is_a_user_error_not_a_dead_child(tmp_path):
    """`base_t = 12.0` and `def base_t()`: the function rebinds the param. The compile child
    died with "exited without a result (exit 3)" when frames then used the param."""
    prog = _write(tmp_path, LAMP.replace("def post():", "def base_t():").replace(
        'frames("post",', 'frames("base_t",').replace('"post.foot"', '"base_t.foot"').replace(
        '"post.head"', '"base_t.head"'))
    res = runner.invoke(app, ["check", str(prog)])
    assert res.exit_code == 2, res.output
    assert "param base_t is rebound by a function of the same name" in res.output
    assert "exited without a result" not in res.output and "internal error" not in res.output


def test_a_mistyped_material_gets_a_did_you_mean(tmp_path):
    """Issue 26.4: part, param, mate and material names all get a "did you mean"."""
    prog = _write(tmp_path, LAMP.replace('material="cast_iron"', 'material="cast_irn"'))
    res = runner.invoke(app, ["check", str(prog)])
    assert res.exit_code == 2, res.output
    assert "part base: unknown material 'cast_irn' (did you mean 'cast_iron'?); use one of:" in res.output


@pytest.mark.parametrize("old, new, expected", [
    ('mate("post.foot"', 'mate("post.fot"', "part 'post' publishes no frame 'fot' (did you mean 'foot'?)"),
    ('"revolute"', '"revolut"', "unknown mate type 'revolut' (did you mean 'revolute'?)"),
    ('fit="clearance"', 'fit="clearence"', "fit 'clearence' is not a fit class (did you mean 'clearance'?)"),
    ('mate("arm.pivot", "post.head"', 'mate("arm.pivot", "pots.head"', "unknown part 'pots' (did you mean 'post'?)"),
])
def test_mistyped_frames_mate_types_fits_and_parts_get_a_did_you_mean(tmp_path, old, new, expected):
    """Issue 26.4, tried again from a fresh clone: a frame, mate type or fit typo had no hint."""
    assert old in LAMP
    res = runner.invoke(app, ["check", str(_write(tmp_path, LAMP.replace(old, new, 1)))])
    assert res.exit_code == 2 and expected in res.output, res.output
