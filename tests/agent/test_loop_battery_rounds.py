"""The battery fixer works in rounds (issue 23.6): fix, rebuild, rerun the battery, until it
passes, a round makes no progress, or the round bound. Driven by a scripted fixer over the real
lamp program, its edits gated for real; the battery is a stand-in that reads the program (which
checks fail is a function of the mate's options), so each round's rebuild is instant."""

from __future__ import annotations

import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from procedura_brep.agent.articulation import BATTERY_ROUNDS, ArticulationStage
from procedura_brep.agent.staged import StagedOptions
from procedura_brep.agent.tools import Tools

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"
PNG = (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x02\x00\x00\x00"
       b"\x90wS\xde\x00\x00\x00\x0cIDATx\x9cc\xf8\xff\xff?\x00\x05\xfe\x02\xfe\xa7\x35\x81\x84\x00"
       b"\x00\x00\x00IEND\xaeB`\x82")


def _pivot(source: str) -> str:
    return next(line for line in source.splitlines() if line.startswith('mate("arm.pivot"'))


def _failing(source: str) -> list[str]:
    """The stand-in battery: B2 fails while the arm may swing to 80 deg, B1 while the pivot has
    no effort, B3 while it has no velocity; B7 always fails."""
    pivot = _pivot(source)
    out = []
    if "effort=" not in pivot:
        out.append("B1")
    if re.search(r"limits=\(-80", pivot):
        out.append("B2")
    if "velocity=" not in pivot:
        out.append("B3")
    if "B7" in source:  # a marker comment in the program: a check no edit here fixes
        out.append("B7")
    return out


class _Tools(Tools):
    def __init__(self):
        super().__init__()
        self.built: list[str] = []

    def final_build(self, source, out_dir, *, simulate=True, formats=None, progress=None):
        self.built.append(source)
        failing = _failing(source)
        (out_dir / "f.png").write_bytes(PNG)
        checks = [{"id": c, "name": c, "passed": c not in failing, "message": f"{c} failed on arm_pivot",
                   "frames": ["f.png"]} for c in ("B1", "B2", "B3", "B7")]
        return SimpleNamespace(report={"battery": {"passed": not failing, "checks": checks}},
                               status="battery_failed" if failing else "ok", ok=not failing)


class _Host:
    def __init__(self, out_dir: Path, replies: list[dict]) -> None:
        self.tools, self.options, self.out_dir = _Tools(), StagedOptions(), out_dir
        self.name, self.prompt, self.lines = "lamp", "a lamp", []
        self.replies = [json.dumps(r) for r in replies]
        self.requests: list[str] = []

    def call(self, role, system, messages, *, max_tokens=8000):
        assert role == "battery_fixer"
        self.requests.append("\n".join(m.text for m in messages))
        return self.replies.pop(0)

    def refs(self):
        return []

    def progress(self, stage, text):
        self.lines.append(text)


def _lamp(*, limits="(-80, 80)", marker=False) -> str:
    src = LAMP.read_text().replace("limits=(-45, 45)", f"limits={limits}")
    return src + ("# B7: a check no edit here fixes\n" if marker else "")


def _run(tmp_path, source, replies):
    host = _Host(tmp_path, replies)
    stage = ArticulationStage(host)
    failed = stage.battery(source)
    out = stage.fix_rounds(source, failed, None)
    return host, stage, out


