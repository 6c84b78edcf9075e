"""The origin gate: a part drawn at its assembly position gets a ``part-origin`` warning."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.gates import check_model
from procedura_brep.gates.origin import CODE, FIX, origin_gate
from procedura_brep.testing.models import compiled, cpart
from procedura_brep.testing.placed import BLOCK, block_on_base
from procedura_brep.testing.programs import program_text


def _world_boxes(model) -> dict[str, np.ndarray]:
    return {p.name: np.array(kernel.bbox(p.shape())) for p in model.parts}


def _origin(findings) -> list:
    return [f for f in findings if f.code == CODE]


def test_world_coordinates_trip_it_and_the_same_assembly_around_its_origins_does_not(worker):
    world_src, local_src = block_on_base(world=True), block_on_base(world=False)
    world, local = compiled(world_src, worker=worker), compiled(local_src, worker=worker)
    # the same placed geometry: only the structure differs
    wb, lb = _world_boxes(world), _world_boxes(local)
    assert wb.keys() == lb.keys() == {"base", "block"}
    for name in wb:
        np.testing.assert_allclose(wb[name], lb[name], atol=1e-6)
    np.testing.assert_allclose(world.part("block").placement, np.eye(4), atol=1e-12)  # the solver agreed
    np.testing.assert_allclose(local.part("block").placement[:3, 3], [0, 300 + BLOCK / 2, 0], atol=1e-9)

    w_report, l_report = check_model(world, world_src), check_model(local, local_src)
    assert w_report.passed and l_report.passed  # a warning: the program is valid
    assert _origin(l_report.findings) == []
    (f,) = _origin(w_report.findings)
    assert f.severity == "warning" and f.part == "block" and f.mate == "block_foot"
    assert f.value == pytest.approx(300.0, abs=1e-3)  # the block's near face is 300 mm away
    assert f.limit == pytest.approx(BLOCK + 5.0)  # its largest side: 40 mm + the 5 mm peg
    assert "block.foot" in f.message and "(0.0, 320.0, 0.0) mm" in f.message
    assert "by (0.0, -320.0, 0.0) mm" in f.message and FIX in f.message.lower()
    assert "[warning] part-origin: part block, mate block_foot" in w_report.feedback
    measured = w_report.as_dict()["origin"]
    assert set(measured["parts"]) == {"block"} and l_report.as_dict()["origin"]["parts"] == {}
    assert measured["parts"]["block"]["frame_origin_mm"] == [0.0, 320.0, 0.0]
    assert w_report.as_dict()["verdicts"]["origin"] is True


def test_the_limit_is_the_part_s_own_size(worker):
    """A block drawn less than its own size from its origin passes; just beyond, it trips."""
    size = BLOCK + 5.0
    near = compiled(block_on_base(world=True, offset=size - 1.0), worker=worker)
    far = compiled(block_on_base(world=True, offset=size + 1.0), worker=worker)
    assert _origin(origin_gate(near)[0]) == []
    (f,) = _origin(origin_gate(far)[0])
    assert f.value == pytest.approx(size + 1.0, abs=1e-3) and f.limit == pytest.approx(size)


def test_a_long_arm_with_its_pivot_frame_at_one_end_never_trips(worker):
    """The body extends from the origin (distance 0), however long the part is."""
    src = program_text(
        doc="A post and a 600 mm arm pivoting at one end.",
        params=("pin_d = 8.0  # mm, pivot pin", "arm_l = 600.0  # mm, arm length"),
        parts=('@part(detail="silhouette", material="steel", description="post")\n'
               "def post():\n"
               "    return Cylinder(15, 100, align=(Align.CENTER, Align.CENTER, Align.MIN))\n",
               '@part(detail="major", material="aluminium", description="long arm")\n'
               "def arm():\n"
               "    boss = Cylinder(10, 12, align=(Align.CENTER, Align.CENTER, Align.MIN))\n"
               "    return boss + Box(arm_l, 20, 12, align=(Align.MIN, Align.CENTER, Align.MIN))\n"),
        frames=('frames("post", top=Location((0, 0, 100)))', 'frames("arm", pivot=Location((0, 0, 0)))'),
        mates=('mate("arm.pivot", "post.top", "revolute", nominal="pin_d", fit="clearance", '
               'limits=(-90, 90))',))
    model = compiled(src, worker=worker)
    findings, res = origin_gate(model)
    assert findings == [] and res.passed and res.measured["parts"] == {}


def test_a_body_away_from_a_mounting_frame_at_the_origin_is_not_this_mistake():
    """The frame at the origin and the body 300 mm off it: a floater (connectivity), not a part
    drawn at its assembly position, so no origin finding; drawn with the frame at the body, it
    trips."""
    from build123d import Align, Box, Pos

    from procedura_brep.mates.placement import trans
    from procedura_brep.program.model import CompiledMate, CompiledModel

    def model(frame_y: float) -> CompiledModel:
        base = cpart("base", Box(100, 100, 10, align=(Align.CENTER, Align.CENTER, Align.MAX)), top=np.eye(4))
        body = Pos(0, 300, 0) * Box(20, 20, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))
        block = cpart("block", body, trans(0, -frame_y, 0), foot=trans(0, frame_y, 0))
        mate = CompiledMate(name="block_foot", type="peg_socket", kind="static", child="block",
                            child_frame="foot", parent="base", parent_frame="top", nominal_name="peg_d",
                            nominal=5.0, fit={}, options={}, dof={}, world_frame=np.eye(4))
        return CompiledModel(name="m", params={}, parts=[base, block], mates=[mate])

    assert origin_gate(model(0.0))[0] == []
    (f,) = origin_gate(model(300.0))[0]
    assert f.part == "block" and f.value == pytest.approx(290.0, abs=1e-3)


def test_the_root_is_judged_on_its_body_alone():
    from build123d import Box, Pos

    from procedura_brep.program.model import CompiledModel

    def root(x: float) -> CompiledModel:
        return CompiledModel(name="m", params={}, parts=[cpart("base", Pos(x, 0, 0) * Box(100, 100, 10))],
                             mates=[])

    assert origin_gate(root(0.0))[0] == [] and origin_gate(root(140.0))[0] == []  # within 100 mm
    (f,) = origin_gate(root(1000.0))[0]
    assert f.part == "base" and f.mate is None and f.severity == "warning"
    assert f.value == pytest.approx(950.0, abs=1e-3) and f.limit == pytest.approx(100.0)
    assert "root" in f.message and "(-1000.0, 0.0, 0.0) mm" in f.message


def test_colour_blocks_ride_with_their_part():
    """A block of paint shares its part's placement and is never judged on its own."""
    from build123d import Box, Pos

    from procedura_brep.program.model import CompiledModel
    far = cpart("tyre", Pos(1000, 0, 0) * Box(10, 10, 10))
    far.block_of = "base"
    model = CompiledModel(name="m", params={}, parts=[cpart("base", Box(100, 100, 10)), far], mates=[])
    assert origin_gate(model)[0] == []
