"""`revise`: a person's change request through diagnosed, gated edits on the named parts only."""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from procedura_brep.agent.revise import ReviseError, revise
from procedura_brep.pipeline import build

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
