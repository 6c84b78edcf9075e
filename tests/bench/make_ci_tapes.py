"""Write tests/bench/tapes/: HAND-WRITTEN replay tapes for the CI bench (no model wrote them).

Three cases x two variants (full, one-shot) plus a judge tape:

* lamp (tests/program/lamp.py) and plinth (tests/bench/plinth_program.py): the staged tape
  generated from the program (plan, review, one build per part, render, diagnose, finish) and a
  one-shot tape that answers with the whole program;
* box (tests/tapes/box_program.py): the staged tape, and a one-shot tape whose three replies
  hold no program, so that run ships nothing (it scores 0 and stays in the mean);
* judge.jsonl: one hand-written score reply per shipped model (5), in item-id order.

Run: python tests/bench/make_ci_tapes.py
"""

from __future__ import annotations

import json
from pathlib import Path

from procedura_brep.testing.tapes import HAND_WRITTEN, staged_tape, write_tape

HERE = Path(__file__).parent
ROOT = HERE.parent.parent
PROGRAMS = {"lamp": ROOT / "tests/program/lamp.py", "plinth": HERE / "plinth_program.py",
            "box": ROOT / "tests/tapes/box_program.py"}
PROMPTS = {"lamp": "a desk lamp with a swinging arm",
           "plinth": "a column on a square plinth with a round cap",
           "box": "a small box with a hinged lid and a knob"}
JUDGE = [(7, 6, 8), (5, 5, 7), (8, 7, 9), (4, 6, 5), (6, 8, 7)]
"""Hand-written raw scores (geometry, aesthetics, semantic) for judge steps 0-4."""


def _row(role: str, step: int, text: str, note: str | None = None, prompt: str | None = None) -> dict:
    row: dict = {"v": 1, "role": role, "step": step, "model": "hand-written"}
    if note:
        row["note"] = note
    if prompt:
        row["prompt"] = prompt
    row.update({"request": {}, "reply": {"text": text, "usage": {"input_tokens": 100 * (step + 1),
                                                                  "output_tokens": 40}}})
    return row


def main() -> None:
    out = HERE / "tapes"
    for case, path in PROGRAMS.items():
        source = path.read_text(encoding="utf-8")
        origin = f"{path.relative_to(ROOT)}"
        staged = staged_tape(source, PROMPTS[case], origin=origin)
        (out / case).mkdir(parents=True, exist_ok=True)
        write_tape(out / case / "full.jsonl", staged)
        note = HAND_WRITTEN.format(origin=origin)
        if case == "box":
            rows = [_row("oneshot", k, "I am not able to write this program.", note if k == 0 else None)
                    for k in range(3)]
        else:
            rows = [_row("oneshot", 0, f"Here is the program.\n```python\n{source}```\n", note)]
        write_tape(out / case / "one-shot.jsonl", rows)
    judge_note = "HAND-WRITTEN TAPE: judge scores written by a developer for the CI bench; no model produced them."
    rows = [_row("judge", k, json.dumps({"geometry": g, "aesthetics": a, "semantic": s,
                                         "reason": "hand-written score"}), judge_note if k == 0 else None)
            for k, (g, a, s) in enumerate(JUDGE)]
    write_tape(out / "judge.jsonl", rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
