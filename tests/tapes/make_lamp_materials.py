"""Write tests/tapes/lamp_materials.jsonl: a HAND-WRITTEN staged-run tape (no model wrote it)
that exercises the materials stage.

Run ``python tests/tapes/make_lamp_materials.py`` after editing the replies below. The run: the
lamp of tests/program/lamp.py rebuilt part by part (plan, review, three builds, render,
diagnose: none, finish(ok)), then the materials stage: a library reply that forgets the arm
(refused by the parser; the retry is told which part is missing) -> a library of two entries
(red arm paint, black base lacquer) with one material per part, the post wrongly in the red
paint -> the material critic moves the post to a new polished chrome entry -> a sub-parts
rewrite of the arm that rounds its edges (its triangle count changes: refused, so paint never
changes shape).
"""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.testing.tapes import staged_tape, write_tape

HERE = Path(__file__).parent
LAMP = HERE.parent / "program" / "lamp.py"
PROMPT = "a desk lamp with a swinging arm: black base, red arm, chrome post"
NOTE = ("HAND-WRITTEN TAPE: written by a developer to exercise the staged pipeline and its "
        "materials stage offline (from tests/program/lamp.py); no model produced these replies.")

LIBRARY = [
    {"name": "lamp_red", "base": "painted_aluminium", "rgb": [0.78, 0.08, 0.06], "roughness": 0.35,
     "wear": 0.1},
    {"name": "base_lacquer", "rgb": [0.04, 0.04, 0.045], "roughness": 0.3, "metalness": 0.0,
     "density": 7200, "material_class": "metal", "wear": 0.05},
]
FORGETS_ARM = {"summary": "red and black", "library": LIBRARY,
               "assign": {"base": "base_lacquer", "post": "lamp_red"}}
FIRST = {"summary": "black lacquered base, red arm and post",
         "library": LIBRARY, "assign": {"base": "base_lacquer", "post": "lamp_red", "arm": "lamp_red"}}
CRITIC = {"summary": "the post should be polished chrome, not red paint",
          "library": [{"name": "chrome", "base": "stainless_steel", "rgb": [0.86, 0.87, 0.9],
                       "roughness": 0.08}],
          "assign": {"post": "chrome"}}


def fenced(obj) -> str:
    return "```json\n" + json.dumps(obj, indent=1) + "\n```"


def rounded_arm() -> str:
    """The arm's five blocks with its long edges rounded (a shape change, not paint)."""
    return "\n".join([
        "## params", "```python", "none", "```",
        "## helpers", "```python", "none", "```",
        "## body", "```python",
        '@part(detail="major", material="lamp_red", description="arm swinging about a pin at the post top")',
        "def arm():",
        "    b = Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))",
        "    return fillet(b.edges().filter_by(Axis.X), radius=3)",
        "```",
        "## frames", "```python", 'frames("arm", pivot=Location((7, -7, 0), (-90, 0, 0)))', "```",
        "## mates", "```python",
        'mate("arm.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-45, 45))',
        "```"])


def main() -> None:
    rows = staged_tape(LAMP.read_text(), PROMPT, origin="tests/program/lamp.py")
    rows[0]["note"] = NOTE
    calls = [("materials", "Here are the materials.\n" + fenced(FORGETS_ARM)),
             ("materials", fenced(FIRST)),
             ("material_critic", fenced(CRITIC)),
             ("subparts", "The arm is one colour block per long edge:\nREWRITE arm\n" + rounded_arm())]
    step = rows[-1]["step"]
    for k, (role, text) in enumerate(calls, start=1):
        rows.append({"v": 1, "role": role, "step": step + k, "model": "hand-written", "request": {},
                     "reply": {"text": text, "usage": {}}})
    out = HERE / "lamp_materials.jsonl"
    write_tape(out, rows)
    print(f"wrote {out} ({len(rows)} calls)")


if __name__ == "__main__":
    main()
