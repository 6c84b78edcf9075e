"""Part keys that survive splices: a part misses the cache only when what it reads changes."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep import kernel
from procedura_brep.program.edit import set_params
from procedura_brep.program.sandbox import CompileOptions, Worker
from procedura_brep.program.splice import splice
from procedura_brep.testing.models import compiled, rebuilt
from procedura_brep.testing.programs import reply_text, tower, tower_reply

LAMP = (Path(__file__).parent / "lamp.py").read_text()
ALL = {"base", "post", "arm"}


@pytest.fixture(scope="module")
def cached_worker(tmp_path_factory):
    w = Worker(cache_dir=tmp_path_factory.mktemp("cache"))
    yield w
    w.close()


@pytest.fixture
def w(cached_worker):
    """The module's worker with an empty part cache."""
    for f in Path(cached_worker.cache_dir).glob("*.brep"):
        f.unlink()
    return cached_worker


def helpers(src: str, text: str) -> str:
    return src.replace("# === helpers ===\n", "# === helpers ===\n" + text, 1)


def volumes(model) -> dict[str, float]:
    return {p.name: round(kernel.volume(p.local_shape()), 6) for p in model.parts}


def test_unused_helper_param_constant_and_class_keep_every_hit(w):
    compiled(LAMP, worker=w)
    src = helpers(LAMP, "def unused(x):\n    return Box(x, x, x)\n\nUNUSED = 3\n\n"
                        "class Spare:\n    size = 4\n") \
        .replace("pin_d = 8.0", "knob_d = 6.0  # mm, not read by any part\npin_d = 8.0")
    m = compiled(src, worker=w)
    assert rebuilt(m) == set() and m.timings["cache_hits"] == 3


# base reaches edge_r through rounded (helper -> helper); post reaches cap_len; arm neither
HELPED = helpers(LAMP, "def edge_r():\n    return 6\n\ndef rounded(b):\n"
                       "    return fillet(b.edges().filter_by(Axis.Z), radius=edge_r())\n\n"
                       "def cap_len():\n    return 1.0\n\n") \
    .replace("    return fillet(b.edges().filter_by(Axis.Z), radius=6)", "    return rounded(b)") \
    .replace("length=1.0)", "length=cap_len())")


def test_a_changed_helper_misses_exactly_the_parts_that_reach_it(w):
    first = compiled(HELPED, worker=w)
    assert rebuilt(first) == ALL
    deep = compiled(HELPED.replace("    return 6\n", "    return 3\n"), worker=w)
    assert rebuilt(deep) == {"base"}  # through rounded -> edge_r
    assert volumes(deep)["base"] > volumes(first)["base"]  # a smaller fillet leaves more
    mid = compiled(HELPED.replace("radius=edge_r())", "radius=edge_r() + 1)"), worker=w)
    assert rebuilt(mid) == {"base"}
    cap = compiled(HELPED.replace("    return 1.0\n", "    return 2.0\n"), worker=w)
    assert rebuilt(cap) == {"post"}


def test_a_changed_constant_misses_only_its_readers(w):
    src = helpers(LAMP, "ARM_LEN = 90\n\ndef arm_box():\n"
                        "    return Box(ARM_LEN, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))\n\n") \
        .replace("    return Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))",
                 "    return arm_box()")
    compiled(src, worker=w)
    short = compiled(src.replace("ARM_LEN = 90", "ARM_LEN = 60"), worker=w)
    assert rebuilt(short) == {"arm"}
    lo, hi = kernel.bbox(short.part("arm").local_shape())
    assert abs(hi[0] - lo[0] - 60) < 1
    # base_t is read by base and by base's frame: only base (its socket moved) misses
    thick = compiled(set_params(src, {"base_t": 15.0}), worker=w)
    assert rebuilt(thick) == {"base"}


def test_a_changed_base_class_misses_the_parts_using_the_subclass(w):
    src = helpers(LAMP, "class Bar:\n    def length(self):\n        return 90\n\n"
                        "class ArmBar(Bar):\n    width = 14\n\n") \
        .replace("    return Box(90, 14, 10,", "    return Box(ArmBar().length(), ArmBar.width, 10,")
    compiled(src, worker=w)
    m = compiled(src.replace("        return 90\n", "        return 50\n"), worker=w)
    assert rebuilt(m) == {"arm"}
    lo, hi = kernel.bbox(m.part("arm").local_shape())
    assert abs(hi[0] - lo[0] - 50) < 1


def test_material_and_description_edits_keep_the_cache(w):
    compiled(LAMP, worker=w)
    src = LAMP.replace('material="painted_aluminium", description="arm swinging',
                       'material="brass", description="a brass arm swinging')
    m = compiled(src, worker=w)
    assert rebuilt(m) == set()
    assert m.part("arm").material == "brass"


