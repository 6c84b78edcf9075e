"""One map from a run's status to the exit code, used by build, generate and revise."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app
from procedura_brep.run import status as status_mod
from procedura_brep.run.status import EXIT_CODES, Status, exit_code

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"
TAPE = Path(__file__).parents[2] / "examples" / "tapes" / "lamp_oneshot.jsonl"


@pytest.mark.parametrize("status, compiled, code", [
    ("ok", True, 0), ("gates_failed", True, 1), ("battery_failed", True, 1), ("failed", True, 1),
    ("failed", False, 2), ("interrupted", True, 130), ("budget_exceeded", True, 1),
    (Status.OK, False, 0), ("gave_up", True, 1),  # an agent's own verdict: a failure
])
def test_exit_code_map(status, compiled, code):
    assert exit_code(status, compiled=compiled) == code


def test_every_status_has_an_exit_code_and_reads_as_its_value():
    assert set(EXIT_CODES) == set(Status)
    assert [str(s) for s in Status] == [s.value for s in Status]
    assert f"{Status.GATES_FAILED}" == "gates_failed" and Status("ok") is Status.OK


def test_build_exits_with_the_mapped_code(tmp_path, worker, monkeypatch):
    """The plant: the map says 7 for gates_failed; the CLI must exit 7 (it has no map of its own)."""
    monkeypatch.setitem(status_mod.EXIT_CODES, Status.GATES_FAILED, 7)
    lifted = tmp_path / "lifted.py"
    lifted.write_text(LAMP.read_text().replace("foot=Location((0, 0, 0))", "foot=Location((0, 0, -0.5))"))
    res = CliRunner().invoke(app, ["build", str(lifted), "-o", str(tmp_path / "o"), "--formats", "step", "-q"])
    assert res.exit_code == 7, res.output
    assert "post is not seated on base" in res.stderr


def test_generate_exits_with_the_mapped_code(tmp_path, worker, monkeypatch):
    monkeypatch.setitem(status_mod.EXIT_CODES, Status.OK, 5)
    res = CliRunner().invoke(app, ["generate", "--one-shot", "a desk lamp with a swinging arm", "-o",
                                   str(tmp_path / "run"), "--model", f"replay:{TAPE}", "--formats", "step",
                                   "-q"])
    assert res.exit_code == 5, res.output
