"""Refine routes work back to the build stage (issue 23.6): a gated ``add_part`` builds a part
the critic asks for through the build path (its build request, splice, gates, N_vis); a part
whose edits are refused twice is rebuilt from its build request, and a mate that could not be
satisfied goes back to the plan's mate. End to end through generate_staged on hand-written
tapes (built by these tests), and the session's rules on a fake workbench."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from procedura_brep.agent.actions import (
    MAX_REBUILDS,
    REBUILD_AFTER,
    Action,
    ActionError,
    EditRefused,
    RefineSession,
    parse_action,
)
from procedura_brep.agent.staged import StagedOptions, generate_staged
from procedura_brep.testing.tapes import part_replies, plan_from_program, write_tape

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"
ARM_MATE = 'mate("arm.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-45, 45))'
HIGH_ARM = "SUMMARY: a lamp\nISSUES:\n- [HIGH] arm: it should hang from the post head on a seat."
CLEAN = "SUMMARY: the lamp matches the prompt.\nISSUES: none"


def _tape(path: Path, calls: list[tuple[str, str]]) -> Path:
    rows = [{"v": 1, "role": role, "step": k, "model": "hand-written", "request": {},
             "reply": {"text": text, "usage": {}}} for k, (role, text) in enumerate(calls)]
    rows[0].update(note="HAND-WRITTEN TAPE (built by this test)", prompt="a desk lamp with an arm")
    write_tape(path, rows)
    return path


def _fixer(**action) -> tuple[str, str]:
    return ("fixer", json.dumps(action))


def _calls(out: Path) -> list[dict]:
    return [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines()]


def _no_arm(src: str) -> str:
    """The lamp as built without its arm (the critic then asks for it)."""
    lines = [ln for ln in src.splitlines() if not ln.startswith(('frames("arm"', 'mate("arm', "pin_d ="))]
    text = "\n".join(lines) + "\n"
    start = text.index('@part(detail="major", material="painted_aluminium"')
    end = text.index("# === frames ===")
    return text[:start] + text[end:]


OPTS = StagedOptions(review=False, simulate=False)


def test_add_part_builds_the_part_the_critic_asks_for_through_the_build_path(tmp_path):
    src = LAMP.read_text()
    base, post, arm = part_replies(src)
    plan = "```json\n" + json.dumps(plan_from_program(_no_arm(src))) + "\n```"
    tape = _tape(tmp_path / "t.jsonl", [
        ("plan", plan), ("build", base), ("build", post),
        _fixer(action="render", views=["iso_se"]), _fixer(action="diagnose"),
        ("critic", "SUMMARY: a post on a base\nISSUES:\n- [HIGH] post: the lamp has no arm; add a "
                   "90 mm arm on a pin at the post head."),
        _fixer(action="add_part", name="arm", what="90 x 14 x 10 mm arm swinging on a pin at the post head",
               mates_to="post", type="revolute", nominal="pin_d"),
        ("build", arm),
        _fixer(action="render", views=["iso_se"]), _fixer(action="diagnose"), ("critic", CLEAN),
        _fixer(action="finish", verdict="ok")])
    out = tmp_path / "add"
    res = generate_staged(None, out, model=f"replay:{tape}", options=OPTS)
    assert res.status == "ok", res.message
    report = json.loads((out / "report.json").read_text())
    refine = report["refine"]
    assert refine["verdict"] == "ok" and refine["edits"] == 1, refine
    (row,) = refine["routed"]
    assert row["kind"] == "add_part" and row["part"] == "arm" and row["accepted"]
    # the part joins the program, the plan and the committed log
    program = (out / "program.py").read_text()
    assert "def arm():" in program and 'mate("arm.pivot", "post.head", "revolute"' in program
    assert [c["name"] for c in report["committed"]] == ["base", "post", "arm"]
    assert report["plan"]["parts"][-1]["name"] == "arm"
    assert report["plan"]["parts"][-1]["mates"] == [{"partner": "post", "type": "revolute", "nominal": "pin_d"}]
    assert (out / "history" / "003-refine-add_part.py").read_text() == program
    # its build call is the build stage's request over the whole current program, told why
    build = [c for c in _calls(out) if c["role"] == "build"][-1]["request"]
    text = "\n".join(m["text"] for m in build["messages"])
    assert "Write part 3 of 3: arm" in text and "Refine adds this part" in text and "def post():" in text
    assert any(m["images"] for m in build["messages"])  # the renders of the build so far
    fixer = [c for c in _calls(out) if c["role"] == "fixer"][3]["request"]["messages"][-1]["text"]
    assert "edit applied (1/6 edits); part arm added, mated to post" in fixer


def test_an_add_part_that_fails_its_gates_is_refused_and_the_diagnosis_stands(tmp_path):
    src = LAMP.read_text()
    base, post, arm = part_replies(src)
    floating = arm.replace("return Box(90", "return Pos(0, 0, 300) * Box(90")
    plan = "```json\n" + json.dumps(plan_from_program(_no_arm(src))) + "\n```"
    add = dict(action="add_part", name="arm", what="90 x 14 x 10 mm arm swinging on a pin at the post head",
               mates_to="post", type="revolute", nominal="pin_d")
    tape = _tape(tmp_path / "t.jsonl", [
        ("plan", plan), ("build", base), ("build", post),
        _fixer(action="render", views=["iso_se"]), _fixer(action="diagnose"),
        ("critic", "SUMMARY: a post\nISSUES:\n- [HIGH] post: no arm; add one."),
        _fixer(**{**add, "mates_to": "lampshade"}),  # not a part: refused before any call
        _fixer(**add), ("build", floating), ("build", floating), ("build", floating),
        _fixer(action="finish", verdict="give_up", reason="the arm will not sit")])
    out = tmp_path / "refused"
    res = generate_staged(None, out, model=f"replay:{tape}", options=OPTS)
    assert res.status == "ok", res.message
    refine = res.refine
    assert refine["edits"] == 0 and refine["verdict"] == "give_up"
    assert "mates_to 'lampshade' is not a part" in refine["refused"][0]
    assert "arm was not added: its build failed 3 attempt(s)" in refine["refused"][1]
    assert "the diagnosis still allows one edit" in refine["refused"][1]
    assert refine["routed"][-1]["accepted"] is False
    assert "def arm" not in (out / "program.py").read_text()
    assert [c.name for c in res.state.committed] == ["base", "post"]


def test_a_part_refused_twice_is_rebuilt_and_its_unsatisfiable_mate_goes_back_to_the_plan(tmp_path):
    """Two edits of the arm are refused (its pivot frame turned, the arm driven into the post:
    a finding on the arm_pivot mate); the arm is then rebuilt from its build request, which says
    the mate could not be satisfied and shows the plan's mate; the rebuilt arm declares a seat
    instead, and the plan's mate follows it."""
    src = LAMP.read_text()
    base, post, arm = part_replies(src)
    turned = arm.replace("pivot=Location((7, -7, 0), (-90, 0, 0))", "pivot=Location((7, -7, 0), (0, 0, 0))")
    seated = arm.replace(ARM_MATE, 'mate("arm.pivot", "post.head", "seat_face", nominal="pin_d", fit="clearance")')
    assert turned != arm and seated != arm
    plan = "```json\n" + json.dumps(plan_from_program(src)) + "\n```"
    tape = _tape(tmp_path / "t.jsonl", [
        ("plan", plan), ("build", base), ("build", post), ("build", arm),
        _fixer(action="render", views=["iso_se"]), _fixer(action="diagnose"), ("critic", HIGH_ARM),
        _fixer(action="edit_part", part="arm", reply=turned),
        _fixer(action="edit_part", part="arm", reply=turned), ("build", seated),
        _fixer(action="render", views=["iso_se"]), _fixer(action="diagnose"), ("critic", CLEAN),
        _fixer(action="finish", verdict="ok")])
    out = tmp_path / "rebuild"
    res = generate_staged(None, out, model=f"replay:{tape}", options=OPTS)
    assert res.status == "ok", res.message
    refine = json.loads((out / "report.json").read_text())["refine"]
    assert refine["verdict"] == "ok" and refine["edits"] == 1
    (row,) = refine["routed"]
    assert row["kind"] == "rebuild" and row["part"] == "arm" and row["accepted"]
    assert row["refused_edits"] == REBUILD_AFTER == 2 and row["mates"] == ["arm_pivot"]
    program = (out / "program.py").read_text()
    assert '"seat_face", nominal="pin_d"' in program and '"revolute"' not in program
    assert (out / "history" / "004-refine-rebuild_part.py").read_text() == program
    # the rebuild's request: the arm's build request, the refusals and the plan's mate
    build = [c for c in _calls(out) if c["role"] == "build"][-1]["request"]
    text = "\n".join(m["text"] for m in build["messages"])
    assert "Write part 3 of 3: arm" in text and "is rebuilt from its build request" in text
    assert "arm and post interpenetrate" in text
    assert "mate(s) arm_pivot could not be satisfied" in text
    assert "The plan's mates for it: to post: revolute, nominal pin_d" in text
    # the plan's mate follows the mate the rebuilt part declares; the log holds the new arm
    assert res.state.plan["parts"][2]["mates"] == [{"partner": "post", "type": "seat_face", "nominal": "pin_d"}]
    assert "seat_face" in res.state.committed[2].text
    fixer = [c for c in _calls(out) if c["role"] == "fixer"][4]["request"]["messages"][-1]["text"]
    assert "arm could not be fixed in place (2 refused edits)" in fixer and "edit applied (1/6" in fixer