def test_rounds_go_on_while_each_makes_progress_up_to_the_bound(tmp_path):
    """B1, B2, B3 and B7 fail; each round fixes one of the first three, so three rounds run
    (three fixer calls, each battery rerun on the edited program) and the bound ends them with
    B7 still failing. Each round is a row of the report, and each later round is told what the
    earlier ones did and what still fails."""
    assert BATTERY_ROUNDS == 3
    src = _lamp(marker=True)
    host, stage, out = _run(tmp_path, src, [
        {"action": "set_mate", "mate": "arm_pivot", "limits": [-45, 45]},
        {"action": "set_mate", "mate": "arm_pivot", "effort": 5},
        {"action": "set_mate", "mate": "arm_pivot", "velocity": 2},
        {"action": "give_up", "reason": "never asked: the bound ends the rounds first"}])
    rounds = stage.report["battery_fixer"]
    assert [r["round"] for r in rounds] == [1, 2, 3] and all(r["accepted"] for r in rounds)
    assert [r["failing_before"] for r in rounds] == [["B1", "B2", "B3", "B7"], ["B1", "B3", "B7"],
                                                      ["B3", "B7"]]
    assert [r["failing_after"] for r in rounds] == [["B1", "B3", "B7"], ["B3", "B7"], ["B7"]]
    assert "round bound (3)" in rounds[-1]["stop"] and len(host.replies) == 1
    pivot = _pivot(out)
    assert "limits=(-45, 45)" in pivot and "effort=5" in pivot and "velocity=2" in pivot
    assert host.tools.built[-1] == out == stage.built_source  # the finish reuses this build
    assert stage.report["battery_first"]["failed"] == ["B1", "B2", "B3", "B7"]
    assert stage.report["battery_last"]["failed"] == ["B7"]
    # the second call is told round 2, the first round's action and what failed after it
    assert "Round 2 of at most 3" in host.requests[1]
    assert "round 1: B1 failed" in host.requests[1] and "the battery then failed B1, B3, B7" in host.requests[1]
    assert "- B2 (B2): B2 failed" in host.requests[0]  # the other failing checks are listed
    # each round keeps its own frames
    assert [r["frames"] for r in rounds] == [["history/articulation/B1_0.png"],
                                             ["history/articulation/B1_r2_0.png"],
                                             ["history/articulation/B3_r3_0.png"]]
    assert all((tmp_path / r["frames"][0]).read_bytes() == PNG for r in rounds)


def test_rounds_end_when_the_battery_passes(tmp_path):
    host, stage, out = _run(tmp_path, _lamp(), [
        {"action": "set_mate", "mate": "arm_pivot", "limits": [-45, 45], "effort": 5},
        {"action": "set_mate", "mate": "arm_pivot", "velocity": 2}])
    rounds = stage.report["battery_fixer"]
    assert len(rounds) == 2 and rounds[-1]["stop"] == "the battery passes" and not host.replies
    assert stage.report["battery_last"]["passed"] and _failing(out) == []


@pytest.mark.parametrize("reply,stop", [
    ({"action": "set_mate", "mate": "arm_pivot", "home": 10}, "no progress: still 3 failing"),
    ({"action": "give_up", "reason": "cannot"}, "no change applied"),
    ({"action": "set_mate", "mate": "no_such_mate", "effort": 1}, "no change applied"),
])
def test_a_round_without_progress_ends_the_rounds(tmp_path, reply, stop):
    host, stage, out = _run(tmp_path, _lamp(), [reply, {"action": "give_up", "reason": "unused"}])
    (row,) = stage.report["battery_fixer"]
    assert row["stop"].startswith(stop) and len(host.replies) == 1


def test_a_round_that_adds_failing_checks_is_undone(tmp_path):
    """Only B3 fails; the fixer widens the limits, so B2 fails too: the rounds end and the
    program before that edit ships (the finish rebuilds it)."""
    src = _lamp(limits="(-45, 45)").replace('limits=(-45, 45))', 'limits=(-45, 45), effort=5)')
    host, stage, out = _run(tmp_path, src, [
        {"action": "set_mate", "mate": "arm_pivot", "limits": [-80, 80]},
        {"action": "give_up", "reason": "unused"}])
    (row,) = stage.report["battery_fixer"]
    assert row["accepted"] and row["failing_after"] == ["B2", "B3"] and "undone" in row["stop"]
    assert out == src and stage.built_source != out
