"""The recorded drill press run (the README's first command) still replays through today's
pipeline and ships: every part committed, every gate and the MuJoCo battery passing."""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.agent.staged import generate_staged

TAPE = Path(__file__).parents[2] / "examples" / "tapes" / "drill_press_staged.jsonl"


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
