from __future__ import annotations

import json

import pytest

from procedura_brep.gates.check import check_model
from procedura_brep.gates.metrics import mesh_metrics
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledModel
from procedura_brep.testing.models import cpart


def _one(shape, name="box"):
    return CompiledModel(name="m", params={}, parts=[cpart(name, shape)], mates=[])


def test_box_sharp_length_and_dihedral():
    from build123d import Box
    m = mesh_metrics(_one(Box(100, 60, 10)))
    assert m["shrp60_mm"] == pytest.approx(680.0, abs=1e-6)  # 4 * (100 + 60 + 10)
    assert m["shrp60_per_span"] == pytest.approx(6.8, abs=1e-6)
    assert m["dih95_deg"] == pytest.approx(90.0, abs=1e-6)
    assert m["triangles_per_part"] == {"box": 12} and m["components"] == 1 and m["n_vis"] == 0


def test_filleted_box_has_no_sharp_edges():
    from build123d import Box, fillet
    b = Box(100, 60, 10)
    b = fillet(b.edges(), radius=3)
    m = mesh_metrics(_one(b))
    assert m["shrp60_mm"] == 0.0
    assert 0.0 < m["dih95_deg"] < 60.0
    assert m["mesh_pieces"] == 1 and m["triangles"] > 12


def test_triangles_per_part_and_components():
    from build123d import Align, Box
    a = cpart("a", Box(10, 10, 10, align=(Align.MIN,) * 3))
    b = cpart("b", Box(10, 10, 10, align=(Align.MIN,) * 3), trans(30, 0, 0))
    m = mesh_metrics(CompiledModel(name="m", params={}, parts=[a, b], mates=[]))
    assert m["triangles_per_part"] == {"a": 12, "b": 12}
    assert m["components"] == 2 and m["n_vis"] == 1


def test_check_model_report_is_json(make_peg):
    src = "\n".join(f"line {i}" for i in range(1, 20))
    report = check_model(make_peg(10.0, lift=0.5), src)
    d = json.loads(json.dumps(report.as_dict()))
    assert d["passed"] is False
    assert d["verdicts"] == {"compile": True, "mate": False, "pieces": True, "interference": True,
                             "connectivity": True, "origin": True, "coupling": True}
    assert d["n_vis"] == 0  # the peg still touches the socket walls (fit clearance = contact)
    mate = d["mates"]["post_on_base"]
    assert mate["area_mm2"] == 0.0 and mate["area_limit_mm2"] == pytest.approx(5.0)
    assert set(d["triangles_per_part"]) == {"base", "post"}
    assert "> 12 | line 12" in d["feedback"]
    ok = check_model(make_peg(10.0)).as_dict()
    assert ok["passed"] and ok["n_vis"] == 0 and ok["findings"] == []
