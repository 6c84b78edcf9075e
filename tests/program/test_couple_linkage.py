"""``couple(..., "linkage", closes=...)``: a loop cut at a second mate, checked at compile (the
cut is a revolute or spherical mate that closes a loop, and its anchors meet at the compiled
pose), and its articulation (the cut left out of the tree, the loop's joints passive)."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep.articulation import articulate

SRC = (Path(__file__).parent / "fourbar.py").read_text()
LINK = 'couple("rocker_base", "crank_base", "linkage", closes="loop_pin")'


def _errors(model) -> list[str]:
    return [f.message for f in model.findings if f.severity == "error"]


def test_a_four_bar_compiles_and_articulates_as_a_tree_with_a_cut(worker):
    m = worker.compile(SRC)
    assert not _errors(m)
    (c,) = m.couplings
    assert (c.type, c.closes, c.ratio, c.mesh) == ("linkage", "loop_pin", 0.0, ("coupler", "rocker"))
    art = articulate(m)
    assert [j.name for j in art.joints] == ["crank_base", "rocker_base", "coupler_b_end"]
    (cut,) = art.cuts
    assert (cut.name, cut.parent, cut.child) == ("loop_pin", "rocker", "coupler")
    assert cut.anchor_m == pytest.approx([0.21, 0.09, 0.008])
    # every loop joint but the driver follows the loop
    assert {j.name: j.coupling.driver if j.coupling else None for j in art.joints} == {
        "crank_base": None, "rocker_base": "crank_base", "coupler_b_end": "crank_base"}


@pytest.mark.parametrize("edit, expected", [
    (lambda s: s.replace('d_pivot=Location((50 + span, 0, 0))', 'd_pivot=Location((55 + span, 0, 0))'),
     "mate loop_pin: the loop it closes does not meet at the compiled pose: its two anchors are 5 mm apart"),
    (lambda s: s.replace(LINK, ""),
     "mate loop_pin: 'coupler' is already placed; a kinematic mate may not close a loop (unless a "
     "couple(..., \"linkage\", closes=\"loop_pin\") names it"),
    (lambda s: s.replace('closes="loop_pin"', 'closes="coupler_b_end"'),
     "closes='coupler_b_end': that mate places coupler, so it closes no loop"),
    (lambda s: s.replace('closes="loop_pin"', 'closes="loop_pn"'),
     "closes='loop_pn' is not a mate of the program (did you mean 'loop_pin'?)"),
    (lambda s: s.replace(LINK, 'couple("rocker_base", "crank_base", "linkage")'),
     "linkage needs closes='<mate>'"),
])
def test_a_bad_linkage_is_one_line(worker, edit, expected):
    errors = _errors(worker.compile(edit(SRC)))
    assert any(expected in e for e in errors), errors
