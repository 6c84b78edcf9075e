"""``male="parent"``: the male half goes on the parent and the female is cut from the child
(a pulley on a shaft, a nut on a rod), so the parent is not cut."""

from __future__ import annotations

import pytest

from procedura_brep import kernel

from .progs import program

RAW_BASE = 160 * 160 * 40.0  # the parent's raw volume, mm^3 (progs.TEMPLATE)
RAW_BLOCK = 90 * 90 * 30.0  # the child's


def _build(worker, src: str):
    from procedura_brep.program.sandbox import CompileOptions
    m = worker.compile(src, CompileOptions(name="t"))
    assert m.ok, [f.as_dict() for f in m.findings]
    return m


def _volumes(m) -> tuple[float, float]:
    return (kernel.volume(m.part("base").local_shape()), kernel.volume(m.part("block").local_shape()))


@pytest.mark.parametrize("mtype, nominal, fit, options", [
    ("peg_socket", 10.0, "location", ""),
    ("revolute", 10.0, "clearance", ", limits=(-45, 90)"),
    ("prismatic", 12.0, "clearance", ", limits=(-5, 20)"),
])
def test_male_on_the_parent_cuts_the_child_not_the_parent(worker, mtype, nominal, fit, options):
    default = _volumes(_build(worker, program(mtype, nominal, fit, options)))
    flipped = _volumes(_build(worker, program(mtype, nominal, fit, options + ', male="parent"')))
    assert default[0] < RAW_BASE - 1e-3 and default[1] > RAW_BLOCK + 1e-3  # socket in the base
    assert flipped[0] > RAW_BASE + 1e-3 and flipped[1] < RAW_BLOCK - 1e-3  # peg on the base
    # the same features, on the other sides: what the parent lost the child now loses
    assert flipped[1] == pytest.approx(RAW_BLOCK - (RAW_BASE - default[0]), rel=1e-6)
    assert flipped[0] == pytest.approx(RAW_BASE + (default[1] - RAW_BLOCK), rel=1e-6)


def test_male_on_the_parent_passes_the_mate_gate(worker):
    from procedura_brep.gates.check import check_model
    src = program("peg_socket", 10.0, "location", ', male="parent"')
    report = check_model(_build(worker, src), src)
    mate_gate = next(g for g in report.gates if g.gate == "mate")
    assert mate_gate.passed, report.feedback


def test_male_side_must_be_child_or_parent(worker):
    from procedura_brep.program.sandbox import CompileOptions
    m = worker.compile(program("peg_socket", 10.0, "location", ', male="shaft"'), CompileOptions())
    assert not m.ok
    assert any("option male = 'shaft' must be one of: child, parent" in f.message for f in m.findings)