# the session's rules, on a fake workbench ------------------------------------------------------

class _Bench:
    """Edits of a part named 'stuck' are refused; a rebuild appends '+rebuilt'."""

    can_rebuild = True

    def __init__(self):
        self.rebuilds: list[str] = []

    def render(self, source, *, views, close_up):
        return [f"{source}:{v}" for v in views]

    def critique(self, source, views, trail):
        from procedura_brep.agent.critic import parse_critique
        return parse_critique(HIGH_ARM)

    def edit_part(self, source, part, reply):
        if part == "stuck":
            raise EditRefused("stuck does not pass its gates")
        return source + f"|{part}"

    def rebuild_part(self, source, part, reasons):
        self.rebuilds.append(part)
        return source + f"|{part}+rebuilt"

    def add_part(self, source, args):
        return source + f"|+{args['name']}"


def _session(bench, **kw):
    s = RefineSession(bench, "p0", **kw)
    s.run(Action("render", {"views": ["iso_ne"]}))
    s.run(Action("diagnose"))
    return s


def test_a_rebuild_comes_after_two_refusals_once_per_part_and_is_an_edit():
    bench = _Bench()
    s = _session(bench)
    first = s.run(Action("edit_part", {"part": "stuck", "reply": "x"}))
    assert not first.ok and not bench.rebuilds and s.latch
    second = s.run(Action("edit_part", {"part": "stuck", "reply": "x"}))
    assert second.ok and second.action == "rebuild_part" and bench.rebuilds == ["stuck"]
    assert "could not be fixed in place (2 refused edits)" in second.observation
    assert s.source == "p0|stuck+rebuilt" and s.edits == 1 and not s.latch  # the diagnosis is used
    for _ in range(3):  # the same part is not rebuilt twice
        s.run(Action("render", {"views": ["iso_ne"]}))
        s.run(Action("diagnose"))
        s.run(Action("edit_part", {"part": "stuck", "reply": "x"}))
        s.run(Action("edit_part", {"part": "stuck", "reply": "x"}))
    assert bench.rebuilds == ["stuck"] and s.edits == 1


