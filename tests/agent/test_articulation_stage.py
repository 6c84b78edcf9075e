"""The articulation stage: the strict plan, promotions by evidence, gated mate edits, and a
replayed run whose battery fails (B2) and is fixed by one battery-fixer edit."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.agent.articulation import FixerError, parse_fixer
from procedura_brep.agent.articulation_plan import ArticulationPlanError, parse_articulation, promotion_refusal
from procedura_brep.agent.staged import generate_staged
from procedura_brep.program.mate_edit import REMOVE, set_mate

TAPES = Path(__file__).parents[1] / "tapes"
TAPE = TAPES / "lamp_articulation.jsonl"
LAMP = Path(__file__).parents[1] / "program" / "lamp.py"


@pytest.fixture(scope="module")
def lamp(worker):
    from procedura_brep.program import compile_source
    model = compile_source(LAMP.read_text(), name="lamp", worker=worker)
    assert model.ok, model.findings
    return model


# the plan -------------------------------------------------------------------------------------

def test_a_malformed_plan_lists_every_problem(lamp):
    with pytest.raises(ArticulationPlanError) as exc:
        parse_articulation('{"joints": [{"mate": "post_foot", "limits": [1]}, {"mate": "nope"}],'
                           ' "promote": [{"mate": "arm_pivot", "type": "spherical"}], "base": "x",'
                           ' "colour": 1}', lamp)
    text = " | ".join(exc.value.problems)
    for bit in ("unknown key(s) colour", "post_foot: it is a static peg_socket mate",
                "limits is [lo, hi]", "no mate named 'nope'", "arm_pivot: it is already kinematic",
                "type must be one of revolute, prismatic", "base must be"):
        assert bit in text, (bit, text)
    with pytest.raises(ArticulationPlanError, match="not JSON|one JSON object"):
        parse_articulation("no plan here", lamp)


# the reply states only what it changes: links, base and wheels are the tool's

def test_a_reply_need_not_restate_links_base_or_wheels(lamp):
    plan = parse_articulation('{"joints": [{"mate": "arm_pivot", "effort": 4}]}', lamp)
    assert plan.base is None and plan.links is None and plan.wheels is None
    assert plan.edits[0].options == {"effort": 4.0}
    assert parse_articulation('{"joints": []}', lamp).edits == []


def test_a_stated_base_is_still_checked(lamp):
    assert parse_articulation('{"joints": [], "base": "welded"}', lamp).base == "welded"
    with pytest.raises(ArticulationPlanError, match="base must be"):
        parse_articulation('{"joints": [], "base": "bolted"}', lamp)


def test_drives_must_agree_with_the_limits(lamp):
    with pytest.raises(ArticulationPlanError, match="velocity drive is for a continuous turn"):
        parse_articulation('{"joints": [{"mate": "arm_pivot", "drive": "velocity"}], "base": "welded"}', lamp)
    with pytest.raises(ArticulationPlanError, match="position drive needs limits"):
        parse_articulation('{"joints": [{"mate": "arm_pivot", "limits": null, "drive": "position"}],'
                           ' "base": "welded"}', lamp)
    plan = parse_articulation('```json\n{"joints": [{"mate": "arm_pivot", "limits": null, '
                              '"drive": "velocity"}], "base": "welded"}\n```', lamp)
    assert plan.edits[0].options == {"limits": None} and plan.edits[0].drive == "velocity"


def test_a_promotion_needs_symmetry_evidence():
    """A round peg on its axis may become a revolute; a box on a box may not; a prismatic needs a
    parallel symmetry axis."""
    from build123d import Box, Cylinder

    from procedura_brep.articulation.evidence import symmetry_axis
    from procedura_brep.kernel import tessellate
    from tests.articulation.models import mate
    frame = np.eye(4)
    frame[:3, 3] = [0.0, 0.0, 10.0]
    m = mate("peg_foot", "peg", "block", frame=frame)

    def ev(child, parent):
        return {"parts": {"peg": {"symmetry": symmetry_axis(tessellate(child.wrapped))},
                          "block": {"symmetry": symmetry_axis(tessellate(parent.wrapped))}}}

    block = Box(40, 30, 10)
    assert promotion_refusal(m, "revolute", ev(Cylinder(5, 30), block)) is None
    why = promotion_refusal(m, "revolute", ev(Box(12, 7, 30), block))
    assert why and "refused" in why and "round about the mate axis" in why
    off = Cylinder(5, 30).translate((8, 0, 0))  # round, parallel, but off the anchor
    assert "refused" in promotion_refusal(m, "revolute", ev(off, block))
    assert promotion_refusal(m, "prismatic", ev(off, block)) is None


def test_set_mate_rewrites_exactly_one_line():
    src = LAMP.read_text()
    new = set_mate(src, "arm_pivot", options={"limits": (-30.0, 30.0), "effort": 5.0})
    diff = [(a, b) for a, b in zip(src.splitlines(), new.splitlines()) if a != b]
    assert len(diff) == 1 and len(src.splitlines()) == len(new.splitlines())
    assert diff[0][1] == ('mate("arm.pivot", "post.head", "revolute", nominal="pin_d", '
                          'fit="clearance", limits=(-30.0, 30.0), effort=5.0)')
    promoted = set_mate(src, "post_foot", type="revolute", fit="clearance", options={"depth": REMOVE})
    assert 'mate("post.foot", "base.top", "revolute", nominal="spigot_d", fit="clearance")' in promoted
    from procedura_brep.errors import EditError
    with pytest.raises(EditError, match="no mate named 'arm'.*mates: post_foot, arm_pivot"):
        set_mate(src, "arm", options={"limits": None})


def test_the_fixer_reply_is_one_strict_action():
    assert parse_fixer('```json\n{"action": "set_mate", "mate": "a", "limits": [-1, 1]}\n```')["mate"] == "a"
    for bad, msg in (('{"action": "set_mate", "mate": "a"}', "at least one option"),
                     ('{"action": "set_mate", "mate": "a", "colour": 1}', "unknown option"),
                     ('{"action": "set_param", "name": "x", "value": true}', "numeric"),
                     ('{"action": "render"}', "one of set_mate"), ("nothing", "one of set_mate")):
        with pytest.raises(FixerError, match=msg):
            parse_fixer(bad)


# the replayed run ------------------------------------------------------------------------------

def test_the_tape_is_labelled_hand_written():
    first = json.loads(TAPE.read_text().split("\n", 1)[0])
    assert "HAND-WRITTEN" in first["note"] and first["model"] == "hand-written"
    roles = [json.loads(x)["role"] for x in TAPE.read_text().splitlines()]
    assert roles[-3:] == ["articulation", "articulation", "battery_fixer"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("artic") / "lamp"
    lines: list[str] = []
    result = generate_staged(None, out, model=f"replay:{TAPE}",
                             progress=lambda s, t: lines.append(f"{s}: {t}"))
    return result, out, lines


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_battery_failure_is_fixed_by_one_gated_edit(run):
    result, out, lines = run
    assert result.status == "ok", result.message
    report = json.loads((out / "report.json").read_text())
    art = report["articulation"]
    # the malformed plan was retried with its problems; the second was applied as a program edit
    assert art["attempts"] == 2 and any("arm_hinge" in p for p in art["plan_problems"][0])
    assert [e["mate"] for e in art["edits"] if e["accepted"]] == ["arm_pivot"]
    assert any(f.startswith("base: the plan says free") for f in art["findings"])
    assert art["articulation"]["base"] == "welded"
    # the widened limits made B2 fail; the fixer saw the check and set them back
    assert art["battery_first"] == {"passed": False, "failed": ["B2"], "status": "battery_failed"}
    (fixer,) = art["battery_fixer"]  # one round: the battery then passes
    assert fixer["check"] == "B2" and "arm_pivot" in fixer["message"] and fixer["accepted"]
    assert fixer["round"] == 1 and fixer["failing_after"] == [] and fixer["stop"] == "the battery passes"
    assert art["battery_last"]["passed"]
    assert report["battery"]["passed"] and report["status"] == "ok"
    program = (out / "program.py").read_text()
    assert "limits=(-45, 45)" in program and "(-80.0, 80.0)" not in program
    assert "limits=(-80.0, 80.0)" in (out / "history" / "004-articulation-arm_pivot.py").read_text()
    assert (out / "history" / "005-battery_fixer-set_mate.py").read_text() == program
    for rel in fixer["frames"]:
        assert (out / rel).read_bytes().startswith(b"\x89PNG")
    calls = [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines()]
    req = next(c for c in calls if c["role"] == "battery_fixer")["request"]
    text = " ".join(m["text"] for m in req["messages"])
    assert "Failed check: B2" in text and "drives 'arm'" in text
    assert f"{len(fixer['frames'])} frame(s)" in text
    # the articulation call was shown the evidence and the current links
    req = next(c for c in calls if c["role"] == "articulation")["request"]
    text = " ".join(m["text"] for m in req["messages"])
    assert "## Symmetry" in text and "link base: base, post" in text


def test_no_articulation_flag_reaches_the_options(monkeypatch, tmp_path):
    from typer.testing import CliRunner

    import procedura_brep.agent.staged as staged
    from procedura_brep.cli import app
    seen = {}

    def fake(prompt, out, *, options, **kw):
        seen["options"] = options
        return staged.StagedResult("ok", out, staged.RunState("x"))

    monkeypatch.setattr(staged, "generate_staged", fake)
    res = CliRunner().invoke(app, ["generate", "a lamp", "--model", f"replay:{TAPE}", "-o",
                                   str(tmp_path / "o"), "--no-articulation", "-q"])
    assert res.exit_code == 0, res.output
    assert seen["options"].articulation is False
    CliRunner().invoke(app, ["generate", "a lamp", "--model", f"replay:{TAPE}", "-o",
                             str(tmp_path / "p"), "-q"])
    assert seen["options"].articulation is True


class _Host:
    """The bits of a staged run the stage's edits need (no model calls)."""

    def __init__(self, out_dir: Path) -> None:
        from procedura_brep.agent.staged import StagedOptions
        from procedura_brep.agent.tools import Tools
        self.tools, self.options, self.out_dir = Tools(), StagedOptions(), out_dir
        self.name, self.prompt, self.lines = "lamp", "a lamp", []

    def progress(self, stage: str, text: str) -> None:
        self.lines.append(text)


