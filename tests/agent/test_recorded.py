"""The recorded staged runs still replay through today's pipeline and ship: every part
committed, every gate and the MuJoCo battery passing. The robot arm (the README's first command)
goes through every stage, materials and articulation included; the drill press predates them."""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.agent.staged import generate_staged

TAPES = Path(__file__).parents[2] / "examples" / "tapes"
TAPE = TAPES / "drill_press_staged.jsonl"
ARM = TAPES / "robot_arm_staged.jsonl"


def test_the_recorded_drill_press_replays_and_ships(tmp_path):
    first = json.loads(TAPE.read_text().split("\n", 1)[0])
    assert "recorded through exchange, model played by an external coding agent" in first["note"].lower()
    out = tmp_path / "drill_press"
    result = generate_staged(None, out, model=f"replay:{TAPE}")  # the tape must be fully consumed
    assert result.status == "ok", result.message
    report = json.loads((out / "report.json").read_text())
    assert len(report["committed"]) == 31 and not report["skipped"]
    assert report["gates"]["passed"] and report["battery"]["passed"]
    assert report["refine"]["verdict"] == "ok"
    assert report["usage"]["total"]["calls"] == 40


def test_the_recorded_robot_arm_replays_through_every_stage_and_ships(tmp_path):
    first = json.loads(ARM.read_text().split("\n", 1)[0])
    assert "recorded through exchange, model played by an external coding agent" in first["note"].lower()
    roles = {json.loads(line)["role"] for line in ARM.read_text().splitlines()}
    assert roles == {"plan", "review", "build", "fixer", "critic", "materials", "material_critic",
                     "subparts", "articulation"}
    out = tmp_path / "robot_arm"
    result = generate_staged(None, out, model=f"replay:{ARM}")  # the tape must be fully consumed
    assert result.status == "ok", result.message
    report = json.loads((out / "report.json").read_text())
    assert len(report["committed"]) == 28 and not report["skipped"]
    assert report["gates"]["passed"] and report["battery"]["passed"]
    assert report["refine"]["verdict"] == "ok"
    assert [s["step"] for s in report["materials"]["steps"]] == ["library", "critic", "subparts"]
    assert len(report["articulation"]["edits"]) == 6
    assert len(report["battery"]["checks"][2]["measured"]["joints"]) == 6
    assert report["usage"]["total"]["calls"] == 38
    # the run's own materials reach the exports: more than one colour in the GLB
    from pygltflib import GLTF2
    colours = {tuple(m.pbrMetallicRoughness.baseColorFactor) for m in GLTF2().load(str(out / "model.glb")).materials}
    assert len(colours) >= 3
