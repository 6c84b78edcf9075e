from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep.gates.connectivity import analyse, connectivity_gate
from procedura_brep.gates.geometry import CONNECT_MM, part_geometry
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledModel
from procedura_brep.testing.models import cpart


def _box(x, y, z):
    from build123d import Align, Box
    return Box(x, y, z, align=(Align.MIN, Align.MIN, Align.MIN))


def _model(*parts):
    return CompiledModel(name="m", params={}, parts=list(parts), mates=[])


def test_thin_detached_panel_is_caught():
    # the paper's worst case: 70 % span, ~1.9 % volume, clearly detached
    body = cpart("body", _box(100, 50, 50))
    panel = cpart("panel", _box(70, 50, 1.36), trans(15, 0, 55))
    conn = analyse(_model(body, panel))
    assert conn.n_vis == 1
    (fl,) = conn.floaters
    assert fl.parts == ["panel"] and fl.rho == pytest.approx(0.7, abs=1e-3)
    assert fl.volume / conn.components[conn.body].volume == pytest.approx(0.019, abs=1e-3)
    findings, res = connectivity_gate(_model(body, panel))
    assert not res.passed and findings[0].part == "panel"
    assert "bbox (15.0, 0.0, 55.0)..(85.0, 50.0, 56.4)" in findings[0].message
    assert findings[0].value == pytest.approx(0.7, abs=1e-3) and findings[0].limit == 0.01


def test_tiny_detached_piece_below_tau_is_not_counted():
    body = cpart("body", _box(100, 50, 50))
    crumb = cpart("crumb", _box(0.5, 0.5, 0.5), trans(120, 0, 0))
    conn = analyse(_model(body, crumb))
    assert len(conn.components) == 2
    assert conn.n_vis == 0  # rho = 0.5 / 120 < 0.01


def test_face_to_face_parts_are_connected():
    a = cpart("a", _box(100, 50, 50))
    b = cpart("b", _box(30, 30, 80), trans(10, 10, 50))   # sits on a's top face
    c = cpart("c", _box(20, 50, 20), trans(100, 0, 0))     # against a's +x face
    conn = analyse(_model(a, b, c))
    assert len(conn.components) == 1 and conn.n_vis == 0


def test_fit_clearance_counts_as_contact(make_peg):
    # lifted 0.1 mm: the shoulder and the peg's tip are clear (0.1 mm > CONNECT_MM, and the tip
    # sits over the socket's relief), so the only contact left is the peg's wall across the
    # H7/g6 radial clearance (8.5 um per side at d = 10)
    model = make_peg(10.0, "clearance", lift=0.1)
    gap = model.mates[0].fit["offset"]
    assert 0 < gap < CONNECT_MM
    assert len(analyse(model).components) == 1
    # the same fixture falls apart once contact is tighter than the clearance: this test can fail
    assert len(analyse(model, contact=gap / 2).components) == 2


def test_part_of_two_disjoint_solids_is_two_pieces():
    body = cpart("body", _box(100, 50, 50))
    twin = _box(10, 10, 10) + _box(10, 10, 10).translate((50, 0, 0))
    conn = analyse(_model(body, cpart("twin", twin, trans(0, 0, 50))))
    # both blocks of the twin sit on the body's top face
    assert len(conn.components) == 1
    conn = analyse(_model(body, cpart("twin", twin, trans(0, 0, 60))))
    assert len(conn.components) == 3 and conn.n_vis == 2
    assert [f.parts for f in conn.floaters] == [["twin"], ["twin"]]


def test_delta_aware_variant_rejects_only_an_increase():
    body = cpart("body", _box(100, 50, 50))
    panel = cpart("panel", _box(70, 50, 2), trans(15, 0, 55))
    model = _model(body, panel)
    findings, res = connectivity_gate(model, baseline=1)
    assert res.passed and res.measured["n_vis"] == 1
    assert [f.severity for f in findings] == ["warning"]
    findings, res = connectivity_gate(model, baseline=0)
    assert not res.passed and findings[0].code == "floater-increase"
    assert findings[0].value == 1 and findings[0].limit == 0


