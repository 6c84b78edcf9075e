"""The staged run as data (issue 25.4): one table of stages drives the run and --resume."""

from __future__ import annotations

import json

import pytest

from procedura_brep.agent import stages
from procedura_brep.agent.runstate import ResumeError, RunDir, RunState
from procedura_brep.agent.staged import StagedRun


def test_every_row_names_a_method_of_the_run_and_the_run_ends_done():
    assert stages.STAGE_NAMES[-1] == "done" and stages.STAGE_NAMES[0] == "plan"
    for row in stages.STAGES:
        assert callable(getattr(StagedRun, row.method)), row
        assert row.reads and row.writes
    assert stages.next_stage("refine") == "materials" and stages.next_stage("finish") == "done"


class _Run:
    """Just what StagedRun.run uses: the state, the out dir, the stage methods, advance, finish."""

    def __init__(self, tmp_path, stage):
        self.out_dir, self.state, self.ran = tmp_path, RunState("p", stage=stage), []

    def __getattr__(self, name):
        if name.startswith("stage_"):
            return lambda: self.ran.append(name[6:]) or ("result" if name == "stage_finish" else None)
        raise AttributeError(name)

    def _advance(self, stage):
        self.state.stage = stage

    def _finish(self, status, message=""):
        return status


def test_a_run_follows_the_table_from_its_stage_and_a_new_row_is_one_entry(tmp_path, monkeypatch):
    run = _Run(tmp_path, "materials")  # a resumed run: the earlier rows are done
    assert StagedRun.run(run) == "result" and run.ran == ["materials", "articulation", "finish"]
    rows = list(stages.STAGES)
    rows.insert(rows.index(next(r for r in rows if r.name == "refine")) + 1,
                stages.Stage("lint", "stage_lint", "state.source", "nothing"))
    monkeypatch.setattr(stages, "STAGES", tuple(rows))
    monkeypatch.setattr(stages, "STAGE_NAMES", (*(r.name for r in rows), "done"))
    import procedura_brep.agent.staged as staged
    monkeypatch.setattr(staged, "STAGES", tuple(rows))
    run = _Run(tmp_path, "refine")
    StagedRun.run(run)
    assert run.ran == ["refine", "lint", "materials", "articulation", "finish"]


def test_resume_refuses_a_stage_the_table_does_not_have(tmp_path):
    rd = RunDir(tmp_path)
    rd.save(RunState("p", stage="build"))
    assert rd.load().stage == "build"
    data = json.loads(rd.state_path.read_text())
    data["stage"] = "polish"
    rd.state_path.write_text(json.dumps(data))
    with pytest.raises(ResumeError, match="stage 'polish'"):
        rd.load()


def test_history_numbers_are_unique_across_stages(tmp_path):
    """Issue 26.3: two history entries shared the number 029 (the articulation stage counted
    from the commits and refine's edits, not past the materials stage's entries)."""
    from procedura_brep.agent.runstate import history_path
    (tmp_path / "history").mkdir()
    for name in ("001-base.py", "002-post.py", "002-post.attempt-1.txt", "003-refine-edit_part.py",
                 "004-materials-library.py", "revisions.jsonl"):
        (tmp_path / "history" / name).write_text("x")
    assert history_path(tmp_path, "articulation-arm_pivot").name == "005-articulation-arm_pivot.py"
    assert history_path(tmp_path / "new", "refine-set_param").name == "001-refine-set_param.py"
