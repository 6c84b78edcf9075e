"""Write tests/tapes/lamp_articulation.jsonl: a HAND-WRITTEN tape (no model wrote it) for the
articulation stage with a battery failure and its fix.

Run ``python tests/tapes/make_lamp_articulation.py`` after editing the replies below. The run it
drives: the test lamp (tests/program/lamp.py) is planned, reviewed and built part by part, the
refine renders, diagnoses (no issue) and finishes; then the articulation call answers a
malformed plan (retried with its problems), then a plan that widens the arm's limits to
(-80, 80) deg and says the base is free (logged: no wheels, it stays welded). The arm then drives
into the base in the B2 sweep; the battery fixer sees the failing check and its frames and sets
the limits back to (-45, 45); the final build's battery passes.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "src"))

from procedura_brep.testing.tapes import staged_tape, write_tape  # noqa: E402 - after the sys.path line above

PROMPT = "a desk lamp with a swinging arm"
LAMP = ROOT / "tests" / "program" / "lamp.py"
NOTE = ("HAND-WRITTEN TAPE: written by a developer to exercise the articulation stage and its "
        "battery fix offline; no model produced these replies.")

BAD_PLAN = {"joints": [{"mate": "arm_hinge", "limits": [-80, 80]}], "base": "floating"}
PLAN = {"links": [["base", "post"], ["arm"]],
        "joints": [{"mate": "arm_pivot", "limits": [-80, 80], "effort": 10, "velocity": 3,
                    "drive": "position"}],
        "promote": [], "base": "free", "wheels": []}
FIX = {"action": "set_mate", "mate": "arm_pivot", "limits": [-45, 45]}


def fenced(obj: dict) -> str:
    return "```json\n" + json.dumps(obj, indent=1) + "\n```"


def rows() -> list[dict]:
    out = staged_tape(LAMP.read_text(), PROMPT, origin="tests/program/lamp.py")
    out[0]["note"] = NOTE
    extra = [("articulation", "Here is the articulation.\n" + fenced(BAD_PLAN)),
             ("articulation", fenced(PLAN)),
             ("battery_fixer", "The arm swings into the base below -45 deg.\n" + fenced(FIX))]
    for role, text in extra:
        out.append({"v": 1, "role": role, "step": len(out), "model": "hand-written", "request": {},
                    "reply": {"text": text, "usage": {}}})
    return out


def main() -> None:
    path = Path(__file__).with_name("lamp_articulation.jsonl")
    data = rows()
    write_tape(path, data)
    print(f"wrote {path} ({len(data)} calls)")


if __name__ == "__main__":
    main()
