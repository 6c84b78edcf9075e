"""sheet.png: the picture every run directory carries (issue 26, item 3)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from procedura_brep.cli import app
from procedura_brep.run import steps
from procedura_brep.run.build import build

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"
TILE = steps.SHEET_SIZE
PAD, LABEL, HEAD = 6, 16, 24  # render.compose.contact_sheet's layout


def _tiles(img: Image.Image) -> list[np.ndarray]:
    """The seven view tiles of a sheet (three columns), as arrays."""
    a = np.asarray(img.convert("RGB"))
    out = []
    for i in range(len(steps.SHEET_VIEWS)):
        x = PAD + (i % 3) * (TILE + PAD)
        y = HEAD + (i // 3) * (TILE + LABEL + PAD) + LABEL
        out.append(a[y:y + TILE, x:x + TILE])
    return out


@pytest.mark.slow
def test_every_build_writes_a_sheet_of_seven_drawn_views(tmp_path, worker):
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["build", str(LAMP), "-o", str(out), "-q"])
    assert res.exit_code == 0, res.output
    sheet = out / "sheet.png"
    assert sheet.is_file()
    # the last line names the run dir, the status, the time and the sheet
    last = res.stdout.strip().splitlines()[-1]
    assert str(out) in last and "status ok" in last and f"sheet {sheet}" in last and " s," in last
    img = Image.open(sheet)
    assert img.size[0] > 3 * (TILE + PAD) and img.size[1] == HEAD + 3 * (TILE + LABEL + PAD) + PAD
    for name, tile in zip(steps.SHEET_VIEWS, _tiles(img)):
        # every tile shows the model: a good share of it differs from the background corner
        shown = np.any(np.abs(tile.astype(int) - tile[2, 2].astype(int)) > 8, axis=2).mean()
        assert shown > 0.03, (name, shown)
    summary = (out / "summary.md").read_text()
    assert "![the model: six views and an iso](sheet.png)" in summary and "`sheet.png`" in summary


@pytest.mark.slow
def test_a_parent_holding_gl_draws_the_sheet_itself(tmp_path, worker, monkeypatch):
    """A process that holds a GL context (the staged agent renders in-process) cannot let a
    forked child draw: the build's parent draws sheet.png after the child's exports."""
    drawn: list[str] = []
    real = steps.sheet

    def spy(model, root, **kw):
        drawn.append(str(root))
        return real(model, root, **kw)

    monkeypatch.setattr(steps, "gl_in_use", lambda: True)
    monkeypatch.setattr(steps, "sheet", spy)
    res = build(LAMP, tmp_path / "run", formats=("step",), progress=None)
    assert res.ok and (tmp_path / "run" / "sheet.png").is_file()
    assert len(drawn) == 1  # in this process (the child's calls are not seen by this spy)
    assert res.report["timings"]["sheet_s"] > 0