def test_promotions_are_applied_or_refused_by_evidence_and_logged(tmp_path):
    """The lamp with its arm seated (static): promoting the post's foot (the post is round about
    it) to a revolute is applied as a program edit; promoting the arm's seat (a box on a post
    whose axis is not the seat's) is refused and logged, and the program keeps it static."""
    from procedura_brep.agent.articulation import ArticulationStage
    from procedura_brep.articulation import articulate, mates_evidence
    src = LAMP.read_text().replace('"revolute", nominal="pin_d", fit="clearance", limits=(-45, 45)',
                                   '"seat_face", nominal="pin_d", fit="clearance"')
    host = _Host(tmp_path)
    stage = ArticulationStage(host)
    model = host.tools.compile_model(src, "lamp")
    plan = parse_articulation('{"promote": [{"mate": "post_foot", "type": "revolute", "limits": null,'
                              ' "drive": "velocity"}, {"mate": "arm_pivot", "type": "revolute",'
                              ' "limits": [-30, 30]}], "base": "welded"}', model)
    new = stage.apply(src, model, plan, mates_evidence(model))
    rows = {r["mate"]: r for r in stage.report["edits"]}
    assert rows["post_foot"]["accepted"], rows["post_foot"]
    assert not rows["arm_pivot"]["accepted"]
    assert "promote arm_pivot to revolute refused" in rows["arm_pivot"]["reason"]
    assert 'mate("post.foot", "base.top", "revolute", nominal="spigot_d", fit="location", limits=None)' in new
    assert '"seat_face", nominal="pin_d"' in new
    art = articulate(host.tools.compile_model(new, "lamp"))
    assert [(j.name, j.type, j.drive) for j in art.joints] == [("post_foot", "continuous", "velocity")]
    assert (tmp_path / "history" / "001-articulation-post_foot.py").read_text() == new


