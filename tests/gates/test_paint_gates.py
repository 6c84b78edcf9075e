"""The gates treat a colour block as part of its painted part's body (issue 13, item 6): the
connectivity gate counts it attached, the interference gate does not flag the shared cut faces."""

from __future__ import annotations

import dataclasses

from procedura_brep.gates import check_model
from procedura_brep.gates.connectivity import analyse
from procedura_brep.gates.interference import scan
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledModel
from procedura_brep.testing.models import cpart

from ..program.painted import painted_lamp


def _box(x, y, z):
    from build123d import Align, Box
    return Box(x, y, z, align=(Align.MIN, Align.MIN, Align.MIN))


def _model(*parts):
    return CompiledModel(name="m", params={}, parts=list(parts), mates=[])


def test_the_painted_lamp_passes_every_gate(worker):
    from procedura_brep.program import compile_source
    model = compile_source(painted_lamp(), name="lamp", worker=worker)
    report = check_model(model)
    assert report.passed, [f.message for f in report.findings]
    assert report.gate("connectivity").measured["components"] == 1
    assert not scan(model)


def test_a_block_counts_as_attached_to_its_part():
    """Even where its mesh does not touch the part (a hand-made model), a block joins its
    part's component: the same geometry as an ordinary part is a floater."""
    body = cpart("body", _box(100, 50, 50))
    panel = cpart("panel", _box(70, 50, 2), trans(15, 0, 60))
    assert analyse(_model(body, panel)).n_vis == 1
    block = dataclasses.replace(panel, block_of="body")
    conn = analyse(_model(body, block))
    assert conn.n_vis == 0 and len(conn.components) == 1


def test_a_block_and_its_part_are_not_an_interfering_pair():
    body = cpart("body", _box(100, 50, 50))
    inside = cpart("inside", _box(20, 20, 20), trans(10, 10, 10))
    assert [(r.a, r.b) for r in scan(_model(body, inside))] == [("body", "inside")]
    assert scan(_model(body, dataclasses.replace(inside, block_of="body"))) == []
    other = cpart("other", _box(20, 20, 20), trans(10, 10, 10))
    # two blocks of one part do not interfere with each other either; with a third part they do
    pair = [dataclasses.replace(inside, block_of="body"), dataclasses.replace(other, block_of="body")]
    assert scan(_model(body, *pair)) == []
    assert scan(_model(body, pair[0], other)) != []
