"""report.json records every part's solved placement; a part drawn at its assembly position is a
warning in a build, never a failure."""

from __future__ import annotations

import json

import numpy as np

from procedura_brep.run.build import build
from procedura_brep.testing.models import compiled
from procedura_brep.testing.placed import BLOCK, block_on_base


def _report(tmp_path, source: str, name: str) -> dict:
    program = tmp_path / f"{name}.py"
    program.write_text(source)
    result = build(program, tmp_path / name, formats=("step",))
    assert result.ok, result.reason
    return json.loads((tmp_path / name / "report.json").read_text())


def test_every_part_row_carries_its_solved_placement(tmp_path, worker):
    source = block_on_base(world=False)
    report = _report(tmp_path, source, "local")
    model = compiled(source, worker=worker)
    rows = {r["name"]: r for r in report["parts"]}
    assert list(rows) == [p.name for p in model.parts] == ["base", "block"]
    for p in model.parts:
        placement = rows[p.name]["placement"]
        assert len(placement) == 4 and all(len(row) == 4 for row in placement)  # row-major 4x4
        np.testing.assert_allclose(placement, p.placement, atol=1e-12)
    np.testing.assert_allclose(rows["base"]["placement"], np.eye(4), atol=1e-12)  # the root
    np.testing.assert_allclose(np.asarray(rows["block"]["placement"])[:3, 3], [0, 300 + BLOCK / 2, 0])


def test_a_part_drawn_in_world_coordinates_is_a_warning_in_a_build(tmp_path):
    report = _report(tmp_path, block_on_base(world=True), "world")
    assert report["status"] == "ok" and report["gates"]["passed"]
    (f,) = [f for f in report["gates"]["findings"] if f["code"] == "part-origin"]
    assert f["severity"] == "warning" and f["part"] == "block"
    rows = {r["name"]: r for r in report["parts"]}
    np.testing.assert_allclose(rows["block"]["placement"], np.eye(4), atol=1e-12)  # the solver agreed
