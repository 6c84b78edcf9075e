"""Every mate type, compiled in the sandbox: placement, fits, interference, nominal edits, DOF."""

from __future__ import annotations

import math

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.errors import RangeError
from procedura_brep.mates import TYPES, iso286
from procedura_brep.mates import placement as pl
from procedura_brep.program.edit import set_params

from .progs import CASES, program


def _build(worker, src: str):
    from procedura_brep.program.sandbox import CompileOptions
    m = worker.compile(src, CompileOptions(name="t"))
    assert m.ok, [f.as_dict() for f in m.findings]
    return m


@pytest.fixture(scope="module")
def built(worker):
    return {t: _build(worker, program(t, n, f, o)) for t, n, f, o in CASES}


def test_every_type_is_covered():
    assert {c[0] for c in CASES} == set(TYPES)


@pytest.mark.parametrize("mtype", [c[0] for c in CASES])
def test_child_frame_coincides_with_parent_frame(built, mtype):
    m = built[mtype]
    mate = m.mates[0]
    child = m.part("block")
    dist, ang = pl.residual(child.world_frame("foot"), mate.world_frame)
    assert dist <= 1e-6 and ang <= 1e-9
    parent = m.part("base")
    home = pl.home_value(mtype, mate.options) if mate.kind == "kinematic" else None
    expect = parent.world_frame("top") @ pl.delta(mtype, home)
    dist, ang = pl.residual(mate.world_frame, expect)
    assert dist <= 1e-6 and ang <= 1e-9
    assert mate.dof["count"] == TYPES[mtype].dof.count
    assert (mate.dof["count"] == 0) == (TYPES[mtype].kind == "static")


@pytest.mark.parametrize("mtype", [c[0] for c in CASES])
def test_features_change_both_halves(built, mtype):
    """Male added to the child, female cut from the parent: volumes differ from the raw boxes."""
    m = built[mtype]
    vb = kernel.volume(m.part("block").local_shape())
    vp = kernel.volume(m.part("base").local_shape())
    assert vb > 90 * 90 * 30 + 1e-3
    assert vp < 160 * 160 * 40 - 1e-3


def test_clearance_peg_radial_gap_equals_table(worker):
    from build123d import Align, Box, Cylinder, Solid
    m = _build(worker, program("peg_socket", 10.0, "clearance"))
    mate = m.mates[0]
    inv = pl.rigid_inverse(mate.world_frame)
    child = Solid(kernel.located(m.part("block").shape(), inv))
    parent = Solid(kernel.located(m.part("base").shape(), inv))
    below = Box(100, 100, 50, align=(Align.CENTER, Align.CENTER, Align.MAX))
    peg = child & below
    hole = Cylinder(6, 10, align=(Align.CENTER, Align.CENTER, Align.MAX)) - parent
    peg_d = peg.bounding_box().size.X
    hole_d = hole.bounding_box().size.X
    gap = (hole_d - peg_d) / 2
    assert gap == pytest.approx(iso286(10.0, "clearance").offset, abs=1e-6)
    assert gap == pytest.approx(0.0085, abs=1e-6)


@pytest.mark.parametrize("fit, positive", [("clearance", False), ("location", None), ("press", True)])
def test_interference_volume_by_fit(worker, fit, positive):
    m = _build(worker, program("peg_socket", 10.0, fit))
    common = kernel.common_volume(m.part("block").shape(), m.part("base").shape())
    if positive is None:
        return  # H7/k6 is a transition fit at mid-tolerance: either sign is legal
    if positive:
        assert common > 1e-3
    else:
        assert common == pytest.approx(0.0, abs=1e-6)


def test_changing_nominal_changes_both_halves(worker):
    src = program("peg_socket", 10.0, "clearance")
    a = _build(worker, src)
    b = _build(worker, set_params(src, {"nom": 14.0}))
    for name in ("block", "base"):
        va = kernel.volume(a.part(name).local_shape())
        vb = kernel.volume(b.part(name).local_shape())
        assert abs(va - vb) > 1.0, name
    assert b.mates[0].nominal == 14.0 and b.mates[0].fit["hole"] > a.mates[0].fit["hole"]


