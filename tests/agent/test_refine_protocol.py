"""The critic's reply format and the refine loop's invariants, on a fake workbench."""

from __future__ import annotations

import pytest

from procedura_brep.agent.actions import Action, ActionError, CompileOutcome, EditRefused, RefineSession, parse_action
from procedura_brep.agent.critic import CritiqueError, parse_critique

VIEWS = ("iso_ne", "front", "left")


class Bench:
    """A fake workbench: the program is a string, a param edit appends to it."""

    def __init__(self, critiques, floaters=()):
        self.critiques = list(critiques)
        self.floaters = tuple(floaters)
        self.compiled: list[str] = []

    def render(self, source, *, views, close_up):
        return [f"{source}:{v}" for v in (views or [close_up])]

    def critique(self, source, views, trail):
        assert all(v.startswith(source + ":") for v in views)  # never a stale view
        return parse_critique(self.critiques.pop(0))

    def edit_part(self, source, part, reply):
        if "broken" in reply:
            raise EditRefused(f"part {part} does not compile")
        return source + f"|{part}"

    def set_param(self, source, name, value):
        return source + f"|{name}={value:g}"

    def compile(self, source):
        self.compiled.append(source)
        return CompileOutcome(not self.floaters, floaters=self.floaters)

    def connectivity(self, source):
        return CompileOutcome(not self.floaters, floaters=self.floaters)


HIGH = "SUMMARY: wheel floats\nISSUES:\n- [HIGH] wheel: floats 20 mm; lower its frame by 20 mm."
CLEAN = "SUMMARY: looks right\nISSUES: none"


def act(s, action, **args):
    return s.run(Action(action, args))


def test_edits_need_a_fresh_diagnosis_and_one_diagnosis_allows_one_edit():
    s = RefineSession(Bench([HIGH, CLEAN]), "p0")
    assert not act(s, "set_param", name="wheel_d", value=140).ok
    assert "needs a fresh diagnosis" in s.steps[-1].observation
    assert not act(s, "diagnose").ok and "no views" in s.steps[-1].observation
    assert act(s, "render", views=["iso_ne"]).ok
    assert act(s, "diagnose").ok and "[HIGH] wheel" in s.steps[-1].observation
    assert act(s, "set_param", name="wheel_d", value=140).ok and s.source == "p0|wheel_d=140"
    assert not act(s, "edit_part", part="wheel", reply="x").ok  # latch consumed
    assert not act(s, "diagnose").ok and "predate the last edit" in s.steps[-1].observation
    act(s, "render", views=["front"])
    assert act(s, "diagnose").ok and s.edits == 1


def test_a_refused_edit_keeps_the_diagnosis_and_the_budget():
    """Issue 23.6: a refused action (a set_param on a param other parts read, an edit that does
    not compile) used up the diagnosis, so the corrected edit was refused too."""
    s = RefineSession(Bench([HIGH]), "p0", max_edits=1)
    act(s, "render", views=["iso_ne"]), act(s, "diagnose")
    step = act(s, "edit_part", part="wheel", reply="broken")
    assert not step.ok and "does not compile" in step.observation and s.edits == 0 and s.latch
    assert "the diagnosis still allows one edit" in step.observation
    assert act(s, "edit_part", part="wheel", reply="fixed").ok and s.edits == 1 and not s.latch


def test_finish_ok_is_gated_on_floaters_high_issues_and_a_current_diagnosis():
    bench = Bench([HIGH, CLEAN, CLEAN], floaters=["bolt (box 0,0,0 - 5,5,5)"])
    s = RefineSession(bench, "p0")
    step = act(s, "finish", verdict="ok")
    assert not step.ok and "bolt (box" in step.observation and "predates" in step.observation
    act(s, "render", views=["iso_ne"]), act(s, "diagnose")
    step = act(s, "finish", verdict="ok")
    assert not step.ok and "HIGH issue(s) open: [HIGH] wheel" in step.observation
    act(s, "set_param", name="wheel_d", value=1)
    act(s, "render", views=["iso_ne"]), act(s, "diagnose")
    assert not act(s, "finish", verdict="ok").ok  # the floater is still there
    bench.floaters = ()
    s.compiled_version = -1  # (the fake's floaters changed without an edit)
    assert act(s, "finish", verdict="ok").ok and s.verdict == "ok"
    assert not act(s, "diagnose").ok and "ended" in s.steps[-1].observation


