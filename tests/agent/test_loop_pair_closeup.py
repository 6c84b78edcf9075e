"""Issue 23.4: a finding between two parts reaches the fixer and the critic with a close-up of
the pair (the two in colour, the rest ghosted), not only the build retries."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

from procedura_brep.agent.refine import refine
from procedura_brep.agent.tools import Tools

PROGRAM = '''"""Two blocks, the upper one sunk into the lower. Hand-written test program."""
from procedura_brep.program import *

# === params ===
base_t = 10.0  # mm
seat_d = 20.0  # mm, the block's seat: the nominal of its mate

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="a base plate")
def base():
    return Box(80, 60, base_t, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="a block on the base, sunk 3 mm")
def block():
    return Box(30, 30, 20, align=(Align.CENTER, Align.CENTER, Align.MIN)).moved(Location((0, 0, -3)))

@part(detail="sub", material="steel", description="a knob on the base's corner")
def knob():
    return Cylinder(5, 8, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("base", top=Location((0, 0, 0)), corner=Location((30, 20, 0)))
frames("block", foot=Location((0, 0, 0)))
frames("knob", foot=Location((0, 0, 0)))

# === assembly ===
mate("block.foot", "base.top", "seat_face", nominal="seat_d", features=False)
mate("knob.foot", "base.corner", "seat_face", nominal="seat_d", features=False)
'''

CRITIC = "SUMMARY: the block is sunk into the base.\nISSUES:\n- [HIGH] block+base: lift the block 3 mm."


def test_a_pair_finding_comes_to_the_fixer_and_the_critic_with_its_close_up(tmp_path, worker):
    replies = iter([json.dumps({"action": "compile"}),
                    json.dumps({"action": "render", "views": ["iso_se"]}),
                    json.dumps({"action": "diagnose"}), CRITIC,
                    json.dumps({"action": "finish", "verdict": "give_up", "reason": "test"})])
    sent: list[tuple[str, list]] = []

    def call(role, system, messages, max_tokens=0):
        sent.append((role, list(messages)))
        return next(replies)

    host = SimpleNamespace(tools=Tools(), name="blocks", prompt="two blocks", out_dir=Path(tmp_path),
                           call=call, refs=lambda: [], progress=lambda stage, text: None)
    refine(host, PROGRAM, intro="Refine it.", max_edits=2, max_actions=6)
    compiled = sent[1][1][-1]  # the fixer's second call: the compile observation last
    assert "compiled with findings" in compiled.text and "Close-up of block and base" in compiled.text
    assert [img.name for img in compiled.images] == ["iso_se", "iso_nw"]
    critic = next(msgs for role, msgs in sent if role == "critic")[0]
    assert "Close-up of block and base" in critic.text
    assert [img.name for img in critic.images] == ["iso_se", "iso_se", "iso_nw"]  # its views, then the pair's