def test_revolute_moves_only_about_its_axis(built):
    m = built["revolute"]
    mate = m.mates[0]
    parent = m.part("base")
    fp, fc = parent.frames["top"], m.part("block").frames["foot"]
    axis_origin = mate.world_frame[:3, 3]
    axis = mate.world_frame[:3, 2]
    for ang in (-45.0, 0.0, 33.0, 90.0):
        pl.check_value(mate.name, "revolute", ang, limits=tuple(mate.options["limits"]))
        t = pl.solve(parent.placement, fp, fc, pl.delta("revolute", ang))
        wf = t @ fc
        assert np.linalg.norm(wf[:3, 3] - axis_origin) < 1e-9
        assert np.allclose(wf[:3, 2], axis, atol=1e-12)
        cos = float(np.dot(wf[:3, 0], mate.world_frame[:3, 0]))
        assert math.degrees(math.acos(max(-1, min(1, cos)))) == pytest.approx(abs(ang), abs=1e-7)
    with pytest.raises(RangeError, match=r"block_foot \(revolute\) position = 91 deg is outside the "
                                         r"allowed range \[-45, 90\] deg"):
        pl.check_value(mate.name, "revolute", 91.0, limits=tuple(mate.options["limits"]))


def test_prismatic_moves_only_along_its_axis(built):
    m = built["prismatic"]
    mate = m.mates[0]
    parent = m.part("base")
    fp, fc = parent.frames["top"], m.part("block").frames["foot"]
    for pos in (-5.0, 0.0, 7.5, 20.0):
        t = pl.solve(parent.placement, fp, fc, pl.delta("prismatic", pos))
        wf = t @ fc
        assert np.allclose(wf[:3, :3], mate.world_frame[:3, :3], atol=1e-12)
        d = wf[:3, 3] - mate.world_frame[:3, 3]
        assert np.linalg.norm(d - pos * mate.world_frame[:3, 2]) < 1e-9
    with pytest.raises(RangeError, match=r"position = -6 mm is outside the allowed range \[-5, 20\] mm"):
        pl.check_value(mate.name, "prismatic", -6.0, limits=tuple(mate.options["limits"]))


def test_spherical_keeps_its_centre_and_cone(built):
    m = built["spherical"]
    mate = m.mates[0]
    parent = m.part("base")
    fp, fc = parent.frames["top"], m.part("block").frames["foot"]
    for rot in ((10, 0, 0), (0, -20, 45), (15, 15, 0)):
        t = pl.solve(parent.placement, fp, fc, pl.delta("spherical", rot))
        assert np.linalg.norm((t @ fc)[:3, 3] - mate.world_frame[:3, 3]) < 1e-9
        pl.check_value(mate.name, "spherical", rot, cone=mate.options["cone"])
    with pytest.raises(RangeError, match=r"tilt = 40 deg is outside the allowed range \[0, 30\] deg"):
        pl.check_value(mate.name, "spherical", (40, 0, 0), cone=mate.options["cone"])


@pytest.mark.parametrize("options, message", [
    (", limits=(10, -10)", "must have lo < hi"),
    (", limits=(-400, 10)", "outside [-360, 360]"),
    (", home=120, limits=(-45, 90)", "home = 120 is outside its limits"),
    (", wobble=3", "unknown option(s) wobble"),
])
def test_bad_kinematic_options_are_compile_errors(worker, options, message):
    from procedura_brep.program.sandbox import CompileOptions
    m = worker.compile(program("revolute", 10.0, "clearance", options), CompileOptions())
    assert not m.ok
    assert any(message in f.message and f.mate == "block_foot" for f in m.findings), m.findings