def test_rebuilds_are_bounded_and_need_a_bench_that_can_rebuild():
    assert MAX_REBUILDS == 2
    bench = _Bench()
    bench.edit_part = lambda source, part, reply: (_ for _ in ()).throw(EditRefused("no"))
    s = _session(bench)
    for part in ("a", "b", "c"):
        for _ in range(2):
            s.run(Action("edit_part", {"part": part, "reply": "x"}))
        s.run(Action("render", {"views": ["iso_ne"]}))
        s.run(Action("diagnose"))
    assert bench.rebuilds == ["a", "b"]
    bench = _Bench()
    bench.can_rebuild = False  # a revise never rebuilds
    s = _session(bench)
    for _ in range(3):
        assert not s.run(Action("edit_part", {"part": "stuck", "reply": "x"})).ok
    assert not bench.rebuilds


def test_add_part_is_an_edit_needing_a_diagnosis_and_budget():
    bench = _Bench()
    s = RefineSession(bench, "p0", max_edits=1)
    args = {"name": "screw", "what": "a 12 mm lead screw", "mates_to": "frame", "type": "revolute",
            "nominal": "screw_d"}
    assert "needs a fresh diagnosis" in s.run(Action("add_part", args)).observation
    s.run(Action("render", {"views": ["iso_ne"]})), s.run(Action("diagnose"))
    assert s.run(Action("add_part", args)).ok and s.source == "p0|+screw" and s.edits == 1
    s.run(Action("render", {"views": ["iso_ne"]})), s.run(Action("diagnose"))
    assert "budget (1) is spent" in s.run(Action("add_part", args)).observation


@pytest.mark.parametrize("reply,needle", [
    ('{"action": "add_part", "name": "screw", "what": "a lead screw", "mates_to": "frame", "type": "revolute"}',
     "bad: nominal"),
    ('{"action": "add_part", "name": "Screw", "what": "a lead screw", "mates_to": "frame", '
     '"type": "revolute", "nominal": "d"}', "bad: name"),
    ('{"action": "add_part", "name": "screw", "what": "s", "mates_to": "frame", "type": "revolute", '
     '"nominal": "d"}', '"what"'),
])
def test_add_part_arguments_are_checked(reply, needle):
    with pytest.raises(ActionError) as info:
        parse_action(reply, view_names=("iso_ne",))
    assert needle in str(info.value)