def test_a_run_resumed_at_finish_keeps_its_refine_and_articulation_reports(run, tmp_path):
    """The stage reports live in state.json: a run killed after the articulation stage and
    resumed at ``finish`` still reports both (before, report.json lost them)."""
    import shutil
    result, out, _ = run
    first = json.loads((out / "report.json").read_text())
    assert first["articulation"]["edits"] and first["refine"]
    again = tmp_path / "again"
    shutil.copytree(out, again)
    state = json.loads((again / "state.json").read_text())
    state["stage"] = "finish"  # as if killed before the finish built the run directory
    (again / "state.json").write_text(json.dumps(state))
    (again / "report.json").unlink()
    resumed = generate_staged(None, again, model=f"replay:{TAPE}", resume=True)
    assert resumed.status == result.status
    report = json.loads((again / "report.json").read_text())
    assert report["articulation"] == first["articulation"]
    assert report["refine"] == first["refine"]


def test_a_coupled_joint_gets_no_drive_and_the_evidence_lists_couplings(worker):
    """Issue 27.5: the articulation stage plans drives for drivers only."""
    from procedura_brep.agent.articulation_plan import evidence_text
    from procedura_brep.program import compile_source
    model = compile_source((LAMP.parent / "transmission.py").read_text(), name="t", worker=worker)
    assert model.ok, model.findings
    ok = parse_articulation(json.dumps({"joints": [{"mate": "pinion_hub", "drive": "position"},
                                                   {"mate": "wheel_hub", "limits": [-90, 90]}]}), model)
    assert [(e.mate, e.drive) for e in ok.edits] == [("pinion_hub", "position"), ("wheel_hub", None)]
    with pytest.raises(ArticulationPlanError, match="joints wheel_hub: it follows pinion_hub through a "
                                                    "coupling, so it gets no drive of its own"):
        parse_articulation(json.dumps({"joints": [{"mate": "wheel_hub", "drive": "position"}]}), model)
    text = evidence_text(model, {"parts": {}, "contacts": []}, None)
    assert "## Couplings" in text and "- wheel_hub follows pinion_hub: gear, ratio -0.333333" in text
    # a recorded model gave a lead screw limits of +-29700 deg to match its carriage's travel,
    # which the mate vocabulary refuses: the request says how to plan a multi-turn driver
    assert "a lead screw, turns continuously (limits null, drive velocity)" in " ".join(text.split())
