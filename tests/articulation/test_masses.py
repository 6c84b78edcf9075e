"""Part masses by declaration: solid, ``mass=`` (density scaled), ``hollow=`` (a shell: exact
from OCCT's offset, else the thin-shell approximation, with the method recorded)."""

from __future__ import annotations

import faulthandler
import math
import os
import signal
import time

import numpy as np
import pytest
from build123d import Align, Box, Cylinder, Pos, Rot

from procedura_brep.articulation import shell
from procedura_brep.articulation.mass import mass_report, part_mass, part_mass_detail
from procedura_brep.program.model import CompiledModel
from procedura_brep.testing.models import cpart

ALU = 2700.0  # kg/m^3, the built-in aluminium
CENTRED = (Align.CENTER, Align.CENTER, Align.CENTER)


def placed(x: float, y: float, z: float, deg: float = 0.0) -> np.ndarray:
    """A rigid placement (mm): a turn about Z then a shift."""
    a = np.radians(deg)
    m = np.eye(4)
    m[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    m[:3, 3] = (x, y, z)
    return m


def model(*parts) -> CompiledModel:
    for p in parts:
        p.material = "aluminium"
    return CompiledModel(name="m", params={}, parts=list(parts), mates=[])


@pytest.fixture(autouse=True)
def _fresh_shells(monkeypatch):
    monkeypatch.setattr(shell, "_CACHE", {})
    monkeypatch.setattr(shell, "_SPENT", [0.0])


def test_a_declared_mass_scales_the_density_and_keeps_com_and_inertia_shape():
    body = Box(200, 80, 40) + Pos(90, 0, 30) * Cylinder(15, 40)  # an off-centre lump
    p = cpart("body", body, placed(100, -50, 20, deg=30))
    m = model(p)
    solid = part_mass(m, "body")
    p.mass = 1.25
    got = part_mass_detail(m, "body")
    assert got.method == "declared"
    assert got.props.mass == pytest.approx(1.25, rel=1e-12)
    assert np.allclose(got.props.com, solid.com, rtol=0, atol=1e-12)
    assert np.allclose(got.props.inertia, solid.inertia * (1.25 / solid.mass), rtol=1e-12, atol=0)
    assert solid.mass == pytest.approx(body.volume * ALU * 1e-9, rel=1e-9)


def test_a_declared_mass_is_shared_by_a_painted_part_and_its_blocks():
    part = cpart("body", Box(100, 100, 20))
    stripe = cpart("body_stripe", Pos(0, 0, 15) * Box(100, 20, 10))
    stripe.block_of = "body"
    m = model(part, stripe)
    stripe.material = "steel"
    solid = {n: part_mass(m, n).mass for n in ("body", "body_stripe")}
    part.mass = 3.0
    got = {n: part_mass_detail(m, n) for n in ("body", "body_stripe")}
    assert {g.method for g in got.values()} == {"declared"}
    assert sum(g.props.mass for g in got.values()) == pytest.approx(3.0, rel=1e-12)
    assert got["body"].props.mass / got["body_stripe"].props.mass == pytest.approx(
        solid["body"] / solid["body_stripe"], rel=1e-12)


def test_a_painted_shell_is_the_unpainted_part_s_shell_shared_with_its_blocks():
    from procedura_brep import kernel
    whole = Box(100, 100, 100, align=CENTRED)
    region = Pos(0, 0, 40) * Box(100, 100, 20, align=CENTRED)  # the top 20 mm, painted
    part = cpart("body", whole - region)
    block = cpart("body_top", whole & region)
    block.block_of = "body"
    part.unpainted = kernel.write_brep(whole.wrapped)
    part.hollow = 5.0
    m = model(part, block)
    block.material = "rubber"
    got = {n: part_mass_detail(m, n) for n in ("body", "body_top")}
    assert {g.method for g in got.values()} == {"shell-exact"}
    assert sum(g.props.mass for g in got.values()) == pytest.approx((100**3 - 90**3) * ALU * 1e-9, rel=1e-6)
    solid = {n: part_mass(model(cpart("a", whole - region), cpart("b", whole & region)), k).mass
             for n, k in (("body", "a"), ("body_top", "b"))}
    solid["body_top"] *= 1200 / ALU  # rubber
    assert got["body"].props.mass / got["body_top"].props.mass == pytest.approx(
        solid["body"] / solid["body_top"], rel=1e-9)
    assert "shared with its paint blocks" in got["body_top"].note


def test_hollow_box_is_the_exact_shell():
    p = cpart("box", Box(100, 100, 100, align=CENTRED), placed(500, 0, 0, deg=45))
    p.hollow = 5.0
    got = part_mass_detail(model(p), "box")
    assert got.method == "shell-exact" and got.note == ""
    shell_mm3 = 100**3 - 90**3
    assert got.props.mass == pytest.approx(shell_mm3 * ALU * 1e-9, rel=1e-6)
    assert np.allclose(got.props.com, [0.5, 0, 0], atol=1e-9)
    # about its centre a cube's inertia is isotropic: (a^5 - b^5) / 6 per unit density
    i_kgm2 = (100**5 - 90**5) / 6 * ALU * 1e-9 * 1e-6
    assert np.allclose(got.props.inertia, np.eye(3) * i_kgm2, rtol=1e-6, atol=1e-12)


def _cut_corner(d: float):
    """A big box whose face is the plane x + z = d * sqrt(2) (for cutting a box's edge)."""
    c = d + 200
    return Pos(c / math.sqrt(2), 0, c / math.sqrt(2)) * Rot(0, -45, 0) * Box(400, 400, 400)


def test_hollow_of_an_off_centre_solid_matches_the_shell_cut_by_a_boolean():
    # a convex box with one edge cut off: its inward offset is every face plane moved in by
    # the wall, and its centre is not the solid's, so the subtraction's parallel-axis terms
    # count; the shell is checked against OCCT's boolean of the two
    d = 60 / math.sqrt(2)
    body = Box(100, 100, 100) - _cut_corner(d)
    cavity = Box(90, 90, 90) - _cut_corner(d - 5)
    want = shell.volume_integrals((body - cavity).wrapped)
    pose = placed(10, 20, 30, deg=90)
    p = cpart("box", body, pose)
    p.hollow = 5.0
    got = part_mass_detail(model(p), "box")
    assert got.method == "shell-exact"
    rho = ALU * 1e-9
    assert got.props.mass == pytest.approx(want.volume * rho, rel=1e-6)
    r = pose[:3, :3]
    assert np.allclose(got.props.com, (r @ want.com + pose[:3, 3]) / 1000, rtol=0, atol=1e-9)
    assert abs(want.com[0]) > 1  # the cut moves the centre
    assert np.allclose(got.props.inertia, r @ want.inertia @ r.T * rho * 1e-6, rtol=1e-6, atol=1e-12)


def _forced(monkeypatch, fn) -> None:
    monkeypatch.setattr(shell, "exact_shell", fn)


def test_the_approximation_is_used_and_named_when_the_offset_fails(monkeypatch):
    _forced(monkeypatch, lambda shape, wall: "OCCT's inward offset is not a valid shape")
    p = cpart("box", Box(100, 100, 100, align=CENTRED))
    p.hollow = 5.0
    got = part_mass_detail(model(p), "box")
    assert got.method == "shell-approx"
    assert got.note == "OCCT's inward offset is not a valid shape"
    assert got.props.mass == pytest.approx(6 * 100**2 * 5 * ALU * 1e-9, rel=1e-9)  # area x wall
    # a thin-walled cube about a central axis: 2 end faces a^4/6 + 4 side faces (a^4/12 + a^4/4)
    i_surface = 5 / 3 * 100**4
    assert got.props.inertia[0, 0] == pytest.approx(i_surface * 5 * ALU * 1e-15, rel=1e-6)


def test_a_crashing_offset_is_a_note_not_a_dead_process(monkeypatch):
    def segfault(shape, wall):
        faulthandler.disable()  # pytest's: it would print the child's stack
        os.kill(os.getpid(), signal.SIGSEGV)

    _forced(monkeypatch, segfault)
    p = cpart("box", Box(100, 100, 100))
    p.hollow = 5.0
    got = part_mass_detail(model(p), "box")
    assert (got.method, got.note) == ("shell-approx", "OCCT's inward offset crashed")


def test_a_slow_offset_is_cut_at_the_wall_clock_limit(monkeypatch):
    monkeypatch.setattr(shell, "EXACT_WALL_S", 1.0)
    _forced(monkeypatch, lambda shape, wall: time.sleep(30))
    p = cpart("box", Box(100, 100, 100))
    p.hollow = 5.0
    t = time.perf_counter()
    got = part_mass_detail(model(p), "box")
    assert time.perf_counter() - t < 10
    assert (got.method, got.note) == ("shell-approx", "OCCT's inward offset took over 1 s")


def test_the_exact_shells_of_a_process_share_one_time_budget(monkeypatch):
    monkeypatch.setattr(shell, "EXACT_BUDGET_S", 1.5)
    _forced(monkeypatch, lambda shape, wall: time.sleep(30))
    boxes = [cpart(f"b{k}", Box(100, 100, 100 + k)) for k in range(3)]
    for b in boxes:
        b.hollow = 5.0
    m = model(*boxes)
    t = time.perf_counter()
    notes = [part_mass_detail(m, b.name).note for b in boxes]
    assert time.perf_counter() - t < 10
    assert notes[0] == "OCCT's inward offset took over 1.5 s"
    assert notes[1:] == ["this process spent its 1.5 s for exact shells (EXACT_BUDGET_S)"] * 2


def test_a_wrong_offset_is_checked_not_trusted():
    # a box with a through hole: OCCT 8.0.1's inward offset of it is not a valid shape (its
    # volume is the hole's alone); the shell falls back to area x wall and says why
    body = Box(100, 100, 100) - Pos(30, 0, 0) * Cylinder(10, 100)
    p = cpart("box", body)
    p.hollow = 5.0
    got = part_mass_detail(model(p), "box")
    exact = 100**3 - math.pi * 10**2 * 100 - (90**3 - math.pi * 15**2 * 90)
    if got.method == "shell-exact":  # a later OCCT that offsets it right
        assert got.props.mass == pytest.approx(exact * ALU * 1e-9, rel=1e-6)
    else:
        assert (got.method, got.note) == ("shell-approx", "OCCT's inward offset is not a valid shape")
        assert got.props.mass == pytest.approx(body.area * 5 * ALU * 1e-9, rel=1e-9)


def test_a_wall_not_under_the_half_thickness_weighs_solid_with_a_warning():
    plate = cpart("plate", Box(200, 200, 8))  # half-thickness volume/area = 3.7 mm
    plate.hollow = 4.0
    m = model(plate)
    got = part_mass_detail(m, "plate")
    assert got.method == "solid" and "hollow=4 mm is not less than the part's mean half-thickness" in got.note
    assert got.props.mass == pytest.approx(200 * 200 * 8 * ALU * 1e-9, rel=1e-9)
    section, findings = mass_report(m)
    assert [(f.code, f.part, f.severity) for f in findings] == [("part-hollow", "plate", "warning")]
    assert section["parts"][0]["note"] == got.note


def test_the_report_section_lists_every_part_and_the_total():
    a = cpart("a", Box(100, 100, 100, align=CENTRED))
    b = cpart("b", Box(50, 50, 50, align=CENTRED), placed(0, 0, 300))
    b.mass = 2.0
    a.hollow = 5.0
    section, findings = mass_report(model(a, b))
    assert findings == []
    rows = {r["name"]: r for r in section["parts"]}
    assert (rows["a"]["method"], rows["a"]["hollow_mm"]) == ("shell-exact", 5.0)
    assert (rows["b"]["method"], rows["b"]["declared_kg"], rows["b"]["mass_kg"]) == ("declared", 2.0, 2.0)
    m_a = rows["a"]["mass_kg"]
    total = section["total"]
    assert total["mass_kg"] == pytest.approx(m_a + 2.0, rel=1e-12)
    assert total["com_m"] == pytest.approx([0, 0, 0.3 * 2.0 / (m_a + 2.0)], abs=1e-12)
    assert section["frame"] == "world" and section["units"]["inertia"] == "kg m^2"
    izz = rows["a"]["inertia_kg_m2"][2][2] + rows["b"]["inertia_kg_m2"][2][2]
    assert total["inertia_kg_m2"][2][2] == pytest.approx(izz, rel=1e-12)  # both on the Z axis


def test_floored_moments_survive_the_six_digits_an_mjcf_file_keeps():
    """A lamina's moments sit on the triangle inequality (C = A + B) and a slender part's nearly
    so; rounded to the 6 significant digits MuJoCo's XML writer keeps they tipped over and the
    written model.xml was refused ("inertia must satisfy A + B >= C": a recorded lead screw's,
    1.63693e-06 + 0.00342787 < 0.00342951). floored() keeps a margin that rounding cannot eat."""
    from procedura_brep.articulation.mass import MassProps, floored

    rng = np.random.default_rng(3)
    cases = [np.array([1.63693e-06, 0.00342787, 0.00342787 + 1.63693e-06])]
    cases += [np.array([a, b, a + b]) for a, b in rng.uniform(1e-7, 1e-2, (300, 2))]
    for w in cases:
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        got, _ = floored(MassProps(1.0, np.zeros(3), q @ np.diag(w) @ q.T)).principal()
        r = np.array([float(f"{x:g}") for x in got])  # what to_xml writes
        for k in range(3):
            assert r[k] <= r.sum() - r[k], (w, got, r)
        # barely moved: by the margin (2e-5 of the largest) and the floor at most
        assert np.all(np.abs(np.sort(got) - np.sort(w)) <= 2.1e-5 * w.max() + 2e-9)
