"""Material declarations in a program, through the CLI: ``check`` and ``build`` agree on an
unknown material (it names the part and lists the library, declared ones included) and on a
declaration out of range (it names the line, the value and the range)."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from procedura_brep.cli import app

LAMP = (Path(__file__).parent / "lamp.py").read_text()
DECL = 'material("lamp_red", base="painted_aluminium", rgb=(0.8, 0.1, 0.1), roughness=0.4)\n\n'
runner = CliRunner()


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "prog.py"
    p.write_text(text)
    return p


def _with_decl(arm_material: str, decl: str = DECL) -> str:
    return (LAMP.replace("# === parts ===\n", "# === parts ===\n" + decl)
            .replace('material="painted_aluminium"', f'material="{arm_material}"'))


def _check_and_build(tmp_path: Path, source: str) -> tuple[object, object, dict]:
    prog = _write(tmp_path, source)
    checked = runner.invoke(app, ["check", str(prog), "--json"])
    out = tmp_path / "out"
    built = runner.invoke(app, ["build", str(prog), "-o", str(out), "--formats", "step"])
    return checked, built, json.loads((out / "report.json").read_text())


def test_a_declared_material_builds(tmp_path):
    checked, built, report = _check_and_build(tmp_path, _with_decl("lamp_red"))
    assert checked.exit_code == 0, checked.output
    assert built.exit_code == 0, built.output
    assert {p["name"]: p["material"] for p in report["parts"]}["arm"] == "lamp_red"


def test_a_misspelt_declared_material_fails_check_and_build_alike(tmp_path):
    checked, built, report = _check_and_build(tmp_path, _with_decl("lamp_rd"))
    assert checked.exit_code == built.exit_code == 2, (checked.output, built.output)
    for text in (checked.output, built.output):
        assert "part arm: unknown material 'lamp_rd' (did you mean 'lamp_red'?); use one of: steel" in text
        assert "lamp_red (or declare it with material(...))" in text
    assert "internal error" not in built.output
    f = report["findings"][0]
    assert f["code"] == "material" and f["part"] == "arm" and "lamp_red" in f["message"]


def test_a_declaration_out_of_range_names_line_value_and_range(tmp_path):
    bad = DECL.replace("roughness=0.4", "roughness=1.5")
    checked, built, report = _check_and_build(tmp_path, _with_decl("lamp_red", bad))
    assert checked.exit_code == built.exit_code == 2, (checked.output, built.output)
    line = LAMP.split("\n").index("# === parts ===") + 2
    msg = f"line {line}: material 'lamp_red': roughness = 1.5 is outside the allowed range [0, 1]"
    assert msg in checked.output and msg in built.output
    assert report["findings"][0]["line"] == line
