"""Links, joints, tree errors, mass properties and geometric evidence."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep import materials
from procedura_brep.articulation import ArticulationError, articulate, link_masses, mates_evidence
from procedura_brep.program.model import CompiledModel

from .models import compile_lamp, mate, part


@pytest.fixture(scope="module")
def lamp(worker):
    return compile_lamp(worker)


@pytest.fixture(scope="module")
def blocks():
    import build123d as bd
    a = bd.Box(30, 20, 10, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MAX))
    b = bd.Box(20, 20, 10, align=(bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN))
    c = bd.Box(10, 10, 10).moved(bd.Location((100, 0, 0)))
    return part("a", a), part("b", b, material="aluminium"), part("c", c)


def test_lamp_links_and_joint(lamp):
    art = articulate(lamp)
    assert [(lk.name, lk.parts) for lk in art.links] == [("base", ["base", "post"]), ("arm", ["arm"])]
    (j,) = art.joints
    assert (j.name, j.type, j.parent, j.child) == ("arm_pivot", "revolute", "base", "arm")
    assert j.lower == pytest.approx(np.radians(-45)) and j.upper == pytest.approx(np.radians(45))
    np.testing.assert_allclose(art.link("arm").frame, lamp.mates[1].world_frame)


def test_orphan_and_loop_are_errors_naming_the_part(blocks):
    a, b, c = blocks
    with pytest.raises(ArticulationError, match="'c'"):
        articulate(CompiledModel("m", {}, [a, b, c], [mate("ab", "b", "a")]))
    loop = [mate("ab", "b", "a"), mate("ba", "a", "b", kind="kinematic", mtype="revolute",
                                       options={"limits": None})]
    with pytest.raises(ArticulationError, match="loop"):
        articulate(CompiledModel("m", {}, [a, b], loop))


def test_mass_from_volume_and_density(blocks):
    a, b, _ = blocks
    model = CompiledModel("m", {}, [a, b], [mate("ab", "b", "a", kind="kinematic",
                                                  mtype="revolute", options={"limits": None})])
    masses = link_masses(model, articulate(model))
    assert masses["a"].mass == pytest.approx(30 * 20 * 10 * 1e-9 * materials.get("steel").density)
    mb = masses["b"]
    assert mb.mass == pytest.approx(20 * 20 * 10 * 1e-9 * 2700)
    # box 20x20x10 mm about its centre: Ixx = m (b^2 + c^2) / 12
    np.testing.assert_allclose(mb.com, [0, 0, 0.005], atol=1e-12)
    assert mb.inertia[0, 0] == pytest.approx(mb.mass * (0.02**2 + 0.01**2) / 12, rel=1e-9)
    assert all(np.linalg.eigvalsh(m.inertia).min() > 0 for m in masses.values())


def test_symmetry_axis_and_contact_area(blocks):
    import build123d as bd
    a, b, _ = blocks
    cyl = part("cyl", bd.Cylinder(10, 40).rotate(bd.Axis.X, 90).moved(bd.Location((0, 200, 0))))
    cube = part("cube", bd.Box(20, 20, 20).moved(bd.Location((0, -200, 0))))
    ev = mates_evidence(CompiledModel("m", {}, [a, b, cyl, cube], []))
    sym = ev["parts"]["cyl"]["symmetry"]
    assert sym["kind"] == "axis"
    assert abs(abs(sym["axis"][1]) - 1.0) < 1e-9
    assert ev["parts"]["cube"]["symmetry"]["kind"] == "isotropic"
    assert ev["parts"]["cube"]["symmetry"]["axis"] is None
    (c,) = ev["contacts"]
    assert {c["a"], c["b"]} == {"a", "b"}
    assert c["area_mm2"] == pytest.approx(400.0, rel=0.02)


def test_explicit_effort_and_velocity_are_kept():
    """An explicit small value (and even 0, were it to get past the compiler) is never replaced
    by the default, as an ``or`` default did."""
    from procedura_brep.articulation.tree import mate_option
    from procedura_brep.mates import TYPES

    m = mate("j", "b", "a", kind="kinematic", mtype="revolute",
             options={"limits": None, "effort": 0.0, "velocity": 0.25})
    assert mate_option(m, "effort") == 0.0 and mate_option(m, "velocity") == 0.25
    bare = mate("k", "b", "a", kind="kinematic", mtype="revolute", options={"limits": None})
    assert mate_option(bare, "effort") == TYPES["revolute"].options["effort"].default


def test_a_curved_seat_has_the_contact_the_mate_gate_measures(worker):
    """A saddle on a round tube: the flat face-to-face area sees nothing there (two independent
    tessellations of one cylinder are not coplanar), so the pair's contact is the seat's bearing
    area as the mate gate measures it (issue 23: 7.5 mm^2 shown against the gate's 2,694)."""
    from pathlib import Path

    from procedura_brep.gates.mate_gate import measure
    from procedura_brep.program import compile_source
    src = (Path(__file__).parent / "programs" / "saddle.py").read_text()
    model = compile_source(src, name="saddle", worker=worker)
    assert model.ok, model.findings
    gate = measure(model, next(m for m in model.mates if m.name == "saddle_seat")).area_mm2
    assert gate > 500  # the 30 mm wide saddle bears on about 40 x 20 mm of the tube's top
    (c,) = mates_evidence(model)["contacts"]
    assert c["face_mm2"] < 0.05 * gate and c["mates"] == ["saddle_seat"]
    assert c["area_mm2"] == pytest.approx(gate)
