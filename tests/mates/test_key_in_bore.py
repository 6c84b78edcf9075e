"""A key in a round bore (issue 23.6, the telescope run): the compiler's own 4 mm key gouged
0.134 mm into a 30 mm bore, and the message named neither the key nor where."""

from __future__ import annotations

from pathlib import Path

from procedura_brep.gates import check_model
from procedura_brep.program import compile_source

SRC = (Path(__file__).parent / "key_in_bore.py").read_text()


def _check(src: str, worker):
    model = compile_source(src, name="key_in_bore", worker=worker)
    assert model.ok, model.findings
    return check_model(model, src)


def test_a_key_in_a_bore_is_seated_without_gouging(worker):
    """The keyway reaches up through the crescent of bore that rises beside the tangent plane."""
    report = _check(SRC, worker)
    m = report.gate("mate").measured["tube_seat"]
    assert m["penetration_mm"] <= 0.01 and m["seated"], m
    assert not [f for f in report.findings if f.severity == "error"], report.findings


def test_a_gouge_names_the_mate_its_type_and_where(worker):
    """A tube 0.3 mm too big for its bore gouges: the finding names the mate and its type, the
    world point and each part's own coordinates and nearest face."""
    report = _check(SRC.replace("return Pos(0, 0, tube_r) * Rot(0, 90, 0) * Cylinder(tube_r, 120)",
                                "return Pos(0, 0, tube_r) * Rot(0, 90, 0) * Cylinder(tube_r + 0.3, 120)"),
                    worker)
    (f,) = [f for f in report.findings if f.code == "mate-penetration"]
    assert f.message.startswith("mate tube_seat (key): tube gouges into ring"), f.message
    assert "mm; there: tube at (" in f.message and "in its own coordinates" in f.message
    assert "ring at (" in f.message and "cylindrical face r 15" in f.message
