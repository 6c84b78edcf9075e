"""Write tests/tapes/lamp_revise.jsonl: a HAND-WRITTEN tape for `revise` (no model wrote it).

The change request "make the arm 120 mm long" with --part arm, on a build of
tests/program/lamp.py: render, diagnose (critic: HIGH on the arm), an edit of the post (refused:
not the named part), diagnose again, one gated edit of the arm, render, diagnose (none), finish.
"""

from __future__ import annotations

import json
from pathlib import Path

NOTE = ("HAND-WRITTEN TAPE: written by a developer to exercise `revise` offline; "
        "no model produced these replies.")

ARM = """## params
```python
pin_d = 8.0     # mm, hinge pin: the nominal of the arm's revolute mate
arm_l = 120.0   # mm, arm length
```
## helpers
none
## body
```python
@part(detail="major", material="painted_aluminium", description="arm swinging about a pin at the post top")
def arm():
    return Box(arm_l, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))
```
## frames
```python
frames("arm", pivot=Location((7, -7, 0), (-90, 0, 0)))
```
## mates
```python
mate("arm.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-45, 45))
```"""
POST = ARM.replace("def arm", "def post").replace('frames("arm"', 'frames("post"')
HIGH = ("SUMMARY: the arm is still 90 mm long.\nISSUES:\n"
        "- [HIGH] arm: the request asks for a 120 mm arm; lengthen it to 120 mm.")


def action(**kw) -> str:
    return json.dumps(kw)


CALLS = [
    ("revise", action(action="render", views=["iso_se", "top"])),
    ("revise", action(action="diagnose")),
    ("revise_critic", HIGH),
    ("revise", action(action="edit_part", part="post", reply=POST)),
    ("revise", action(action="diagnose")),
    ("revise_critic", HIGH),
    ("revise", action(action="edit_part", part="arm", reply=ARM)),
    ("revise", action(action="render", views=["iso_se", "top"])),
    ("revise", action(action="diagnose")),
    ("revise_critic", "SUMMARY: the arm is 120 mm long now.\nISSUES: none"),
    ("revise", action(action="finish", verdict="ok")),
]


def main() -> None:
    out = Path(__file__).with_name("lamp_revise.jsonl")
    rows = []
    for step, (role, text) in enumerate(CALLS):
        row = {"v": 1, "role": role, "step": step, "model": "hand-written"}
        if step == 0:
            row["note"] = NOTE
        row.update({"request": {}, "reply": {"text": text, "usage": {}}})
        rows.append(json.dumps(row, ensure_ascii=False))
    out.write_text("\n".join(rows) + "\n", encoding="utf-8")
    print(f"wrote {out} ({len(rows)} calls)")


if __name__ == "__main__":
    main()
