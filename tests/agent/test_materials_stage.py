"""The materials stage end to end: a hand-written tape replayed through the real pipeline; the
library, the critic's correction and the refused sub-part rewrite are in report.json and
history, and the materials reach STEP colours, MTL, GLB and USD (each read back)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.agent.staged import StagedOptions, generate_staged

TAPES = Path(__file__).parents[1] / "tapes"
TAPE = TAPES / "lamp_materials.jsonl"
RED = (0.78, 0.08, 0.06)
BLACK = (0.04, 0.04, 0.045)
CHROME = (0.86, 0.87, 0.9)


def test_the_tape_is_labelled_hand_written():
    first = json.loads(TAPE.read_text().split("\n", 1)[0])
    assert "HAND-WRITTEN" in first["note"] and first["model"] == "hand-written"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("materials") / "lamp"
    lines: list[str] = []
    result = generate_staged(None, out, model=f"replay:{TAPE}", options=StagedOptions(simulate=False),
                             progress=lambda s, t: lines.append(f"{s}: {t}"))
    return result, out, json.loads((out / "report.json").read_text()), lines


def test_the_stage_builds_a_library_and_assigns_every_part(run):
    result, out, report, _ = run
    assert result.status == "ok", result.message
    mats = report["materials"]
    lib = mats["steps"][0]
    assert lib["step"] == "library" and lib["ok"] and lib["attempts"] == 2
    assert lib["parse_errors"] == ["assign one material to every part; missing: arm"]
    assert lib["assign"] == {"base": "base_lacquer", "post": "lamp_red", "arm": "lamp_red"}
    assert mats["assign"] == {"base": "base_lacquer", "post": "chrome", "arm": "lamp_red"}
    assert [e["name"] for e in mats["library"]] == ["lamp_red", "base_lacquer", "chrome"]
    assert report["gates"]["passed"]


def test_a_malformed_reply_is_retried_with_the_parse_error(run):
    _, out, _, _ = run
    calls = [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines()]
    retry = [c for c in calls if c["role"] == "materials"][1]
    assert any("missing: arm" in m["text"] for m in retry["request"]["messages"])


def test_the_critic_sees_a_pbr_render_with_the_legend_and_corrects_the_post(run):
    _, out, report, _ = run
    critic = report["materials"]["steps"][1]
    assert critic["step"] == "critic" and critic["ok"] and critic["changes"] == {"post": "chrome"}
    # the progress line counts what was applied: the reassignment and the new library entry
    line = next(x for x in run[3] if "critic:" in x)
    assert f"1 part(s) reassigned, {len(critic['library_changes'])} material(s) revised" in line
    assert critic["library_changes"] == ["chrome"]
    calls = [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines()]
    req = next(c for c in calls if c["role"] == "material_critic")["request"]
    text = req["messages"][0]["text"]
    assert "- post: lamp_red (metal, rgb [0.78, 0.08, 0.06]" in text
    assert [i["name"] for i in req["messages"][0]["images"]] == ["pbr_iso_se", "pbr_iso_nw"]


def test_a_subparts_rewrite_that_changes_the_triangle_count_is_refused(run):
    _, out, report, _ = run
    sub = report["materials"]["steps"][2]
    (row,) = sub["rewrites"]
    assert row["part"] == "arm" and not row["accepted"]
    assert row["triangles_after"] != row["triangles_before"]
    assert "paint never changes shape" in row["reason"] and sub["tolerance"] == 0.02
    program = (out / "program.py").read_text()
    assert "fillet(b.edges().filter_by(Axis.X)" not in program  # the rewrite is not in the program


def test_the_program_holds_the_materials_and_history_records_each_applied_step(run):
    _, out, _, _ = run
    program = (out / "program.py").read_text()
    assert 'material("chrome", base="stainless_steel", rgb=(0.86, 0.87, 0.9), roughness=0.08)' in program
    assert '@part(detail="major", material="chrome", description="vertical post' in program
    hist = sorted(p.name for p in (out / "history").iterdir())
    assert hist[-2:] == ["004-materials-library.py", "005-materials-critic.py"]
    assert (out / "history" / "005-materials-critic.py").read_text() == program
    assert json.loads((out / "state.json").read_text())["stage"] == "done"


def test_the_materials_reach_step_mtl_glb_and_usd(run):
    _, out, _, _ = run
    from procedura_brep.export.glb import srgb_to_linear
    from procedura_brep.export.step import read_step_parts
    step = {p.name: p.rgb for p in read_step_parts((out / "model.step").read_bytes())}
    for part, rgb in (("base", BLACK), ("post", CHROME), ("arm", RED)):
        assert np.allclose(step[part], rgb, atol=1 / 255), part
    mtl = (out / "model.mtl").read_text()
    assert "Kd 0.860000 0.870000 0.900000" in mtl.split("newmtl post_chrome\n")[1].split("\n\n")[0]
    from procedura_brep.testing.exports import glb_json
    tree = glb_json(out / "model.glb")
    pbr = {m["name"]: m["pbrMetallicRoughness"] for m in tree["materials"]}["arm_lamp_red"]
    assert pbr["baseColorFactor"] == pytest.approx([*srgb_to_linear(RED), 1.0], abs=1e-9)
    from pxr import Usd, UsdShade
    stage = Usd.Stage.Open(str(out / "model.usda"))
    root = stage.GetDefaultPrim().GetPath()
    sh = UsdShade.Shader(stage.GetPrimAtPath(f"{root}/Looks/chrome/PreviewSurface"))
    from procedura_brep.export.glb import srgb_to_linear  # UsdPreviewSurface colours are linear
    assert tuple(sh.GetInput("diffuseColor").Get()) == pytest.approx(tuple(srgb_to_linear(CHROME)), abs=1e-6)
    assert sh.GetInput("roughness").Get() == pytest.approx(0.08)


def test_the_gate_refuses_a_splice_that_changes_a_shape(run, monkeypatch):
    """Paint never changes shape: a splice that also moved a param is refused, and the
    bench keeps the program it had."""
    from procedura_brep.agent import materials as stage
    from procedura_brep.agent.tools import Tools
    _, out, _, _ = run

    class Host:
        tools, name, prompt, out_dir = Tools(), "model", "lamp", out

    bench = stage.MaterialsBench(Host(), (out / "program.py").read_text())
    real = stage.apply_materials
    monkeypatch.setattr(stage, "apply_materials",
                        lambda src, e, a: real(src, e, a).replace("base_t = 12.0", "base_t = 14.0"))
    before = bench.source
    ok, why = bench.apply(bench.entries, {"arm": "rubber"})
    assert not ok and why.startswith("the splice changed the shape of arm, base, post") and bench.source == before


def test_no_materials_switches_the_stage_off(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    import procedura_brep.agent.staged as staged
    from procedura_brep.cli import app
    seen = {}

    def fake(prompt, out, *, options, **kw):
        seen["options"] = options
        raise staged.StagedError("stopped by the test")

    monkeypatch.setattr(staged, "generate_staged", fake)
    runner = CliRunner()
    runner.invoke(app, ["generate", "x", "--model", f"replay:{TAPE}", "-o", str(tmp_path / "a"), "--no-materials"])
    assert seen["options"].materials is False
    runner.invoke(app, ["generate", "x", "--model", f"replay:{TAPE}", "-o", str(tmp_path / "b")])
    assert seen["options"].materials is True
