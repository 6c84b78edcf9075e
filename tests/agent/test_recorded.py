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


def _ships(tape: Path, out: Path, parts: int) -> dict:
    """Replay a recorded tape (labelled so) through the pipeline; the report of a run that
    shipped ``parts`` parts with every gate, the battery and the refine passing."""
    first = json.loads(tape.read_text().split("\n", 1)[0])
    assert "recorded through exchange, model played by an external coding agent" in first["note"].lower()
    result = generate_staged(None, out, model=f"replay:{tape}")  # the tape must be fully consumed
    assert result.status == "ok", result.message
    report = json.loads((out / "report.json").read_text())
    assert len(report["committed"]) == parts and not report["skipped"]
    assert report["gates"]["passed"] and report["battery"]["passed"]
    assert report["refine"]["verdict"] == "ok"
    return report


def test_the_recorded_drill_press_replays_and_ships(tmp_path):
    report = _ships(TAPE, tmp_path / "drill_press", 31)
    assert report["usage"]["total"]["calls"] == 40


def test_the_recorded_robot_arm_replays_through_every_stage_and_ships(tmp_path):
    roles = {json.loads(line)["role"] for line in ARM.read_text().splitlines()}
    assert roles == {"plan", "review", "build", "fixer", "critic", "materials", "material_critic",
                     "subparts", "articulation"}
    out = tmp_path / "robot_arm"
    report = _ships(ARM, out, 28)
    assert [s["step"] for s in report["materials"]["steps"]] == ["library", "critic", "subparts"]
    assert len(report["articulation"]["edits"]) == 6
    assert len(report["battery"]["checks"][2]["measured"]["joints"]) == 6
    assert report["usage"]["total"]["calls"] == 38
    # the run's own materials reach the exports: more than one colour in the GLB
    from pygltflib import GLTF2
    colours = {tuple(m.pbrMetallicRoughness.baseColorFactor) for m in GLTF2().load(str(out / "model.glb")).materials}
    assert len(colours) >= 3
