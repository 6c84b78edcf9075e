"""Part pieces probes (issue 11.2) and local bearing (11.3): planted defect caught, clean twin passes."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.gates import check_model
from procedura_brep.gates.mate_gate import mate_gate
from procedura_brep.gates.pieces import part_pieces, pieces_gate
from procedura_brep.mates.fits import iso286
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledMate, CompiledModel
from procedura_brep.testing.models import cpart


def _model(parts, mates=()):
    return CompiledModel(name="m", params={}, parts=list(parts), mates=list(mates))


def _cyl(r, h):
    from build123d import Align, Cylinder
    return Cylinder(r, h, align=(Align.CENTER, Align.CENTER, Align.MIN))


def _box(x, y, z):
    from build123d import Align, Box
    return Box(x, y, z, align=(Align.CENTER, Align.CENTER, Align.MIN))


def test_cube_30_mm_off_the_chuck_is_a_detached_piece():
    from build123d import Compound, Pos
    chuck = _cyl(40, 60)
    off = Compound([chuck, Pos(70, 0, 20) * _box(5, 5, 5)])   # 30 mm clear of the chuck's side
    findings, res = pieces_gate(_model([cpart("chuck", off)]))
    assert not res.passed and [f.code for f in findings] == ["part-pieces"]
    f = findings[0]
    assert f.part == "chuck" and f.value == 2 and f.limit == 1
    assert "bbox (67.5, -2.5, 20.0)..(72.5, 2.5, 25.0) mm" in f.message
    assert res.measured["chuck"]["detached"][0]["volume_mm3"] == pytest.approx(125, rel=1e-3)
    fused = chuck + Pos(40, 0, 20) * _box(5, 5, 5)              # the same cube on the chuck
    findings, res = pieces_gate(_model([cpart("chuck", fused)]))
    assert res.passed and not findings


def test_floating_pin_is_caught_and_a_declared_second_piece_is_not():
    from build123d import Compound, Pos
    body = _box(50, 50, 20)
    pin = Pos(0, 0, 40) * _cyl(2, 9)                            # a 4 x 9 mm pin in the air
    part = cpart("holder", Compound([body, pin]))
    assert not pieces_gate(_model([part]))[1].passed
    part.pieces = 2
    findings, res = pieces_gate(_model([part]))
    assert res.passed and not findings
    # two solids that touch face to face are one piece
    touching = Compound([body, Pos(0, 0, 20) * _box(10, 10, 10)])
    assert len(part_pieces(cpart("stack", touching)).groups) == 1


def test_span_threshold_does_not_hide_a_small_detached_piece():
    from build123d import Compound, Pos
    big = cpart("frame", _box(2000, 2000, 10))
    tiny = Compound([_box(40, 40, 10), Pos(0, 0, 30) * _box(5, 5, 5)])  # 0.25 % of the span
    report = check_model(_model([big, cpart("knob", tiny, trans(0, 0, 10))]))
    assert report.as_dict()["n_vis"] == 0 and not report.passed
    assert [f.part for f in report.findings if f.code == "part-pieces"] == ["knob"]


def _seat(d=10.0, **options):
    return CompiledMate(name="plate_on_base", type="seat_face", kind="static", child="plate",
                        child_frame="origin", parent="base", parent_frame="origin",
                        nominal_name="d", nominal=d, fit=iso286(d, "clearance").as_dict(),
                        options=dict(options), dof={}, world_frame=np.eye(4), line=3)


def test_part_slid_30_mm_along_its_parents_face_does_not_register():
    from build123d import Align, Box
    base = cpart("base", Box(300, 300, 20, align=(Align.CENTER, Align.CENTER, Align.MAX)))
    plate = _box(30, 30, 10)
    for dx, seated in ((0.0, True), (30.0, False)):
        model = _model([base, cpart("plate", plate, trans(dx, 0, 0))], [_seat(features=False)])
        findings, res = mate_gate(model)
        assert res.passed is seated, (dx, [f.message for f in findings])
        if not seated:
            assert findings[0].code == "mate-registration" and findings[0].value == 0.0


def test_detached_piece_does_not_bear():
    """A pad left in its counterbore while the plate body sits 0.5 mm above the base."""
    from build123d import Align, Box, Compound, Pos
    base = cpart("base", Box(100, 100, 20, align=(Align.CENTER, Align.CENTER, Align.MAX)))
    pad = Pos(0, 0, -2) * _cyl(5, 2)       # bears on a floor at z = -2 (a counterbore without relief)
    floor = Box(100, 100, 20, align=(Align.CENTER, Align.CENTER, Align.MAX)) - _cyl(5.1, 2).translate((0, 0, -2))
    base = cpart("base", floor)
    lifted = Compound([Pos(0, 0, 0.5) * _box(30, 30, 10), pad])
    model = _model([base, cpart("plate", lifted)], [_seat()])
    findings, res = mate_gate(model)
    assert not res.passed and res.measured["plate_on_base"]["area_mm2"] == 0.0
    report = check_model(model)
    assert any(f.code == "part-pieces" for f in report.findings)
    # nor does it count as touching: the pad touches the base, the hovering body floats
    assert report.as_dict()["n_vis"] == 1
    assert report.as_dict()["connectivity"]["floaters"][0]["parts"] == ["plate"]
    attached = _model([base, cpart("plate", _box(30, 30, 10) + pad)], [_seat()])
    findings, res = mate_gate(attached)
    assert res.passed, [f.message for f in findings]


SEAT = '''from procedura_brep.program import *

# === params ===
pad_d = 10.0  # mm, seat pad: the nominal of the seat_face
rod_d = {rod_d}  # mm, rod diameter
lift = {lift}  # mm, frame below the rod's foot

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base block")
def base():
    return Box(80, 80, 20, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="rod on the base")
def rod():
    return Cylinder(rod_d / 2, 40, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("base", top=Location((0, 0, 0)))
frames("rod", foot=Location((0, 0, -lift)))

# === assembly ===
mate("rod.foot", "base.top", "seat_face", nominal="pad_d", fit="location")
'''


@pytest.mark.parametrize("rod_d,lift,ok,codes", [
    (30.0, 0.0, True, set()),                                  # the rod's face around the pad bears
    (6.0, 0.0, False, {"mate-registration"}),                  # only the pad could bear: relief
    (30.0, 0.5, False, {"mate-registration", "part-pieces"}),  # pad left behind, rod hovers
])
def test_seat_face_pad_alone_cannot_register(worker, rod_d, lift, ok, codes):
    from procedura_brep.program import compile_source
    src = SEAT.format(rod_d=rod_d, lift=lift)
    model = compile_source(src, name="seat", worker=worker)
    assert model.ok, [f.as_dict() for f in model.findings]
    report = check_model(model, src)
    errors = {f.code for f in report.findings if f.severity == "error"}
    assert report.passed is ok and codes <= errors, report.feedback
    if not ok:
        assert errors <= codes | {"floater"}


BOLTS = '''from procedura_brep.program import *

# === params ===
bolt_d = 6.0  # mm, M6 studs: the nominal of the bolt pattern
guard_pcd = {pcd}  # mm, bolt circle

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base block")
def base():
    return Box(400, 400, 20, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="round guard bolted to the base")
def guard():
    return Cylinder(40, 8, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("base", top=Location((0, 0, 0)))
frames("guard", foot=Location((0, 0, 0)))

# === assembly ===
mate("guard.foot", "base.top", "bolt_pattern", nominal="bolt_d", count=4, pcd="guard_pcd")
'''


def test_bolt_studs_left_in_mid_air_by_an_edit(worker):
    from procedura_brep.program import compile_source
    good = BOLTS.format(pcd=50.0).replace('pcd="guard_pcd"', "pcd=guard_pcd")
    model = compile_source(good, name="bolts", worker=worker)
    assert model.ok and check_model(model, good).passed, check_model(model, good).feedback
    bad = BOLTS.format(pcd=300.0).replace('pcd="guard_pcd"', "pcd=guard_pcd")
    model = compile_source(bad, name="bolts", worker=worker)
    report = check_model(model, bad)
    pieces = [f for f in report.findings if f.code == "part-pieces"]
    assert not report.passed and len(pieces) == 4 and all(f.part == "guard" for f in pieces)


TWIN = '''from procedura_brep.program import *

# === params ===
gap = 20.0  # mm, between the two blocks

# === helpers ===

# === parts ===
@part(detail="major", material="steel", description="two blocks"{decl})
def pair():
    return Compound([Box(10, 10, 10), Pos(gap, 0, 0) * Box(10, 10, 10)])

# === frames ===

# === assembly ===
'''


@pytest.mark.parametrize("decl,ok", [("", False), (", pieces=2", True)])
def test_pieces_declaration_compiles_and_counts(worker, decl, ok):
    from procedura_brep.program import compile_source
    src = TWIN.format(decl=decl)
    model = compile_source(src, name="twin", worker=worker)
    assert model.ok, [f.as_dict() for f in model.findings]
    assert model.parts[0].pieces == (2 if ok else 1)
    assert pieces_gate(model)[1].passed is ok


def test_bad_pieces_declaration_is_a_one_line_error(worker):
    from procedura_brep.program import compile_source
    model = compile_source(TWIN.format(decl=", pieces=0"), name="twin", worker=worker)
    msgs = [f.message for f in model.findings if f.severity == "error"]
    assert msgs and "pieces=0 must be an integer in [1, 1000]" in msgs[0]
