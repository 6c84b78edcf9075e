"""``@paint``: colour blocks cut from a part at compile (issue 13, item 6).

Volumes are measured on the compiled solids and compared with what the region must take from
the arm (``Box(90, 14, 10)``, see :mod:`tests.program.painted`).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.program import compile_source
from procedura_brep.program.model import to_json
from procedura_brep.program.sandbox import Worker
from procedura_brep.program.trust import model_from_json as from_json

from .painted import ARM_SECTION, LAMP, paint_decl, painted_lamp, tip_region


def vol(part) -> float:
    return kernel.volume(part.local_shape())


@pytest.fixture(scope="module")
def plain(worker):
    return compile_source(LAMP, name="lamp", worker=worker)


@pytest.fixture(scope="module")
def painted(worker):
    return compile_source(painted_lamp(), name="lamp", worker=worker)


def test_a_block_is_a_part_of_the_model_cut_from_its_part(plain, painted):
    assert painted.ok, [f.message for f in painted.findings]
    assert [p.name for p in painted.parts] == ["base", "post", "arm", "arm_tip"]
    arm, tip = painted.part("arm"), painted.part("arm_tip")
    assert tip.block_of == "arm" and arm.block_of == "" and tip.owner == "arm"
    assert tip.material == "rubber" and arm.material == "painted_aluminium"
    assert tip.detail == arm.detail and "arm" in tip.description
    assert np.array_equal(tip.placement, arm.placement) and tip.frames == {}
    assert vol(tip) == pytest.approx(20 * ARM_SECTION, rel=1e-9)
    assert vol(arm) + vol(tip) == pytest.approx(vol(plain.part("arm")), rel=1e-9)
    # the unpainted solid rides along for the cache and equals the plain compile's arm
    assert arm.unpainted and kernel.volume(kernel.read_brep(arm.unpainted)) == pytest.approx(
        vol(plain.part("arm")), rel=1e-12)
    for name in ("base", "post"):
        assert painted.part(name).digest == plain.part(name).digest


def test_several_blocks_are_cut_in_program_order(worker):
    model = compile_source(painted_lamp(paint_decl("arm_tip", tip_region(70)),
                                        paint_decl("arm_band", tip_region(50), material="brass")),
                           name="lamp", worker=worker)
    assert model.ok, [f.message for f in model.findings]
    # the band's region reaches the tip too, but the tip was already cut: the band is 50..70
    assert vol(model.part("arm_tip")) == pytest.approx(20 * ARM_SECTION, rel=1e-9)
    assert vol(model.part("arm_band")) == pytest.approx(20 * ARM_SECTION, rel=1e-9)
    whole = kernel.volume(kernel.read_brep(model.part("arm").unpainted))
    assert vol(model.part("arm")) == pytest.approx(whole - 40 * ARM_SECTION, rel=1e-9)


@pytest.mark.parametrize("decl, words", [
    (paint_decl("arm_tip", "Pos(500, 0, 0) * Box(10, 10, 10)"), "misses the part"),
    (paint_decl("arm_tip", "Box(500, 500, 500)"), "covers the whole part"),
    (paint_decl("arm_tip", tip_region(), part="lever"), "no part named 'lever'"),
    (paint_decl("arm_tip", tip_region(), material="unobtainium"), "unknown material 'unobtainium'"),
    (paint_decl("post", tip_region()), "also a part's"),
    (paint_decl("arm_tip", "1 / 0"), "ZeroDivisionError"),
    (paint_decl("arm_tip", "42"), "must return a build123d solid"),
    # the arm's pivot pin (the revolute's male half) stands at x = 7
    (paint_decl("arm_tip", "Box(30, 60, 60)"), "reaches into mate arm_pivot's feature"),
])
def test_a_bad_block_is_a_finding_naming_it(worker, decl, words):
    model = compile_source(painted_lamp(decl), name="lamp", worker=worker)
    bad = [f for f in model.findings if f.code == "paint"]
    assert not model.ok and len(bad) == 1, [f.message for f in model.findings]
    name = "post" if "also a part" in words else "arm_tip"
    assert bad[0].part == name and f"block {name}" in bad[0].message and words in bad[0].message
    assert "arm_tip" not in [p.name for p in model.parts]
    assert "arm" in [p.name for p in model.parts]


def test_a_block_name_must_be_unique_and_snake_case(worker):
    twice = compile_source(painted_lamp(paint_decl("arm_tip", tip_region(70)),
                                        paint_decl("arm_tip", tip_region(50))), name="lamp", worker=worker)
    assert any("painted twice" in f.message for f in twice.findings) and not twice.ok


def test_volume_conservation_is_checked(monkeypatch):
    """The check is measured, not assumed: with a negative tolerance no cut can pass it (run in
    this process, so the patched limit applies)."""
    from procedura_brep.program import blocks, runtime
    monkeypatch.setattr(blocks, "MATERIAL", dataclasses.replace(blocks.MATERIAL, paint_volume_rtol=-1.0))
    model = runtime.compile_program(painted_lamp(), name="lamp")
    rows = [f for f in model.findings if f.code == "paint-volume"]
    assert len(rows) == 1 and rows[0].part == "arm_tip" and "unpainted" in rows[0].message
    assert rows[0].value is not None and rows[0].value < 1e-6  # the measured error is tiny


def test_blocks_survive_the_sandbox_json_boundary(painted):
    back = from_json(json.loads(json.dumps(to_json(painted))))
    assert [(p.name, p.block_of, p.material) for p in back.parts] == \
        [(p.name, p.block_of, p.material) for p in painted.parts]
    assert back.part("arm").unpainted == painted.part("arm").unpainted


def test_the_parent_refuses_a_block_of_an_unknown_part(painted):
    from procedura_brep.program.trust import ResultError
    bad = json.loads(json.dumps(to_json(painted)))
    bad["parts"][3]["block_of"] = "lever"
    with pytest.raises(ResultError, match="block_of"):
        from_json(bad)


def test_a_changed_region_recompiles_the_paint_not_the_part(tmp_path):
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        a = w.compile(painted_lamp())
        b = w.compile(painted_lamp(paint_decl("arm_tip", tip_region(60))))
        assert b.timings["cache_hits"] == 3  # the unpainted arm came from the cache
        assert vol(b.part("arm_tip")) == pytest.approx(30 * ARM_SECTION, rel=1e-9)
        assert vol(a.part("arm")) - vol(b.part("arm")) == pytest.approx(10 * ARM_SECTION, rel=1e-6)
        again = w.compile(painted_lamp())
        # a cold compile and a cache hit cut the same bytes (the materials stage compares digests)
        assert again.part("arm").digest == a.part("arm").digest
        assert again.part("arm_tip").digest == a.part("arm_tip").digest
        assert vol(again.part("arm_tip")) == pytest.approx(20 * ARM_SECTION, rel=1e-9)
        unpainted = w.compile(LAMP)
        assert vol(unpainted.part("arm")) == pytest.approx(vol(a.part("arm")) + 20 * ARM_SECTION, rel=1e-9)
    finally:
        w.close()


def test_a_block_of_several_pieces_is_written_the_same_every_time():
    """Issue 23.6: a region of two boxes (side windows) cut blocks whose solids OCCT returned in
    either order, so the block's digest changed from one compile to the next and a later paint
    of another part was refused ("the splice changed the shape of cab_glass_sides")."""
    from build123d import Box, Compound, Pos

    from procedura_brep import kernel
    from procedura_brep.program.blocks import _canonical

    a, b = Pos(0, 0, 0) * Box(10, 1, 5), Pos(0, 20, 0) * Box(10, 1, 5)
    one, two = _canonical(Compound([a, b])), _canonical(Compound([b, a]))
    assert kernel.write_brep(one.wrapped) == kernel.write_brep(two.wrapped)
