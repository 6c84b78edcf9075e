"""Twins: parts whose functions differ only in name, reading the same values and given the same
mate features, share a key; a compile builds their solid once, and so does a cold prebuild."""

from __future__ import annotations

import numpy as np

from procedura_brep import kernel
from procedura_brep.program.sandbox import CompileOptions, Worker
from procedura_brep.testing.models import compiled, rebuilt

LEGS = ("leg_a", "leg_b", "leg_c", "leg_d", "leg_e")
CORNERS = ((-60, -30), (60, -30), (-60, 30), (60, 30), (0, 0))


def table(*, leg_e: str = "return leg(1)", e_frame: str = "(0, 0, 0)", pads: bool = False) -> str:
    """A table top on five legs; each leg's foot is a peg in a socket of the top (a mate
    feature on both). leg_a..leg_d are twins (``return leg(1)``, the same foot frame). With
    ``pads``, each leg's far end holds a pad pressed on a pin (twins too, each pair the same
    but for where it stands)."""
    legs = "\n".join(f'@part(detail="major", material="wood", description="leg {n[-1]}")\n'
                     f"def {n}():\n    {leg_e if n == 'leg_e' else 'return leg(1)'}\n"
                     for n in LEGS)
    if pads:
        legs += "\n".join(f'@part(detail="sub", material="rubber", description="pad {n[-1]}")\n'
                          f"def pad_{n[-1]}():\n    return pad()\n" for n in LEGS)
    corners = "\n".join(f'frames("top", s_{n}=Location(({x}, {y}, 0), (180, 0, 0)))'
                        for n, (x, y) in zip(LEGS, CORNERS))
    feet = "\n".join(f'frames("{n}", foot=Location({e_frame if n == "leg_e" else "(0, 0, 0)"}), '
                     f"toe=Location((0, 0, leg_h)))" for n in LEGS)
    mates = "\n".join(f'mate("{n}.foot", "top.s_{n}", "peg_socket", nominal="peg_d", fit="location")'
                      for n in LEGS)
    if pads:
        feet += "\n" + "\n".join(f'frames("pad_{n[-1]}", seat=Location((0, 0, 0)))' for n in LEGS)
        mates += "\n" + "\n".join(f'mate("pad_{n[-1]}.seat", "{n}.toe", "press_fit", nominal="pin_d", '
                                   f'fit="press")' for n in LEGS)
    return f'''"""A small table. Hand-written test program (procedura-brep format)."""
from procedura_brep.program import *

# === params ===
top_t = 12.0  # mm
leg_h = 70.0  # mm
peg_d = 8.0   # mm
pin_d = 5.0   # mm

# === helpers ===
def leg(k):
    return Box(16 * k, 16, leg_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

def pad():
    return Cylinder(10, 4, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === parts ===
@part(detail="silhouette", material="wood", description="table top")
def top():
    return Box(160, 100, top_t, align=(Align.CENTER, Align.CENTER, Align.MIN))

{legs}
# === frames ===
{corners}
{feet}

# === assembly ===
{mates}
'''


def test_twins_share_a_key_and_are_built_once():
    m = compiled(table(), cache=False)
    keys = {p.name: p.cache_key for p in m.parts}
    assert len({keys[n] for n in LEGS}) == 1 and keys["top"] != keys["leg_a"]
    assert rebuilt(m) == {"top", "leg_a"}  # leg_b..leg_e took leg_a's final solid
    assert m.timings["twins"] == 4 and m.timings["parts_built"] == 2
    legs = [m.part(n) for n in LEGS]
    assert len({p.brep for p in legs}) == 1
    assert len({tuple(p.placement[:3, 3].round(6)) for p in legs}) == 5  # each at its corner
    # the solid a twin takes is the one it builds on its own: a comment makes leg_e's text
    # differ, so it is no twin and is run
    own = compiled(table(leg_e="return leg(1)  # own text"), cache=False)
    assert "leg_e" in rebuilt(own) and own.part("leg_e").brep == m.part("leg_a").brep
    # with its peg, the leg is more than the bare box (the mate feature is in the shared solid)
    assert kernel.volume(m.part("leg_b").local_shape()) > 16 * 16 * 70


def test_a_different_value_or_mate_frame_is_no_twin():
    other = compiled(table(leg_e="return leg(2)"), cache=False)
    assert "leg_e" in rebuilt(other) and other.part("leg_e").cache_key != other.part("leg_a").cache_key
    moved = compiled(table(e_frame="(4, 0, 0)"), cache=False)  # its peg sits elsewhere
    assert "leg_e" in rebuilt(moved) and moved.part("leg_e").brep != moved.part("leg_a").brep


def test_a_twin_of_a_failing_part_reports_its_own_finding():
    src = table().replace("def leg(k):\n", "def leg(k):\n    assert k == 2, 'no such leg'\n")
    from procedura_brep.program.sandbox import default_worker
    m = default_worker().compile(src, CompileOptions(cache=False))
    assert sorted(f.part for f in m.findings if f.code == "part-exception") == sorted(LEGS)


def test_a_cold_prebuild_builds_each_key_once(tmp_path):
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        first = w.compile(table())
        plain = w.compile(table(), CompileOptions(cache=False))
    finally:
        w.close()
    assert first.ok and first.timings["parts_built"] == 2 and first.timings["cache_hits"] == 6
    assert len(list((tmp_path / "cache").glob("*.brep"))) == 2
    assert [p.brep for p in first.parts] == [p.brep for p in plain.parts]


def test_twins_are_tessellated_once_and_each_mesh_is_its_world_mesh(monkeypatch):
    from procedura_brep.program import model as model_mod
    m = compiled(table(), cache=False)
    model_mod.clear_mesh_cache()
    calls: list[str] = []
    real = kernel.tessellate
    monkeypatch.setattr(kernel, "tessellate", lambda shape, **kw: calls.append(kw.get("name", "")) or real(shape, **kw))
    meshes = {p.name: p.mesh() for p in m.parts}
    assert sorted(calls) == ["leg_a", "top"]
    for name in ("leg_a", "leg_d"):  # as OCCT meshes the placed shape itself
        world = real(m.part(name).shape())
        assert len(world.faces) == len(meshes[name].faces)
        ours, theirs = (v[np.lexsort(np.round(v, 6).T)] for v in (meshes[name].vertices, world.vertices))
        assert abs(ours - theirs).max() < 1e-9
    assert abs(meshes["leg_a"].vertices - meshes["leg_d"].vertices).max() > 50  # placed apart
    # a twin's own shape reads as meshed (a face's box is its nodes' box, as for leg_a)
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location
    for name in LEGS:
        assert all(BRep_Tool.Triangulation_s(f, TopLoc_Location()) is not None
                   for f in kernel.faces(m.part(name).local_shape())), name
