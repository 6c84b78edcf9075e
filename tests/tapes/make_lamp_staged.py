"""Write tests/tapes/lamp_staged.jsonl: a HAND-WRITTEN staged-run tape (no model wrote it).

Run ``python tests/tapes/make_lamp_staged.py`` after editing the replies below. The run it
drives: plan (3 parts) -> review (sharpens the post, lists the arm first: put back after its partner) -> build base -> post
fails to compile -> post hovers (mate gate) -> post passes -> arm passes -> refine: an edit
without a diagnosis is refused, render, diagnose (critic: HIGH on the arm), one gated edit,
render, diagnose (none), finish(ok).
"""

from __future__ import annotations

import json
from pathlib import Path

PROMPT = "a desk lamp with a swinging arm"
NOTE = ("HAND-WRITTEN TAPE: written by a developer to exercise the staged pipeline offline; "
        "no model produced these replies.")

PLAN = {"parts": [
    {"name": "base", "detail": "silhouette", "description": "120 x 120 x 12 mm cast base plate, rounded corners, the root",
     "mates": []},
    {"name": "post", "detail": "major", "description": "20 mm round post, 80 mm tall, standing on the base centre",
     "mates": [{"partner": "base", "type": "peg_socket", "nominal": "spigot_d"}]},
    {"name": "arm", "detail": "major", "description": "90 x 14 x 10 mm arm swinging about a pin near the post top",
     "mates": [{"partner": "post", "type": "revolute", "nominal": "pin_d"}]},
]}
REVIEW = {"parts": [PLAN["parts"][0], PLAN["parts"][2], dict(PLAN["parts"][1], description=(
    "20 mm round post, 80 mm tall, on the base centre, chamfered top; the arm pin 6 mm below its top"))]}


def blocks(params: str, helpers: str, body: str, frames: str, mates: str) -> str:
    out = []
    for name, text in (("params", params), ("helpers", helpers), ("body", body), ("frames", frames),
                       ("mates", mates)):
        out += [f"## {name}", "```python", text.strip() or "none", "```"]
    return "\n".join(out)


BASE = blocks("""
base_w = 120.0  # mm, square base side
base_t = 12.0   # mm, base thickness
spigot_d = 12.0  # mm, spigot under the post: the nominal of its peg_socket
""", "", """
@part(detail="silhouette", material="cast_iron", description="square base, rounded corners")
def base():
    b = Box(base_w, base_w, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return fillet(b.edges().filter_by(Axis.Z), radius=6)
""", """frames("base", top=Location((0, 0, base_t)))""", "")

POST_PARAMS = """
spigot_d = 12.0  # mm, spigot under the post: the nominal of its peg_socket
post_d = 20.0   # mm, post diameter
post_h = 80.0   # mm, post height
pin_d = 8.0     # mm, hinge pin: the nominal of the arm's revolute mate
"""
POST_BODY = """
@part(detail="major", material="brushed_steel", description="vertical post at the base centre")
def post():
    p = Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return chamfer(p.edges().group_by(Axis.Z)[-1], length=1.0)
"""
POST_FRAMES = """frames("post", foot=Location((0, 0, FOOT)), head=Location((0, post_d / 2, post_h - 6), (-90, 0, 0)))"""
POST_MATES = """mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")"""
POST_BAD_COMPILE = blocks(POST_PARAMS, "", POST_BODY.replace("post_d / 2", "post_r"),
                          POST_FRAMES.replace("FOOT", "0"), POST_MATES)
POST_HOVER = blocks(POST_PARAMS, "", POST_BODY, POST_FRAMES.replace("FOOT", "-5"), POST_MATES)
POST = blocks(POST_PARAMS, "", POST_BODY, POST_FRAMES.replace("FOOT", "0"), POST_MATES)


def arm(length: int) -> str:
    return blocks("pin_d = 8.0     # mm, hinge pin: the nominal of the arm's revolute mate\n"
                  f"arm_l = {length:.1f}   # mm, arm length", "", """
@part(detail="major", material="painted_aluminium", description="arm swinging about a pin at the post top")
def arm():
    return Box(arm_l, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))
""", """frames("arm", pivot=Location((7, -7, 0), (-90, 0, 0)))""",
                  """mate("arm.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-45, 45))""")


def action(**kw) -> str:
    return "```json\n" + json.dumps(kw) + "\n```"


CALLS = [
    ("plan", "```json\n" + json.dumps(PLAN, indent=1) + "\n```"),
    ("review", "```json\n" + json.dumps(REVIEW, indent=1) + "\n```"),
    ("build", "Here is the base.\n" + BASE),
    ("build", POST_BAD_COMPILE),
    ("build", POST_HOVER),
    ("build", POST),
    ("build", arm(60)),
    ("fixer", action(action="set_param", name="arm_l", value=90)),
    ("fixer", action(action="render", views=["iso_se", "front", "top"])),
    ("fixer", action(action="diagnose")),
    ("critic", "SUMMARY: base, post and arm are there; the arm is short.\nISSUES:\n"
               "- [HIGH] arm: it is 60 mm long against a 90 mm arm in the plan; make it 90 mm long."),
    ("fixer", action(action="edit_part", part="arm", reply=arm(90))),
    ("fixer", action(action="render", views=["iso_se", "front", "top"])),
    ("fixer", action(action="diagnose")),
    ("critic", "SUMMARY: a desk lamp base, post and arm in proportion.\nISSUES: none"),
    ("fixer", action(action="finish", verdict="ok")),
]


def main() -> None:
    out = Path(__file__).with_name("lamp_staged.jsonl")
    rows = []
    for step, (role, text) in enumerate(CALLS):
        row = {"v": 1, "role": role, "step": step, "model": "hand-written", "request": {},
               "reply": {"text": text, "usage": {"input_tokens": 0, "cached_input_tokens": 0, "output_tokens": 0}}}
        if step == 0:
            row = {"v": 1, "role": role, "step": step, "model": "hand-written", "note": NOTE, "prompt": PROMPT,
                   **{k: v for k, v in row.items() if k not in ("v", "role", "step", "model")}}
        rows.append(json.dumps(row, ensure_ascii=False))
    out.write_text("\n".join(rows) + "\n", encoding="utf-8")
    print(f"wrote {out} ({len(rows)} calls)")


if __name__ == "__main__":
    main()
