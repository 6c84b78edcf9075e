"""report.json's ``masses`` section and summary.md's mass table (issue 26.5): per part mass,
method, centre of mass and inertia (world, SI), and the total, from the build's limited child."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.run.build import build
from procedura_brep.run.report import masses_md

LAMP = (Path(__file__).parents[1] / "program" / "lamp.py").read_text()


def lamp(arm: str = "mass=0.6, ", base: str = "hollow=2.0, ") -> str:
    return (LAMP.replace('material="painted_aluminium", ', f'material="painted_aluminium", {arm}')
            .replace('material="cast_iron", ', f'material="cast_iron", {base}'))


def test_a_build_reports_every_part_s_mass_and_the_total(tmp_path):
    out = tmp_path / "lamp"
    res = build(Path("lamp.py"), out, source=lamp(), formats=("step",), gates=False)
    assert res.ok, res.reason
    report = json.loads((out / "report.json").read_text())
    masses = report["masses"]
    rows = {r["name"]: r for r in masses["parts"]}
    assert list(rows) == ["base", "post", "arm"]
    assert (rows["arm"]["method"], rows["arm"]["mass_kg"], rows["arm"]["declared_kg"]) == ("declared", 0.6, 0.6)
    assert rows["base"]["method"] in ("shell-exact", "shell-approx") and rows["base"]["hollow_mm"] == 2.0
    assert rows["post"]["method"] == "solid" and rows["post"]["density_kg_m3"] == 7850
    for r in rows.values():
        assert len(r["com_m"]) == 3 and len(r["inertia_kg_m2"]) == 3
        i = np.array(r["inertia_kg_m2"])
        assert np.allclose(i, i.T, rtol=1e-9, atol=1e-15) and np.all(np.linalg.eigvalsh(i) > 0)
    total = masses["total"]
    assert total["mass_kg"] == pytest.approx(sum(r["mass_kg"] for r in rows.values()), rel=1e-12)
    com = [sum(r["mass_kg"] * r["com_m"][k] for r in rows.values()) / total["mass_kg"] for k in range(3)]
    assert total["com_m"] == pytest.approx(com, abs=1e-12)
    assert "masses_s" in report["timings"]
    text = (out / "summary.md").read_text()
    assert "## Masses" in text and "| arm | declared | 0.6 |" in text
    assert f"| total | | {total['mass_kg']:.4g} |" in text


def test_a_wall_too_thick_is_a_warning_in_the_report(tmp_path):
    out = tmp_path / "lamp"
    res = build(Path("lamp.py"), out, source=lamp(arm="hollow=6.0, ", base=""), formats=("step",),
                gates=False)
    assert res.ok, res.reason  # a warning: the arm is weighed solid
    report = json.loads((out / "report.json").read_text())
    found = [f for f in report["findings"] if f["code"] == "part-hollow"]
    assert len(found) == 1 and found[0]["part"] == "arm" and found[0]["severity"] == "warning"
    assert "hollow=6 mm is not less than the part's mean half-thickness" in found[0]["message"]
    arm = next(r for r in report["masses"]["parts"] if r["name"] == "arm")
    assert arm["method"] == "solid" and arm["note"] in found[0]["message"]


def test_weighing_hollow_parts_is_a_progress_step(tmp_path):
    lines: list[str] = []
    res = build(Path("lamp.py"), tmp_path / "lamp", source=lamp(), formats=("step",), gates=False,
                progress=lines.append)
    assert res.ok, res.reason
    # the parent announces the export, the child weighs first and then says it goes on
    assert lines[:4] == ["compiling lamp", "writing 3 parts as step, viewer",
                         "weighing 1 hollow part(s) as shells", "writing 3 parts as step, viewer"], lines


def test_no_masses_no_table():
    assert masses_md(None) == [] and masses_md({"parts": []}) == []
