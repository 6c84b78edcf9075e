"""The MuJoCo battery on a lamp whose arm tip is a colour block: the block is a visual and
collision geom of the arm's body, moves with it through the sweep, and every check passes."""

from __future__ import annotations

from procedura_brep.sim import run_battery

from ..program.painted import painted_lamp


def test_a_painted_lamp_passes_every_check(worker, tmp_path):
    from procedura_brep.program import compile_source
    model = compile_source(painted_lamp(), name="lamp", worker=worker)
    assert "arm_tip" in [p.name for p in model.parts]
    report = run_battery(model, out_dir=tmp_path)
    assert report.passed, [c.message for c in report.checks if not c.passed]
    assert report.check("B0").measured["bodies"] == 2  # base and arm: no body for the block
