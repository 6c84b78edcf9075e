"""Interference gate probes (issue 11.1): a planted overlap is caught, its clean twin passes."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.config import TOL
from procedura_brep.gates import check_model
from procedura_brep.gates.interference import interference_gate, scan
from procedura_brep.mates.fits import iso286
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledMate, CompiledModel
from procedura_brep.testing.models import cpart, peg_model


def _box(x, y, z, align=("MIN", "MIN", "MIN")):
    from build123d import Align, Box
    return Box(x, y, z, align=tuple(getattr(Align, a) for a in align))


def _cyl(r, h):
    from build123d import Align, Cylinder
    return Cylinder(r, h, align=(Align.CENTER, Align.CENTER, Align.MIN))


def _model(parts, mates=()):
    return CompiledModel(name="m", params={}, parts=list(parts), mates=list(mates))


def _seat(child, parent, *, frame=None, fit="clearance", d=10.0, mtype="seat_face", name=None,
          kind="static", **options):
    f = iso286(d, fit)
    return CompiledMate(name=name or f"{child}_on_{parent}", type=mtype, kind=kind, child=child,
                        child_frame="origin", parent=parent, parent_frame="origin",
                        nominal_name="d", nominal=d, fit=f.as_dict(), options=dict(options),
                        dof={}, world_frame=np.eye(4) if frame is None else frame, line=7)


def _codes(model):
    findings, res = interference_gate(model)
    return [f for f in findings if f.code == "interference"], res


def test_handle_swept_into_the_column_is_caught():
    column = cpart("column", _cyl(20, 300))
    # a 10 x 10 handle whose end is sunk 3 mm into the column's side (x = 20)
    handle = cpart("handle", _box(80, 10, 10), trans(17, -5, 150))
    found, res = _codes(_model([column, handle]))
    assert not res.passed and len(found) == 1
    f = found[0]
    assert f.part == "handle" and "column" in f.message and "not mate partners" in f.message
    assert f.value == pytest.approx(3.0, rel=0.02) and f.limit == TOL.penetration_slack_mm
    assert "volume" in f.message and "mm^3" in f.message
    # clean twin: the handle's end face touches the column's flat (a box column) face to face
    col2 = cpart("column", _box(40, 40, 300, ("CENTER", "CENTER", "MIN")))
    found, res = _codes(_model([col2, cpart("handle", _box(80, 10, 10), trans(20, -5, 150))]))
    assert res.passed and not found


def test_collar_sunk_into_its_parent_links_other_part_is_caught():
    # base <- column (seat), column <- collar (seat); the collar reaches 2 mm into the base
    base = cpart("base", _box(200, 200, 20, ("CENTER", "CENTER", "MAX")))
    column = cpart("column", _cyl(15, 200))
    ring = _cyl(40, 20) - _cyl(15, 20)
    mates = [_seat("column", "base", d=20.0), _seat("collar", "column", d=20.0,
                                                    frame=trans(0, 0, 100))]
    sunk = cpart("collar", ring, trans(0, 0, -2))
    found, res = _codes(_model([base, column, sunk], mates))
    assert [(f.part, f.value) for f in found] == [("collar", pytest.approx(2.0, rel=0.02))]
    assert "base" in found[0].message
    clean = cpart("collar", ring, trans(0, 0, 1))
    found, res = _codes(_model([base, column, clean], mates))
    assert res.passed and not found


def test_two_sibling_bolts_at_the_same_spot_are_caught():
    plate = cpart("plate", _box(100, 100, 10, ("CENTER", "CENTER", "MAX")))
    bolt = _cyl(4, 30)
    a = cpart("bolt_a", bolt, trans(20, 0, 0))
    b = cpart("bolt_b", bolt, trans(20, 0, 0))
    mates = [_seat("bolt_a", "plate", d=8.0, frame=trans(20, 0, 0)),
             _seat("bolt_b", "plate", d=8.0, frame=trans(20, 0, 0), name="bolt_b_on_plate")]
    found, res = _codes(_model([plate, a, b], mates))
    assert len(found) == 1 and {"bolt_a", "bolt_b"} <= set(found[0].message.split())
    assert found[0].value == pytest.approx(8.0, rel=0.02)
    b2 = cpart("bolt_b", bolt, trans(-20, 0, 0))
    mates[1].world_frame = trans(-20, 0, 0)
    found, res = _codes(_model([plate, a, b2], mates))
    assert res.passed and not found


def test_motor_pushed_into_the_head_names_the_motor_and_the_head():
    bracket = cpart("bracket", _box(60, 60, 10, ("CENTER", "CENTER", "MAX")))
    head = cpart("head", _box(200, 200, 100), trans(35, -100, 0))
    motor = cpart("motor", _cyl(25, 120), trans(0, 0, 0))  # x in [-25, 25]: 0 mm into the head...
    pushed = cpart("motor", _cyl(25, 120), trans(52, 0, 0))  # ...then 52 mm along +x
    mates = [_seat("motor", "bracket", d=40.0)]
    found, _ = _codes(_model([bracket, head, motor], mates))
    assert not found
    report = check_model(_model([bracket, head, pushed], mates))
    inter = [f for f in report.findings if f.code == "interference"]
    assert any({"motor", "head"} <= set(f.message.replace(",", " ").split()) for f in inter)
    worst = max(inter, key=lambda f: f.value)
    assert worst.value == pytest.approx(25 + 52 - 35, rel=0.02)
    assert not report.passed and report.as_dict()["verdicts"]["interference"] is False


def test_press_fit_between_partners_is_allowed_but_not_between_strangers():
    model = peg_model(40.0, "press", depth=20.0)
    found, res = _codes(model)
    assert res.passed and not found
    (row,) = [r for r in scan(model) if r.volume]
    assert row.allowed and row.judged_by == "fit" and 0 < row.depth <= row.limit
    assert row.depth == pytest.approx(-model.mates[0].fit["offset"], rel=0.05)
    model.mates = []  # the same ring with no fit declared
    found, res = _codes(model)
    assert not res.passed and found[0].value == pytest.approx(row.depth, rel=0.05)


def test_static_partners_over_their_fit_are_the_mate_gates():
    model = peg_model(10.0, "clearance", lift=-2.0)
    found, res = _codes(model)
    assert not found and res.passed  # the mate gate reports mate-penetration instead
    rows = scan(model)
    assert rows and not rows[0].allowed and rows[0].judged_by == "mate"
    codes = [f.code for f in check_model(model).findings]
    assert "mate-penetration" in codes and "interference" not in codes


def test_partner_overlap_outside_the_feature_region_is_caught():
    base = cpart("base", _box(400, 100, 20, ("MIN", "CENTER", "MAX")))
    # a 170 mm bar seated at x = 10, with a lug at x = 150 dipping 1 mm into the base
    bar = _box(170, 20, 20, ("MIN", "CENTER", "MIN"))
    lug = _box(10, 10, 21, ("MIN", "CENTER", "MIN")).translate((150, 0, -1))
    mates = [_seat("child", "base", d=10.0, frame=trans(10, 0, 0), features=False)]
    found, res = _codes(_model([base, cpart("child", bar + lug)], mates))
    assert not res.passed and len(found) == 1
    assert "outside every feature region" in found[0].message
    assert found[0].value == pytest.approx(1.0, rel=0.02)


def test_b3_agrees_with_the_gate():
    from procedura_brep.sim import contact

    column = cpart("column", _cyl(20, 300))
    handle = cpart("handle", _box(80, 10, 10), trans(17, -5, 150))
    model = _model([column, handle])
    gate = [(r.a, r.b, r.depth) for r in scan(model) if not r.allowed]
    b3 = [(o.a, o.b, o.depth) for o in contact.rest_overlaps(model)]
    assert b3 == gate and len(b3) == 1
    press = peg_model(40.0, "press", depth=20.0)
    assert contact.rest_overlaps(press) == []  # allowed by the fit, in both


@pytest.mark.parametrize("g", [0.5, 1.0, 2.0])
@pytest.mark.parametrize("shape", ["block", "ring", "cylinder"])
def test_planted_gouge_depth_is_read_within_two_percent(shape, g):
    """Issue 11.4: a ring-shaped overlap (a head sunk onto its column) read 1.42 for 2 mm."""
    from procedura_brep.gates.mate_gate import mate_gate

    base = cpart("base", _box(100, 100, 30, ("CENTER", "CENTER", "MAX")))
    if shape == "block":
        child = _box(30, 30, 20, ("CENTER", "CENTER", "MIN"))
        parent = base
    elif shape == "ring":  # a head with a 12 mm bore sunk onto a 40 mm column
        parent = cpart("base", _cyl(20, 60).translate((0, 0, -60)))
        child = _box(60, 60, 20, ("CENTER", "CENTER", "MIN")) - _cyl(6, 20)
    else:
        child = _cyl(8, 40)
        parent = base
    mate = _seat("child", "base", d=12.0)
    model = _model([parent, cpart("child", child, trans(0, 0, -g))], [mate])
    _, res = mate_gate(model)
    assert res.measured[mate.name]["penetration_mm"] == pytest.approx(g, rel=0.02)
    model.mates = []  # as strangers: the interference gate reads the same depth
    found, _ = _codes(model)
    assert found[0].value == pytest.approx(g, rel=0.02)


QUILL = '''from procedura_brep.program import *

# === params ===
spigot_d = 12.0  # mm, spigot under the quill: the nominal of its peg_socket
pulley_d = 10.0  # mm, pulley hub: the nominal of its seat_face
quill_travel = {travel}  # mm, where the pulley sits along x

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="head block")
def head():
    return Box(300, 120, 20, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="quill column at the head centre")
def quill():
    return Cylinder(20, 100, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="pulley beside the quill")
def pulley():
    return Cylinder(30, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("head", top=Location((0, 0, 0)), side=Location((quill_travel, 0, 0)))
frames("quill", foot=Location((0, 0, 0)))
frames("pulley", foot=Location((0, 0, 0)))

# === assembly ===
mate("quill.foot", "head.top", "peg_socket", nominal="spigot_d", fit="location")
mate("pulley.foot", "head.side", "seat_face", nominal="pulley_d", fit="location")
'''


def test_edit_that_drives_the_pulley_into_the_quill_is_refused(tmp_path):
    """Issue 11.1: `edit quill_travel=...` pushed a pulley 4 mm into the quill and was accepted."""
    from typer.testing import CliRunner

    from procedura_brep.cli import app

    prog = tmp_path / "press.py"
    prog.write_text(QUILL.format(travel=60.0))       # pulley r 30 + quill r 20 = 50 < 60: clear
    runner = CliRunner()
    res = runner.invoke(app, ["check", str(prog)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["edit", str(prog), "--set", "quill_travel=46"])  # 4 mm in
    assert res.exit_code == 1
    out = " ".join(res.output.split())
    assert "rejected" in out and "pulley and quill interpenetrate" in out
    depth = float(out.split("interpenetrate: depth ")[1].split(" mm")[0])
    assert depth == pytest.approx(4.0, rel=0.01)
    assert "quill_travel = 60.0" in prog.read_text()


def _plates(n):
    import sys
    sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[2] / "benchmarks"))
    from gates import plates_model  # the benchmark's crossed plates (issue 10.1)
    return plates_model(n)


def test_over_the_pair_budget_the_common_is_cropped_then_not_verified(monkeypatch):
    """Over ``boolean_pair_budget`` the solids are cropped to their boxes' overlap and the pairs
    counted again; still over it, the mate's penetration is *not verified*: a warning naming
    what stopped it, never a pass of it and never a blocking error (no mesh estimate)."""
    import dataclasses

    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches
    from procedura_brep.gates.mate_gate import mate_gate

    model = _plates(4)
    clear_caches()
    findings, res = mate_gate(model)
    m = res.measured["comb_foot"]
    assert m["exact"] and m["penetration_mm"] == pytest.approx(1.0, rel=0.02)
    assert "not-verified" not in {f.code for f in findings}
    pairs = common_mod.face_pairs(*(common_mod.face_boxes(__import__(
        "procedura_brep.gates.geometry", fromlist=["part_geometry"]).part_geometry(p))
        for p in model.parts))
    assert pairs >= 16  # 4 x 4 crossed plates meet at least once each
    monkeypatch.setattr(common_mod, "TOL", dataclasses.replace(TOL, boolean_pair_budget=pairs - 1))
    clear_caches()
    findings, res = mate_gate(model)
    m = res.measured["comb_foot"]
    codes = {f.code: f for f in findings}
    assert not m["exact"] and codes["not-verified"].severity == "warning"
    assert "face pairs meet" in codes["not-verified"].message
    assert "TOL.boolean_pair_budget" in codes["not-verified"].message
    assert "mate-penetration" not in codes  # neither a failure nor a mesh estimate
    assert "face pairs" in m["not_verified"]
    clear_caches()


def test_a_boolean_that_occt_fails_is_not_verified_and_reported_not_raised(monkeypatch):
    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches

    def broken(a, b):
        raise RuntimeError("Standard_Failure: BOPAlgo")

    monkeypatch.setattr(common_mod, "exact_common", broken)
    clear_caches()
    column = cpart("column", _cyl(20, 300))
    handle = cpart("handle", _box(80, 10, 10), trans(17, -5, 150))
    report = check_model(_model([column, handle]))
    codes = {f.code: f for f in report.findings}
    assert codes["not-verified"].severity == "warning" and "OCCT failed" in codes["not-verified"].message
    assert "interference" not in codes and report.passed  # not decided: never a false failure
    nv = report.gate("interference").measured["not_verified"]
    assert nv == [{"a": "column", "b": "handle", "reason": nv[0]["reason"]}]
    clear_caches()


def _drum(teeth: int = 60):
    from build123d import Align, Box, Cylinder, Pos, Rot
    d = Cylinder(40, 30, align=(Align.CENTER, Align.CENTER, Align.MIN))
    d = d + [Rot(0, 0, 360 * i / teeth) * Pos(41.5, 0, 0)
             * Box(3, 2, 30, align=(Align.CENTER, Align.CENTER, Align.MIN)) for i in range(teeth)]
    return d - Cylinder(10, 30, align=(Align.CENTER, Align.CENTER, Align.MIN))


def _slotted_plate(boss_r: float):
    from build123d import Align, Box, Cylinder, Pos
    p = Box(160, 160, 5, align=(Align.CENTER, Align.CENTER, Align.MAX))
    cuts = [Pos(-66 + 16 * (k % 10), -66 + 18 * (k // 10), -2.5) * Box(6, 3, 6) for k in range(80)]
    p = p - [c for c in cuts if (c.center().X ** 2 + c.center().Y ** 2) ** 0.5 > 50]
    return p + Cylinder(boss_r, 20, align=(Align.CENTER, Align.CENTER, Align.MIN))


@pytest.mark.parametrize("boss_r, fails", [(9.8, False), (10.3, True)])
def test_toothed_drum_on_a_slotted_plate_is_decided_exactly(boss_r, fails):
    """Issue 23.1: a toothed drum sits on a slotted plate whose boss stands in its 10 mm bore,
    a pair far over the old face budget (483 x 220 faces). With 0.2 mm radial clearance they
    only touch (the plate's face under the drum): pass. With the boss 0.3 mm oversize the
    finding's depth is the exact 0.3 mm ring wall (the old mesh estimate said 1.34 / 1.38)."""
    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches, part_geometry

    clear_caches()
    model = _model([cpart("drum", _drum()), cpart("plate", _slotted_plate(boss_r))])
    ga, gb = (part_geometry(p) for p in model.parts)
    assert common_mod.face_count(ga) * common_mod.face_count(gb) > 20000  # the old budget
    found, res = _codes(model)
    assert res.measured["not_verified"] == []
    if not fails:
        assert res.passed and not found
        return
    assert not res.passed and len(found) == 1
    f = found[0]
    assert f.value == pytest.approx(0.3, rel=0.2) and "mesh estimate" not in f.message
    assert f.message.startswith("plate and drum interpenetrate")
    assert "plate at (" in f.message and "in its own coordinates, near its " in f.message
    row = res.measured["pairs"][0]
    assert row["exact"] and row["volume_mm3"] > 0
    assert np.hypot(*row["point"][:2]) == pytest.approx(10.0, abs=0.35)  # on the bore wall
    clear_caches()

def test_check_says_not_verified_on_its_last_line(monkeypatch, capsys):
    """`check` never prints "all gates pass" over a pair it could not decide."""
    import dataclasses

    from procedura_brep.console import print_check
    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches

    monkeypatch.setattr(common_mod, "TOL", dataclasses.replace(TOL, boolean_pair_budget=1))
    clear_caches()
    column = cpart("column", _cyl(20, 300))
    handle = cpart("handle", _box(80, 10, 10), trans(17, -5, 150))
    report = check_model(_model([column, handle]))
    clear_caches()
    assert report.passed
    print_check(report.as_dict())
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert "not verified" in last and "all gates pass" not in last


def test_a_long_many_faced_part_is_cropped_to_where_it_meets_and_the_common_is_the_same(monkeypatch):
    """Within the pair budget, a part of many faces reaching far beyond where it can meet the
    other (a long finned bar through a small block) is cropped to that region first (a threaded
    lead screw against its nut: 50 s whole, 20 s cropped); the common is the same solid."""
    from build123d import Box, Pos

    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches, part_geometry
    from procedura_brep.testing.models import cpart

    bar = Box(400, 10, 10)
    for k in range(40):  # 40 fins along the bar: 200+ faces
        bar += Pos(-195 + 10 * k, 0, 7) * Box(2, 10, 4)
    bar_p, block_p = cpart("bar", bar), cpart("block", Pos(100, 0, 0) * Box(12, 30, 30))
    ga, gb = part_geometry(bar_p), part_geometry(block_p)
    assert common_mod.face_count(ga) >= common_mod.TRIM_FACES
    assert common_mod.face_pairs(common_mod.face_boxes(ga), common_mod.face_boxes(gb)) <= TOL.boolean_pair_budget
    crops = []
    real_crop = common_mod.crop
    monkeypatch.setattr(common_mod, "crop", lambda s, lo, hi: crops.append(hi - lo) or real_crop(s, lo, hi))
    clear_caches()
    cropped = common_mod.common(ga, bar_p.shape(), gb, block_p.shape())
    # the bar alone, straight to the block's 12 mm (a part few others meet is not tiled: half
    # of a thread costs far more to cut than its nut's region)
    assert len(crops) == 1 and crops[0][0] < 20
    whole = common_mod.exact_common(bar_p.shape(), block_p.shape())
    assert cropped.exact and len(cropped.solids) == len(whole) >= 1
    assert sum(s.volume for s in cropped.solids) == pytest.approx(sum(s.volume for s in whole), rel=1e-9)
    assert max(s.depth(None) for s in cropped.solids) == pytest.approx(max(s.depth(None) for s in whole), rel=1e-6)
    clear_caches()


def test_the_tiles_of_a_many_faced_part_are_shared_by_the_parts_along_it(monkeypatch):
    """Issue 24.4: n blocks along a finned bar each meet it in a small region. The bar is cut
    into halves, quarters, ... once, and each block's common runs on the smallest tile holding
    its region: the faces all the crops visit grow like n log n, not n times the whole bar's
    (each crop of the whole bar visits its every face); every common is the whole bar's. The
    first few blocks are cropped from the whole bar (a part few others meet is not tiled)."""
    from build123d import Box, Pos

    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches, part_geometry
    from procedura_brep.testing.models import cpart

    bar = Box(640, 10, 10)
    for k in range(64):  # 64 fins along the bar: 300+ faces
        bar += Pos(-315 + 10 * k, 0, 7) * Box(2, 10, 4)
    bar_p = cpart("bar", bar)
    ga = part_geometry(bar_p)
    blocks = [cpart(f"block_{k}", Pos(-300 + 10 * k, 0, 0) * Box(6, 30, 30)) for k in range(60)]
    visited = []
    real_crop = common_mod.crop
    monkeypatch.setattr(common_mod, "crop",
                        lambda s, lo, hi: visited.append(common_mod._face_total(s)) or real_crop(s, lo, hi))
    clear_caches()
    for k, b in enumerate(blocks):
        got = common_mod.common(ga, bar_p.shape(), part_geometry(b), b.shape())
        assert got.exact and got.solids
        if k % 8 == 0 or k == common_mod.DIRECT_CROPS:  # the first tile's common too
            whole = common_mod.exact_common(bar_p.shape(), b.shape())
            assert sum(s.volume for s in got.solids) == pytest.approx(sum(s.volume for s in whole), rel=1e-9)
    clear_caches()
    naive = len(blocks) * common_mod.face_count(ga)
    assert sum(visited) < 0.35 * naive, (sum(visited), naive)


def test_a_many_faced_part_whose_faces_there_end_near_the_region_is_not_cropped(monkeypatch):
    """A wheel of many faces meets its hub in a region its faces there do not reach far beyond
    (the bore, the wheel's side faces no more than four times the region): OCCT skips the other
    faces by their boxes, so a crop would only add a boolean (the rover's gates: 1.7 s with
    the crops, 1.25 s without). The common is the same."""
    import math

    from build123d import Box, Cylinder, Pos, Rot

    from procedura_brep.gates import common as common_mod
    from procedura_brep.gates.geometry import clear_caches, part_geometry
    from procedura_brep.testing.models import cpart

    wheel = Cylinder(50, 20) - Cylinder(15, 20)
    for k in range(40):  # 40 tread blocks round the rim: 200+ faces
        a = 2 * math.pi * k / 40
        wheel += Pos(52 * math.cos(a), 52 * math.sin(a), 0) * Rot(0, 0, math.degrees(a)) * Box(4, 3, 20)
    wheel_p, hub_p = cpart("wheel", wheel), cpart("hub", Cylinder(15.2, 30))
    ga, gb = part_geometry(wheel_p), part_geometry(hub_p)
    assert common_mod.face_count(ga) >= common_mod.TRIM_FACES
    crops = []
    real_crop = common_mod.crop
    monkeypatch.setattr(common_mod, "crop", lambda s, lo, hi: crops.append(hi - lo) or real_crop(s, lo, hi))
    clear_caches()
    got = common_mod.common(ga, wheel_p.shape(), gb, hub_p.shape())
    assert crops == []
    whole = common_mod.exact_common(wheel_p.shape(), hub_p.shape())
    assert got.exact and sum(s.volume for s in got.solids) == pytest.approx(sum(s.volume for s in whole), rel=1e-9)
    assert sum(s.volume for s in whole) > 0
    clear_caches()