def test_literal_nominal_is_a_compile_error_naming_the_mate(worker):
    from procedura_brep.program.sandbox import CompileOptions
    src = program("peg_socket", 10.0, "clearance").replace('nominal="nom"', "nominal=12.0")
    m = worker.compile(src, CompileOptions())
    assert not m.ok
    assert any("mate block_foot" in f.message and "param name" in f.message for f in m.findings)


def test_fit_not_allowed_for_type(worker):
    from procedura_brep.program.sandbox import CompileOptions
    m = worker.compile(program("snap_tab", 12.0, "press"), CompileOptions())
    assert any("takes fit snap, not 'press'" in f.message for f in m.findings)


@pytest.mark.parametrize("options, message", [
    (", limits=(-45, 90), effort=0", "option effort = 0 is outside (0, 1e+06]"),
    (", limits=(-45, 90), velocity=0", "option velocity = 0 is outside (0, 10000]"),
])
def test_zero_effort_or_velocity_is_a_range_error(worker, options, message):
    """A kinematic joint that may exert no effort or move at no speed cannot move: refused,
    never silently replaced by a default."""
    from procedura_brep.program.sandbox import CompileOptions
    m = worker.compile(program("revolute", 10.0, "clearance", options), CompileOptions())
    assert not m.ok
    assert any(message in f.message and f.mate == "block_foot" for f in m.findings), m.findings


def _stud_centres(shape) -> list[tuple[float, float]]:
    out = []
    for s in shape.solids():
        c = s.bounding_box().center()
        out.append((round(c.X, 6), round(c.Y, 6)))
    return sorted(out)


def test_a_single_bolt_sits_on_the_frame_axis():
    from procedura_brep.mates.features import build
    from procedura_brep.mates.vocabulary import check_options
    opts = check_options("m", TYPES["bolt_pattern"], "clearance", {"count": 1, "pcd": 80.0})
    male, female = build("bolt_pattern", 8.0, iso273_fit(8.0), opts)
    assert _stud_centres(male) == [(0.0, 0.0)]
    assert len(female.solids()) == 1
    with pytest.raises(Exception, match="count = 0 is outside"):
        check_options("m", TYPES["bolt_pattern"], "clearance", {"count": 0})


def test_flange_angle0_turns_the_stud_ring():
    from procedura_brep.mates.features import build
    from procedura_brep.mates.vocabulary import check_options
    fit = iso286(40.0, "location")
    base = build("flange", 40.0, fit, check_options("m", TYPES["flange"], "location", {"count": 4}))
    turned = build("flange", 40.0, fit, check_options("m", TYPES["flange"], "location",
                                                      {"count": 4, "angle0": 45.0}))
    r = 1.5 * 40.0 / 2  # the default pcd is 1.5 d
    ring = [s for s in _stud_centres(turned[0]) if abs(s[0]) + abs(s[1]) > 1e-3]
    assert ring == sorted((round(x, 6), round(y, 6)) for x, y in
                          [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a)))
                           for a in (45, 135, 225, 315)])
    assert ring != [s for s in _stud_centres(base[0]) if abs(s[0]) + abs(s[1]) > 1e-3]


def iso273_fit(d: float):
    from procedura_brep.mates import iso273
    return iso273(d, "clearance")


def test_one_bolt_ignores_its_pcd_as_documented():
    """`count=1` means "a single bolt on the frame axis, pcd unused": pcd=0 was refused as
    outside [1, 5000] (seen in a recorded run); a bad pcd with several bolts still is."""
    from procedura_brep.errors import MateError
    from procedura_brep.mates import TYPES
    from procedura_brep.mates.vocabulary import check_options

    bolts = TYPES["bolt_pattern"]
    assert check_options("m", bolts, "clearance", {"count": 1, "pcd": 0})["pcd"] is None
    with pytest.raises(MateError, match="option pcd = 0 is outside"):
        check_options("m", bolts, "clearance", {"count": 2, "pcd": 0})
