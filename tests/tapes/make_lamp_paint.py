"""Write tests/tapes/lamp_paint.jsonl: a HAND-WRITTEN staged-run tape (no model wrote it) that
exercises the sub-parts pass's colour blocks (``PAINT``).

Run ``python tests/tapes/make_lamp_paint.py`` after editing the replies below. The run: the lamp
of tests/program/lamp.py rebuilt part by part (plan, review, three builds, render, diagnose:
none, finish(ok)), then the materials stage: a library (red arm paint, black base lacquer, the
post in chrome) -> the material critic changes nothing -> a sub-parts reply with two PAINTs: the
arm's tip (x >= 70 of its 90 mm) in black rubber, accepted; a band on the post whose region lies
500 mm above the post (it misses the part), refused with the measured common volume.
"""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.testing.tapes import staged_tape, write_tape

HERE = Path(__file__).parent
LAMP = HERE.parent / "program" / "lamp.py"
PROMPT = "a desk lamp with a swinging arm: black base, red arm with a black rubber tip, chrome post"
NOTE = ("HAND-WRITTEN TAPE: written by a developer to exercise the staged pipeline and the "
        "sub-parts pass's colour blocks offline (from tests/program/lamp.py); no model produced "
        "these replies.")

LIBRARY = [
    {"name": "lamp_red", "base": "painted_aluminium", "rgb": [0.78, 0.08, 0.06], "roughness": 0.35},
    {"name": "base_lacquer", "rgb": [0.04, 0.04, 0.045], "roughness": 0.3, "metalness": 0.0,
     "density": 7200, "material_class": "metal"},
    {"name": "chrome", "base": "stainless_steel", "rgb": [0.86, 0.87, 0.9], "roughness": 0.08},
]
FIRST = {"summary": "black lacquered base, red arm, chrome post", "library": LIBRARY,
         "assign": {"base": "base_lacquer", "post": "chrome", "arm": "lamp_red"}}
CRITIC = {"summary": "the assignment matches the reference", "library": [], "assign": {}}

SUBPARTS = "\n".join([
    "The arm ends in a black rubber tip; the post has a dark band.",
    "PAINT arm",
    "```python",
    '@paint("arm", material="rubber", description="black rubber tip, the last 20 mm of the arm")',
    "def arm_tip():",
    "    return Pos(70, 0, 0) * Box(40, 30, 30, align=(Align.MIN, Align.CENTER, Align.CENTER))",
    "```",
    "PAINT post",
    "```python",
    '@paint("post", material="base_lacquer")',
    "def post_band():",
    "    return Pos(0, 0, 500) * Box(30, 30, 10)",
    "```",
])


def fenced(obj) -> str:
    return "```json\n" + json.dumps(obj, indent=1) + "\n```"


def main() -> None:
    rows = staged_tape(LAMP.read_text(), PROMPT, origin="tests/program/lamp.py")
    rows[0]["note"] = NOTE
    calls = [("materials", fenced(FIRST)), ("material_critic", fenced(CRITIC)), ("subparts", SUBPARTS)]
    step = rows[-1]["step"]
    for k, (role, text) in enumerate(calls, start=1):
        rows.append({"v": 1, "role": role, "step": step + k, "model": "hand-written", "request": {},
                     "reply": {"text": text, "usage": {}}})
    out = HERE / "lamp_paint.jsonl"
    write_tape(out, rows)
    print(f"wrote {out} ({len(rows)} calls)")


if __name__ == "__main__":
    main()