@pytest.mark.parametrize("statement", [
    "for k in range(2):\n    len([k])\n",
    "len([1, 2])\n",
    "try:\n    pass\nexcept ValueError:\n    pass\n",
    "from math import *\n",
], ids=["loop-of-calls", "bare-call", "try", "star-import"])
def test_opaque_module_code_makes_every_key_whole_program(w, statement):
    """Module code the keys cannot see through: the same program hits, any edit misses all."""
    src = helpers(LAMP, statement)
    compiled(src, worker=w)
    again = compiled(src, worker=w)
    assert rebuilt(again) == set()
    edited = compiled(helpers(src, "def unused():\n    return 1\n\n"), worker=w)
    assert rebuilt(edited) == ALL


def test_declarations_in_a_loop_keep_per_part_keys(w):
    """golden/rover declares frames and mates in loops: those stay visible to the keys."""
    src = LAMP.replace('frames("base", top=Location((0, 0, base_t)))',
                       'for name in ("base",):\n    frames(name, top=Location((0, 0, base_t)))')
    compiled(src, worker=w)
    assert rebuilt(compiled(helpers(src, "def unused():\n    return 1\n\n"), worker=w)) == set()
    assert rebuilt(compiled(set_params(src, {"pin_d": 9.0}), worker=w)) == {"post", "arm"}


def test_splicing_part_k_plus_1_recompiles_it_and_its_partner(w):
    k = 4
    compiled(tower(k), worker=w)
    spliced = splice(tower(k), tower_reply(k)).source
    m = compiled(spliced, worker=w)
    assert rebuilt(m) == {f"p{k - 1}", f"p{k}"}  # the new block and the socket cut below it
    fresh = compiled(tower(k + 1), worker=w, cache=False)
    assert rebuilt(fresh) == {f"p{i}" for i in range(k + 1)}
    assert volumes(m) == volumes(fresh)


def test_a_splice_with_its_own_helper_and_param_recompiles_only_it_and_its_partner(w):
    k = 3
    compiled(tower(k), worker=w)
    body = ('@part(detail="sub", material="brass", description="knob on the top block")\n'
            "def knob():\n    return knob_body()\n")
    reply = reply_text(part="knob", params=["knob_d = 14.0  # mm, knob diameter"],
                       helpers=("def knob_body():\n    return Cylinder(knob_d / 2, 9, "
                                "align=(Align.CENTER, Align.CENTER, Align.MIN))\n"),
                       body=body, frames=['frames("knob", foot=Location((0, 0, 0)))'],
                       mates=[(f'mate("knob.foot", "p{k - 1}.top", "peg_socket", nominal="peg_d", '
                               'fit="clearance", depth=5)')])
    m = compiled(splice(tower(k), reply).source, worker=w)
    assert rebuilt(m) == {f"p{k - 1}", "knob"}


def test_cached_parts_equal_a_cache_free_compile_after_edits(w):
    compiled(HELPED, worker=w)
    src = helpers(HELPED.replace("    return 6\n", "    return 4\n"), "def unused():\n    return 1\n\n")
    warm = compiled(src, worker=w)
    assert rebuilt(warm) == {"base"}
    cold = w.compile(src, CompileOptions(cache=False))
    assert volumes(warm) == volumes(cold)


def test_material_declarations_keep_per_part_keys(w):
    """A program's own material(...) lines never reach a solid: they keep per-part keys, so a
    helper added later still rebuilds nothing and a param edit only its readers."""
    src = LAMP.replace("# === parts ===\n", "# === parts ===\nmaterial(\"lamp_red\", base=\"painted_steel\", "
                                            "rgb=(0.8, 0.1, 0.1))\n", 1)
    assert "lamp_red" in src
    compiled(src, worker=w)
    assert rebuilt(compiled(helpers(src, "def unused():\n    return 1\n\n"), worker=w)) == set()
    assert rebuilt(compiled(set_params(src, {"pin_d": 9.0}), worker=w)) == {"post", "arm"}


def test_a_helper_bound_to_a_library_function_by_default_keeps_its_cache(w):
    """``def t(..., maker=lead_screw)`` binds a transmission helper where a part of the same
    name cannot hide it (a recorded linear stage did): library code, covered by the engine
    digest, so the part keeps its cache (it rebuilt a 22 s thread on every step); a default
    that is a program object (a list built at module level) still gets no key."""
    src = helpers(LAMP, "def sized(x, maker=Cylinder, rounder=math.floor):\n"
                        "    return maker(rounder(x) / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))\n\n")
    src = src.replace("    p = Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))",
                      "    p = sized(post_d)")
    assert "p = sized(post_d)" in src
    compiled(src, worker=w)
    again = compiled(src, worker=w)
    assert rebuilt(again) == set() and again.timings["cache_hits"] == 3
    assert rebuilt(compiled(src.replace("rounder=math.floor", "rounder=math.ceil"), worker=w)) == {"post"}
    opaque = src.replace("def sized(x, maker=Cylinder, rounder=math.floor):",
                         "SHAPES = [Cylinder]\n\ndef sized(x, maker=SHAPES, rounder=math.floor):\n    maker = maker[0]")
    compiled(opaque, worker=w)
    assert "post" in rebuilt(compiled(opaque, worker=w))  # no key: rebuilt on every compile
