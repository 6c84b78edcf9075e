"""summary.md (issue 26.3): a run directory a person can read at a glance, after a build that
passed, one that failed, and a staged run (which adds what was asked)."""

from __future__ import annotations

from pathlib import Path

from procedura_brep.run.build import build

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"


def test_a_build_writes_a_summary_of_its_report(tmp_path):
    out = tmp_path / "lamp"
    assert build(LAMP, out).ok
    text = (out / "summary.md").read_text()
    assert text.startswith("# lamp: ok")
    for row in ("| arm | painted_aluminium |", "| arm_pivot | revolute | arm | post |",
                "## Findings\n\nnone", "- `model.step`: STEP", "## Timings", "- total: "):
        assert row in text, row


def test_a_failed_build_s_summary_says_why(tmp_path):
    out = tmp_path / "lamp"
    src = LAMP.read_text().replace("return Box(90,", "return Box(1 / 0,")
    res = build(LAMP, out, source=src)
    assert not res.ok
    text = (out / "summary.md").read_text()
    assert text.startswith("# lamp: failed") and "part-exception: part arm: ZeroDivisionError" in text
    assert "- `program.py`" in text and "model.step" not in text