def test_give_up_is_never_gated_and_the_final_program_is_recompiled_when_stale():
    bench = Bench([HIGH], floaters=["x"])
    s = RefineSession(bench, "p0")
    act(s, "render", views=["iso_ne"]), act(s, "diagnose"), act(s, "set_param", name="a", value=2)
    assert act(s, "finish", verdict="give_up", reason="intended gap").ok and s.verdict == "give_up"
    assert bench.compiled[-1] == "p0|a=2"


def test_the_budget_counts_edits_and_the_action_bound_ends_the_session():
    s = RefineSession(Bench([HIGH] * 5), "p0", max_edits=2, max_actions=12)
    for _ in range(3):
        act(s, "render", views=["iso_ne"]), act(s, "diagnose"), act(s, "set_param", name="a", value=1)
    assert s.edits == 2 and "budget (2) is spent" in s.steps[-1].observation
    while not s.done:
        act(s, "compile")
    assert s.verdict == "steps" and len(s.steps) == 12


@pytest.mark.parametrize("reply,needle", [
    ("let me think", "one JSON object"),
    ('{"action": "paint"}', "unknown action 'paint'"),
    ('{"action": "render", "views": []}', "1-20 view names"),
    ('{"action": "render", "views": ["top_secret"]}', "unknown view(s) top_secret; views: iso_ne"),
    ('{"action": "set_param", "name": "a", "value": "big"}', "numeric"),
    ('{"action": "edit_part", "part": "a"}', "five blocks"),
    ('{"action": "finish", "verdict": "done"}', '"ok" or "give_up"'),
])
def test_malformed_actions(reply, needle):
    with pytest.raises(ActionError) as info:
        parse_action(reply, view_names=VIEWS)
    assert needle in str(info.value)


def test_actions_parse_from_fences_and_prose():
    a = parse_action('I will look first.\n```json\n{"action": "render", "views": ["front", "front", "left"]}\n```',
                     view_names=VIEWS)
    assert a == Action("render", {"views": ["front", "left"]})
    assert parse_action('{"action": "render", "close_up": "wheel"}', view_names=VIEWS).args == {"close_up": "wheel"}


def test_critique_parsing():
    c = parse_critique("**SUMMARY:** rover, one wheel off\n**ISSUES:**\n1. [high] `wheel_lr`: floats; lower it.\n"
                       "2. [Medium] mast - short; raise mast_h.\n- [LOW] body.lid: gap; close it.",
                       parts={"wheel_lr", "mast", "body"})
    assert [i.line() for i in c.issues] == ["[HIGH] wheel_lr: floats; lower it.", "[MED] mast: short; raise mast_h.",
                                            "[LOW] body: gap; close it."]
    assert c.top().part == "wheel_lr" and len(c.high) == 1
    assert parse_critique(CLEAN).issues == ()
    with pytest.raises(CritiqueError, match="no 'SUMMARY"):
        parse_critique("ISSUES: none")
    with pytest.raises(CritiqueError, match="no part 'hull'"):
        parse_critique("SUMMARY: s\nISSUES:\n- [HIGH] hull: sunk", parts={"body"})
    with pytest.raises(CritiqueError, match="could not read: - the wheel floats"):
        parse_critique("SUMMARY: s\nISSUES:\n- the wheel floats")


def test_an_applied_edit_says_which_helpers_the_splice_renamed():
    """Issue 23.6: a shared helper renamed on edit (claw_jaw -> claw_jaw_2) was reported only as
    "edit applied"; the fixer must learn the new name."""
    bench = Bench([HIGH])
    bench.last_renames = {"claw_jaw": "claw_jaw_2"}
    s = RefineSession(bench, "p0")
    act(s, "render", views=["iso_ne"])
    act(s, "diagnose")
    assert act(s, "edit_part", part="wheel", reply="x").ok
    assert "claw_jaw -> claw_jaw_2" in s.steps[-1].observation
