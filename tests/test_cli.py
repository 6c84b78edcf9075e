"""The CLI: build and edit end to end on the lamp program (CliRunner, sandboxed compiles)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app

LAMP = Path(__file__).parent / "program" / "lamp.py"
runner = CliRunner()


def invoke(*args: str):
    res = runner.invoke(app, list(args))
    assert "Traceback" not in res.output
    return res


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    out = tmp_path_factory.mktemp("lamp")
    res = invoke("build", str(LAMP), "-o", str(out), "--formats", "step")
    assert res.exit_code == 0, res.output
    return out


def test_build_writes_the_run_directory(built):
    for name in ("program.py", "model.step", "mates.json", "report.json"):
        assert (built / name).stat().st_size > 0
    assert (built / "program.py").read_text() == LAMP.read_text()


def test_mates_json_has_every_field(built):
    mates = json.loads((built / "mates.json").read_text())["mates"]
    by = {m["name"]: m for m in mates}
    peg, hinge = by["post_foot"], by["arm_pivot"]
    assert peg["type"] == "peg_socket" and peg["child"] == {"part": "post", "frame": "foot"}
    assert peg["parent"] == {"part": "base", "frame": "top"}
    assert peg["nominal"] == {"name": "spigot_d", "value_mm": 12.0}
    assert peg["fit"]["iso"] == "H7/k6" and peg["resolved_offset_mm"] == pytest.approx(peg["fit"]["offset"])
    assert peg["dof"]["count"] == 0 and peg["world_frame"]["origin_mm"] == pytest.approx([0, 0, 12])
    assert hinge["dof"] == {"count": 1, "translation": [], "rotation": ["z"]}
    assert hinge["limits"] == [-45, 45] and hinge["fit"]["iso"] == "H7/g6"


def test_report_json_per_part_and_mate(built):
    rep = json.loads((built / "report.json").read_text())
    assert rep["status"] == "ok"
    parts = {p["name"]: p for p in rep["parts"]}
    assert set(parts) == {"base", "post", "arm"}
    assert parts["base"]["material"] == "cast_iron" and parts["base"]["volume_mm3"] > 1e5
    assert parts["base"]["bbox_mm"] == [pytest.approx([-60, -60, 0]), pytest.approx([60, 60, 12])]
    assert all(m["residual_mm"] == 0.0 for m in rep["mates"])
    assert rep["timings"]["compile_s"] > 0 and rep["gates"]["passed"] is True


def test_build_missing_file_is_one_line(tmp_path):
    res = invoke("build", str(tmp_path / "nope.py"), "-o", str(tmp_path / "o"))
    assert res.exit_code == 2 and res.output.count("\n") == 1 and "does not exist" in res.output


def test_build_failing_part_reports_and_writes_report(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text(LAMP.read_text().replace("return Box(90, 14, 10", "return Box(90, 14, -10"))
    res = invoke("build", str(bad), "-o", str(tmp_path / "o"), "--formats", "step")
    assert res.exit_code != 0 and "part arm" in res.output and res.output.count("\n") == 1
    rep = json.loads((tmp_path / "o" / "report.json").read_text())
    assert rep["status"] == "failed" and rep["findings"][0]["part"] == "arm"


def test_edit_to_new_file_changes_only_the_param_line(tmp_path):
    new = tmp_path / "lamp2.py"
    res = invoke("edit", str(LAMP), "--set", "post_h=95", "-o", str(new), "--no-check")
    assert res.exit_code == 0, res.output
    a, b = LAMP.read_text().splitlines(), new.read_text().splitlines()
    assert [i for i, (x, y) in enumerate(zip(a, b)) if x != y] == [a.index(next(l for l in a if l.startswith("post_h")))]
    assert "post_h = 95.0   # mm" in new.read_text()


def test_edit_unknown_param_lists_params(tmp_path):
    res = invoke("edit", str(LAMP), "--set", "wheel_d=3", "-o", str(tmp_path / "x.py"))
    assert res.exit_code == 2 and "params: base_w, base_t" in res.output


def test_edit_that_breaks_a_mate_is_rejected(tmp_path):
    prog = tmp_path / "lamp.py"
    shutil.copy(LAMP, prog)
    res = invoke("edit", str(prog), "--set", "pin_d=900")
    assert res.exit_code == 1 and "rejected" in res.output and "arm_pivot" in res.output
    assert prog.read_text() == LAMP.read_text()


def test_edit_in_place_with_build(tmp_path):
    prog = tmp_path / "lamp.py"
    shutil.copy(LAMP, prog)
    res = invoke("edit", str(prog), "--set", "post_h=100", "--build", str(tmp_path / "b"))
    assert res.exit_code == 0, res.output
    rep = json.loads((tmp_path / "b" / "report.json").read_text())
    post = next(p for p in rep["parts"] if p["name"] == "post")
    assert post["bbox_mm"][1][2] == pytest.approx(12 + 100, abs=1e-3)
    assert "post_h = 100.0" in prog.read_text()


def test_check_json_and_exit_codes(tmp_path):
    res = invoke("check", str(LAMP), "--json")
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert data["passed"] and data["n_vis"] == 0
    peg = data["mates"]["post_foot"]
    assert peg["area_mm2"] >= peg["area_limit_mm2"] and peg["penetration_mm"] <= peg["penetration_limit_mm"]
    # lift the post 0.5 mm off its seat: the mate gate fails on area -> exit 1
    lifted = tmp_path / "lifted.py"
    lifted.write_text(LAMP.read_text().replace('foot=Location((0, 0, 0))', 'foot=Location((0, 0, -0.5))'))
    res = invoke("check", str(lifted))
    assert res.exit_code == 1 and "FAIL" in res.output
    res = invoke("check", str(tmp_path / "missing.py"))
    assert res.exit_code == 2


def test_render_cli(tmp_path):
    res = invoke("render", str(LAMP), "-o", str(tmp_path / "r"), "--views", "iso_ne,front",
                 "--size", "128", "--sheet", "--mode", "clay")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "r" / "clay_iso_ne.png").exists() and (tmp_path / "r" / "clay_sheet.png").exists()
    res = invoke("render", str(LAMP), "-o", str(tmp_path / "r"), "--views", "sideways")
    assert res.exit_code == 2 and "sideways" in res.output


def test_doctor_reports_every_component():
    res = invoke("doctor")
    names = ("CAD kernel", "MuJoCo", "OpenUSD", "render backend", "FreeCAD", "model")
    for name in names:
        assert name in res.output, res.output
    assert res.exit_code == (1 if "MISSING" in res.output else 0)
    res = invoke("doctor", "--model", "nonsense:model")
    assert "nonsense" in res.output and res.exit_code == 1


def test_export_ap242(tmp_path):
    res = invoke("export", str(LAMP), "-o", str(tmp_path), "--formats", "step", "--step-schema", "AP242")
    assert res.exit_code == 0, res.output
    assert "AP242_MANAGED_MODEL_BASED_3D_ENGINEERING" in (tmp_path / "model.step").read_text()