GOLDEN = Path(__file__).resolve().parents[2] / "golden"


def _goldens() -> list[Path]:
    return sorted(GOLDEN.glob("*/program.py")) if GOLDEN.is_dir() else []


@pytest.mark.slow
@pytest.mark.skipif(not _goldens(), reason="no golden/*/program.py yet")
@pytest.mark.parametrize("program", _goldens(), ids=lambda p: p.parent.name)
def test_golden_programs_have_no_visible_floaters(program: Path):
    from procedura_brep.program import compile_source

    model = compile_source(program.read_text(), name=program.parent.name)
    assert model.ok, [f.as_dict() for f in model.findings]
    conn = analyse(model)
    assert conn.n_vis == 0, [c.as_dict() for c in conn.floaters]
    # lifting one leaf part 3 mm clear of its parent along the mate axis makes exactly it float
    leaf = _leaf(model)
    moved = model.part(leaf.child)
    axis = leaf.world_frame[:3, 2]
    below = (part_geometry(moved).vertices - leaf.world_frame[:3, 3]) @ axis
    moved.placement = trans(*((3.0 + max(0.0, -below.min())) * axis)) @ moved.placement
    conn = analyse(model)
    assert conn.n_vis == 1 and conn.floaters[0].parts == [leaf.child]


def _leaf(model):
    """The largest child of a static mate that is nobody's parent and has no other mate."""
    parents = {m.parent for m in model.mates}
    leaves = [m for m in model.mates if m.kind == "static" and m.child not in parents
              and sum(m.child in (k.child, k.parent) for k in model.mates) == 1]
    if not leaves:
        pytest.skip("no leaf static mate in this golden program")
    return max(leaves, key=lambda m: part_geometry(model.part(m.child)).pieces[0].span)


def test_hollow_solid_with_inner_void_is_one_body():
    from build123d import Box
    shell = Box(40, 40, 40) - Box(20, 20, 20)  # one solid, two shells (outer + closed void)
    conn = analyse(_model(cpart("hollow", shell)))
    assert len(conn.components) == 1 and conn.n_vis == 0
    assert conn.components[0].volume == pytest.approx(40**3 - 20**3, rel=1e-6)


def test_box_pairs_match_brute_force():
    import itertools

    import numpy as np

    from procedura_brep.gates.geometry import box_pairs

    rng = np.random.default_rng(7)
    for _ in range(30):
        n, m = int(rng.integers(1, 50)), int(rng.integers(1, 30))
        lo, lo2 = rng.uniform(0, 10, (n, 3)), rng.uniform(0, 10, (m, 3))
        hi, hi2 = lo + rng.uniform(0, 3, (n, 3)), lo2 + rng.uniform(0, 5, (m, 3))
        g = float(rng.uniform(0, 0.5))

        def near(a, b, c, d, g=g):
            return bool(np.all(a - g <= d) and np.all(c - g <= b))

        one = {(i, j) for i, j in itertools.combinations(range(n), 2)
               if near(lo[i], hi[i], lo[j], hi[j])}
        two = {(i, j) for i in range(n) for j in range(m) if near(lo[i], hi[i], lo2[j], hi2[j])}
        assert {tuple(p) for p in box_pairs(lo, hi, g).tolist()} == one
        assert {tuple(p) for p in box_pairs(lo, hi, g, lo2, hi2).tolist()} == two


def test_a_row_of_separate_boxes_along_y_is_many_pieces_and_no_pairs():
    from build123d import Box, Compound, Pos

    from procedura_brep.gates.geometry import box_pairs

    row = Compound([Pos(0, 2 * i, 0) * Box(1, 1, 1) for i in range(200)])
    geo = part_geometry(cpart("row", row))
    assert len(geo.pieces) == 200 and len({p.solid for p in geo.pieces}) == 200
    lo = [p.lo for p in geo.pieces]
    hi = [p.hi for p in geo.pieces]
    assert len(box_pairs(lo, hi, CONNECT_MM)) == 0
    assert len(box_pairs(lo, hi, 1.0)) == 199  # neighbours 1 mm apart
    assert len(analyse(_model(cpart("row", row))).components) == 200
