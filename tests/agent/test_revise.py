"""`revise`: a person's change request through diagnosed, gated edits on the named parts only."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from procedura_brep.agent.revise import ReviseError, revise
from procedura_brep.run.build import build

ROOT = Path(__file__).parents[1]
TAPE = ROOT / "tapes" / "lamp_revise.jsonl"
LAMP = ROOT / "program" / "lamp.py"


def segments(source: str) -> dict[str, str]:
    """Each part's function, frames and own mates, as text."""
    tree = ast.parse(source)
    out: dict[str, list[str]] = {}
    for stmt in tree.body:
        seg = ast.get_source_segment(source, stmt) or ""
        if isinstance(stmt, ast.FunctionDef):
            out.setdefault(stmt.name, []).append(seg)
        elif isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Call) and stmt.value.args:
            first = stmt.value.args[0]
            if isinstance(first, ast.Constant) and isinstance(first.value, str):
                out.setdefault(first.value.split(".")[0], []).append(seg)
    return {k: "\n".join(v) for k, v in out.items()}


def test_revise_edits_only_the_named_part(tmp_path):
    out = tmp_path / "lamp"
    assert build(LAMP, out).ok
    before = (out / "program.py").read_text()
    result = revise(out, "make the arm 120 mm long", model=f"replay:{TAPE}", parts=["arm"], simulate=False)
    assert result.status == "ok", result.report
    after = (out / "program.py").read_text()
    assert "arm_l = 120.0" in after and "Box(arm_l, 14, 10" in after
    old, new = segments(before), segments(after)
    for part in ("base", "post"):
        assert new[part] == old[part], part  # every other part's source is unchanged
    assert new["arm"] != old["arm"]
    refused = result.report["refused"]
    assert any("may touch only arm, not post" in r for r in refused), refused
    lines = (out / "history" / "revisions.jsonl").read_text().splitlines()
    assert json.loads(lines[-1])["instruction"] == "make the arm 120 mm long"
    report = json.loads((out / "report.json").read_text())
    assert report["revisions"][-1]["edits"] == 1 and report["status"] == "ok"
    assert list((out / "history").glob("*-revise-edit_part.py"))


def test_revise_refuses_bad_requests(tmp_path):
    with pytest.raises(ReviseError, match="no program.py"):
        revise(tmp_path, "bigger", model=f"replay:{TAPE}")
    out = tmp_path / "lamp"
    out.mkdir()
    (out / "program.py").write_text(LAMP.read_text())
    with pytest.raises(ReviseError, match="--part wheel: not a part; parts: base, post, arm"):
        revise(out, "bigger", model=f"replay:{TAPE}", parts=["wheel"])
    with pytest.raises(ReviseError, match="empty"):
        revise(out, "  ", model=f"replay:{TAPE}")


def _requests(out: Path) -> list[dict]:
    return [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines() if x.strip()]


def test_revise_request_states_the_five_block_format(tmp_path):
    out = tmp_path / "lamp"
    assert build(LAMP, out).ok
    revise(out, "make the arm 120 mm long", model=f"replay:{TAPE}", parts=["arm"], simulate=False)
    first = json.dumps(_requests(out)[0])
    for block in ("## params", "## helpers", "## body", "## frames", "## mates", "Reply with five blocks"):
        assert block in first, block


def test_revise_stops_at_its_call_bound_keeping_the_edit_it_made(tmp_path):
    """The tape's 7th call applies the arm edit; with 7 calls allowed the revise stops at the
    8th, with the edit already in program.py (written when it was applied) and rebuilt."""
    out = tmp_path / "lamp"
    assert build(LAMP, out).ok
    seven = tmp_path / "seven.jsonl"  # the calls the bound lets through, so the tape is consumed
    seven.write_text("".join(TAPE.read_text().splitlines(keepends=True)[:7]))
    result = revise(out, "make the arm 120 mm long", model=f"replay:{seven}", parts=["arm"],
                    simulate=False, max_calls=7)
    assert result.status == "calls" and result.report["calls"] == 7
    assert "7 model calls are spent" in result.report["reason"]
    assert result.report["edits"] == 1 and result.report["changed"]
    assert "arm_l = 120.0" in (out / "program.py").read_text()
    assert result.build is not None and result.build.ok
    assert len(_requests(out)) == 7


def test_an_applied_edit_is_in_program_py_before_the_revise_ends(tmp_path):
    """A provider that dies after the edit (the tape ends at call 8) leaves the edit on disk."""
    out = tmp_path / "lamp"
    assert build(LAMP, out).ok
    short = tmp_path / "short.jsonl"
    short.write_text("".join(TAPE.read_text().splitlines(keepends=True)[:7]))
    from procedura_brep.llm import LLMError
    with pytest.raises(LLMError):
        revise(out, "make the arm 120 mm long", model=f"replay:{short}", parts=["arm"], simulate=False)
    assert "arm_l = 120.0" in (out / "program.py").read_text()
