"""Write tests/tapes/box_staged.jsonl: a HAND-WRITTEN staged-run tape (no model wrote it).

The object is tests/tapes/box_program.py (a box with a hinged lid and a knob). The run: plan
(3 parts) -> review drops the knob (restored by the one-direction rule) -> case -> lid -> knob
floats 30 mm above its own peg (caught: detached piece and floater) -> knob fixed -> refine:
render, diagnose (critic: HIGH on the knob), an edit that does not parse (refused; the diagnosis
stands), the corrected edit (applied), a second edit without a new diagnosis (refused),
render and diagnose again (the HIGH issue stays), finish(ok) with it open (refused), give_up
(never gated).
"""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.testing.tapes import part_replies, plan_from_program

HERE = Path(__file__).parent
PROMPT = "a small box with a hinged lid and a knob"
NOTE = ("HAND-WRITTEN TAPE: written by a developer to exercise the staged pipeline offline; "
        "no model produced these replies.")


def fenced(obj) -> str:
    return "```json\n" + json.dumps(obj, indent=1) + "\n```"


def main() -> None:
    source = (HERE / "box_program.py").read_text()
    plan = plan_from_program(source)
    review = {"parts": [p for p in plan["parts"] if p["name"] != "knob"]}
    case, lid, knob = part_replies(source)
    floating = knob.replace("return Cylinder(8, 10,", "return Pos(0, 0, 30) * Cylinder(8, 10,")
    assert floating != knob
    broken = knob.replace("def knob():", "def knob(:")
    calls = [
        ("plan", fenced(plan)),
        ("review", "I removed the knob, it is a detail.\n" + fenced(review)),
        ("build", case), ("build", lid), ("build", floating), ("build", knob),
        ("fixer", json.dumps({"action": "render", "views": ["iso_se", "front"]})),
        ("fixer", json.dumps({"action": "diagnose"})),
        ("critic", "SUMMARY: box, lid and knob are there; the knob is small.\nISSUES:\n"
                   "- [HIGH] knob: 16 mm is too small to grip; make it 24 mm across."),
        ("fixer", json.dumps({"action": "edit_part", "part": "knob", "reply": broken})),
        ("fixer", json.dumps({"action": "edit_part", "part": "knob", "reply": knob})),
        ("fixer", json.dumps({"action": "edit_part", "part": "knob", "reply": knob})),
        ("fixer", json.dumps({"action": "render", "views": ["iso_se", "front"]})),
        ("fixer", json.dumps({"action": "diagnose"})),
        ("critic", "SUMMARY: box, lid and knob are there; the knob is still small.\nISSUES:\n"
                   "- [HIGH] knob: 16 mm is too small to grip; make it 24 mm across."),
        ("fixer", json.dumps({"action": "finish", "verdict": "ok"})),
        ("fixer", json.dumps({"action": "finish", "verdict": "give_up",
                              "reason": "the knob size is a matter of taste"})),
    ]
    rows = []
    for step, (role, text) in enumerate(calls):
        row = {"v": 1, "role": role, "step": step, "model": "hand-written"}
        if step == 0:
            row.update({"note": NOTE, "prompt": PROMPT})
        row.update({"request": {}, "reply": {"text": text, "usage": {}}})
        rows.append(json.dumps(row, ensure_ascii=False))
    out = HERE / "box_staged.jsonl"
    out.write_text("\n".join(rows) + "\n", encoding="utf-8")
    print(f"wrote {out} ({len(rows)} calls)")


if __name__ == "__main__":
    main()
