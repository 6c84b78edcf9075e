"""`generate` (staged by default) and `revise` through the CLI, on hand-written tapes."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app

TAPES = Path(__file__).parents[1] / "tapes"
runner = CliRunner()


def invoke(*args: str, env: dict | None = None):
    res = runner.invoke(app, list(args), env=env)
    assert "Traceback" not in res.output
    return res


def test_generate_replays_a_staged_tape_with_its_own_prompt_and_prints_json(tmp_path):
    out = tmp_path / "lamp"
    res = invoke("generate", "--model", f"replay:{TAPES / 'lamp_staged.jsonl'}", "-o", str(out),
                 "--no-simulate", "--json", "-q")
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    assert report["mode"] == "staged" and report["prompt"] == "a desk lamp with a swinging arm"
    assert [c["name"] for c in report["committed"]] == ["base", "post", "arm"]


def test_generate_without_a_model_or_output_is_a_usage_error(tmp_path):
    env = {"PROCEDURA_BREP_MODEL": "", "PROCEDURA_BREP_CONFIG": str(tmp_path / "none.toml")}
    res = invoke("generate", "a lamp", "-o", str(tmp_path / "x"), env=env)
    assert res.exit_code == 2 and "no model" in res.output and "PROCEDURA_BREP_MODEL" in res.output
    res = invoke("generate", "a lamp", "--model", "scripted:x", env=env)
    assert res.exit_code == 2 and "-o DIR" in res.output
    res = invoke("generate", "--resume", str(tmp_path), "--model", f"replay:{TAPES / 'lamp_staged.jsonl'}")
    assert res.exit_code == 2 and "no state.json" in res.output


def test_the_model_comes_from_the_environment(tmp_path):
    out = tmp_path / "lamp"
    env = {"PROCEDURA_BREP_MODEL": f"replay:{TAPES / 'lamp_staged.jsonl'}"}
    res = invoke("generate", "-o", str(out), "--no-simulate", env=env)
    assert res.exit_code == 0, res.output
    # the last line: calls, wall time, status, the run dir, its main files and its sheet (26.3)
    assert re.search(r"generated and built in \d+ call\(s\), \d+ s[^:]*: status ok -> \S+ "
                     r"\(program\.py, report\.json, model\.step, model\.glb.*\); sheet \S+sheet\.png$",
                     res.stdout.strip()), res.output
    # no silent gap: the final build reports its own stages (issue 26.4: the run's last 17 s
    # printed nothing before)
    stages = [re.sub(r"^\s*[\d.]+ s  ", "", ln) for ln in res.stderr.splitlines()]
    final = stages[stages.index("finish: building the run directory (exports, gates)"):]
    assert [s for s in final if s.startswith("finish: ")][1:4] == [
        f"finish: compiling {out.name}", "finish: running the gates",
        "finish: writing 3 parts as " + ", ".join(__import__("procedura_brep.export.bundle",
                                                              fromlist=["FORMATS"]).FORMATS)], final
    assert "finish: drawing sheet.png" in final, final


def test_revise_through_the_cli(tmp_path):
    out = tmp_path / "lamp"
    assert invoke("build", str(Path(__file__).parents[1] / "program" / "lamp.py"), "-o", str(out), "-q").exit_code == 0
    res = invoke("revise", str(out), "make the arm 120 mm long", "--part", "arm", "--no-simulate",
                 "--model", f"replay:{TAPES / 'lamp_revise.jsonl'}", "-q")
    assert res.exit_code == 0, res.output
    assert "revised" in res.output and "arm_l = 120.0" in (out / "program.py").read_text()
    res = invoke("revise", str(out), "bigger", "--part", "wheel", "--model", "scripted:x")
    assert res.exit_code == 2 and "not a part" in res.output


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_doctor_says_which_model_setting_is_in_force(tmp_path):
    cfg = tmp_path / "config.toml"
    cfg.write_text('model = "openai:llama3"\nbase_url = "http://127.0.0.1:9/v1"\n')
    res = invoke("doctor", env={"PROCEDURA_BREP_MODEL": "", "PROCEDURA_BREP_CONFIG": str(cfg)})
    assert f"model in force: openai:llama3 (from {cfg})" in res.output
    res = invoke("doctor", env={"PROCEDURA_BREP_MODEL": "replay:x.jsonl", "PROCEDURA_BREP_CONFIG": str(cfg)})
    assert "model in force: replay:x.jsonl (from PROCEDURA_BREP_MODEL)" in res.output
