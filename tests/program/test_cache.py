"""The per-part cache: only the edited part and the partners whose features change recompile."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep import kernel
from procedura_brep.program.edit import set_params
from procedura_brep.program.sandbox import CompileOptions, Worker
from procedura_brep.testing.models import rebuilt

LAMP = (Path(__file__).parent / "lamp.py").read_text()


def test_cache_hits_and_invalidation(tmp_path):
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        cold = w.compile(LAMP)
        assert rebuilt(cold) == {"base", "post", "arm"}
        warm = w.compile(LAMP)
        assert rebuilt(warm) == set() and warm.timings["cache_hits"] == 3
        for a, b in zip(cold.parts, warm.parts):
            assert a.brep == b.brep and a.digest == b.digest
        # the revolute's nominal touches post (bore) and arm (pin), not the base
        pin = w.compile(set_params(LAMP, {"pin_d": 9.0}))
        assert rebuilt(pin) == {"post", "arm"}
        # a param only the base reads
        base = w.compile(set_params(LAMP, {"base_w": 130.0}))
        assert rebuilt(base) == {"base"}
        # the spigot nominal changes both halves of post_foot: base (socket) and post (peg)
        spig = w.compile(set_params(LAMP, {"spigot_d": 14.0}))
        assert rebuilt(spig) == {"base", "post"}
        assert kernel.volume(spig.part("post").local_shape()) > kernel.volume(cold.part("post").local_shape())
        # cached results equal a cache-free compile
        fresh = w.compile(set_params(LAMP, {"spigot_d": 14.0}), CompileOptions(cache=False))
        assert rebuilt(fresh) == {"base", "post", "arm"}
        for a, b in zip(fresh.parts, spig.parts):
            assert abs(kernel.volume(a.local_shape()) - kernel.volume(b.local_shape())) < 1e-6
    finally:
        w.close()


def test_adding_a_part_recompiles_it_and_its_parent(tmp_path):
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        w.compile(LAMP)
        added = LAMP.replace("# === frames ===", '''@part(detail="sub", material="brass", description="cap on the post")
def cap():
    return Cylinder(post_d / 2, 5, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===''').replace('frames("arm"', 'frames("cap", foot=Location((0, 0, 0)))\n'
                                              'frames("post", crown=Location((0, 0, post_h)))\nframes("arm"')
        added += 'mate("cap.foot", "post.crown", "seat_face", nominal="pin_d")\n'
        m = w.compile(added)
        assert m.ok, m.findings
        assert rebuilt(m) == {"cap", "post"}
    finally:
        w.close()


def test_module_constants_and_helpers_are_in_the_key(tmp_path):
    """A constant outside the params (read by a part) and a helper class both invalidate."""
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        src = LAMP.replace("# === helpers ===", "# === helpers ===\narm_len = 90\n") \
                  .replace("return Box(90, 14, 10", "return Box(arm_len, 14, 10")
        a = w.compile(src)
        b = w.compile(src.replace("arm_len = 90", "arm_len = 40"))
        assert "arm" in rebuilt(b)
        lo_a, hi_a = kernel.bbox(a.part("arm").local_shape())
        lo_b, hi_b = kernel.bbox(b.part("arm").local_shape())
        assert hi_a[0] - lo_a[0] > hi_b[0] - lo_b[0] + 40
    finally:
        w.close()


def test_docstring_edit_keeps_the_cache(tmp_path):
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        w.compile(LAMP)
        m = w.compile(LAMP.replace('"""Desk lamp', '"""A desk lamp', 1))
        assert rebuilt(m) == set()
    finally:
        w.close()


def _arm_length(model) -> float:
    lo, hi = kernel.bbox(model.part("arm").local_shape())
    return hi[0] - lo[0]


def _volumes(model) -> dict[str, float]:
    return {p.name: round(kernel.volume(p.local_shape()), 6) for p in model.parts}


def test_module_level_object_is_not_cached_stale(tmp_path):
    """``ARM = [Box(...)]`` in the parts section is not in any key: the part is never cached."""
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        a_src = LAMP.replace("# === parts ===", "# === parts ===\nARM = [Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))]") \
                    .replace("return Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))", "return ARM[0]")
        a = w.compile(a_src)
        b = w.compile(a_src.replace("ARM = [Box(90,", "ARM = [Box(40,"))
        assert a.ok and b.ok, (a.findings, b.findings)
        assert abs(_arm_length(a) - 90) < 1 and abs(_arm_length(b) - 40) < 1
        assert "arm" in rebuilt(b) and b.part("arm").cache_key == ""
    finally:
        w.close()


def test_module_object_through_a_default_argument_is_not_cached_stale(tmp_path):
    """``def long_box(b=ARM_BOX)``: the default is evaluated at definition, not in the source."""
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        a_src = LAMP.replace("# === helpers ===", "arm_len = 90.0  # mm, a param\n# === helpers ===\n"
                             "ARM_BOX = Box(arm_len, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))\n"
                             "def arm_box(b=ARM_BOX):\n    return b\n") \
                    .replace("return Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))", "return arm_box()")
        a = w.compile(a_src)
        b = w.compile(a_src.replace("arm_len = 90.0", "arm_len = 40.0"))
        assert a.ok and b.ok, (a.findings, b.findings)
        assert abs(_arm_length(a) - 90) < 1 and abs(_arm_length(b) - 40) < 1
    finally:
        w.close()


def test_a_part_mutating_module_state_is_not_cached(tmp_path):
    """post changes a list arm reads: arm's key (computed before the parts ran) no longer
    describes what it read, so it is not cached and the next program gets its own arm."""
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        base = LAMP.replace("# === helpers ===", "# === helpers ===\nSIZES = [90]\n") \
                   .replace("return Box(90, 14, 10", "return Box(SIZES[-1], 14, 10")
        a_src = base.replace("    p = Cylinder(", "    SIZES.append(40)\n    p = Cylinder(")
        a = w.compile(a_src)
        assert a.ok and abs(_arm_length(a) - 40) < 1
        b = w.compile(base)
        assert b.ok and abs(_arm_length(b) - 90) < 1
    finally:
        w.close()


HOSTILE_AFTER_INNOCENT = [
    ("open_builder", LAMP.replace("# === assembly ===", "# === assembly ===\ndef g():\n"
                                  "    with BuildPart():\n        yield 1\ngen = g()\nnext(gen)")),
    ("table_alias_write", LAMP.replace("# === helpers ===", "# === helpers ===\n"
                                       "t = Solid.shape_constructors\nt[99] = part\n")),
]


@pytest.mark.parametrize("pid, hostile", HOSTILE_AFTER_INNOCENT, ids=[h[0] for h in HOSTILE_AFTER_INNOCENT])
def test_hostile_compile_leaves_nothing_for_the_next_program(tmp_path, pid, hostile):
    """A program that leaves a builder open or writes into build123d's tables fails and
    caches nothing; the innocent program compiled next in the same worker and cache gets its
    own geometry."""
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        bad = w.compile(hostile)
        assert not bad.ok and any(f.code == "policy" for f in bad.findings), bad.findings
        assert not list((tmp_path / "cache").glob("*.brep"))
        good = w.compile(LAMP)
        fresh = w.compile(LAMP, CompileOptions(cache=False))
        assert good.ok and rebuilt(good) == {"base", "post", "arm"}
        assert _volumes(good) == _volumes(fresh)
    finally:
        w.close()


def test_form_feed_is_refused_everywhere():
    """A form feed shifted sections and keys against Python's numbering (stale parts, and an
    edit of pin_d that rewrote pin_depth); now the program is refused with the line."""
    from procedura_brep.errors import EditError
    src = LAMP.replace('"""Desk', '# header\x0c comment\n"""Desk', 1) \
              .replace("pin_d = 8.0", "pin_depth = 5.0  # mm\npin_d = 8.0")
    with pytest.raises(EditError, match=r"line 1: the character '\\x0c'"):
        set_params(src, {"pin_d": 6})


def test_edit_rewrites_only_its_own_line():
    src = LAMP.replace("pin_d = 8.0", "pin_depth = 5.0  # mm\npin_d = 8.0")
    new = set_params(src, {"pin_d": 6})
    diff = [(a, b) for a, b in zip(src.splitlines(), new.splitlines()) if a != b]
    assert diff == [("pin_d = 8.0     # mm, hinge pin: the nominal of the arm's revolute mate",
                     "pin_d = 6.0     # mm, hinge pin: the nominal of the arm's revolute mate")]


def test_edit_refuses_a_size_going_to_zero_or_below():
    from procedura_brep.errors import EditError
    with pytest.raises(EditError, match=r"pin_d = -5 mm: pin_d is a size .* must stay > 0 \(it is 8 now\)"):
        set_params(LAMP, {"pin_d": -5})
    with pytest.raises(EditError, match="base_t = 0 mm"):
        set_params(LAMP, {"base_t": 0})


def test_a_stored_part_carries_its_figures_and_a_hit_uses_them(tmp_path):
    """The parent measures each solid it stores (``<key>.fig``); a compile that hits the cache
    checks the caps on those figures, without reading the BRep back."""
    from procedura_brep.config import SANDBOX
    from procedura_brep.program import cache, caps
    folder = tmp_path / "cache"
    w = Worker(cache_dir=folder)
    try:
        cold = w.compile(LAMP)
        for p in cold.parts:
            fig = cache.load_figures(folder, p.cache_key)
            assert fig == caps.figures_json(caps.measure(kernel.read_brep(p.brep), SANDBOX)), p.name
        # planted: the stored figures of the post claim a billion faces; the hit believes them
        key = cold.part("post").cache_key
        real = (folder / f"{key}.fig").read_text()
        (folder / f"{key}.fig").write_text(real.replace(f'"faces": {cache.load_figures(folder, key)["faces"]}',
                                                        '"faces": 1000000000'))
        big = w.compile(LAMP)
        assert rebuilt(big) == set()
        assert any(f.code == "too-large" and "faces" in f.message for f in big.findings), big.findings
        # figures that do not read as figures: the child measures the solid itself
        (folder / f"{key}.fig").write_text("{not json")
        again = w.compile(LAMP)
        assert again.ok and rebuilt(again) == set()
    finally:
        w.close()


def test_a_measure_stopped_at_a_cap_stores_no_figures(tmp_path):
    from dataclasses import replace

    from procedura_brep.config import SANDBOX
    from procedura_brep.program import cache
    w = Worker(cache_dir=tmp_path / "first")
    try:
        model = w.compile(LAMP)
    finally:
        w.close()
    folder = tmp_path / "second"
    assert cache.store_model(folder, model, replace(SANDBOX, max_part_faces=2)) == 3
    for p in model.parts:
        assert cache.has(folder, p.cache_key) and cache.load_figures(folder, p.cache_key) is None


def test_cache_hits_come_back_by_key_not_as_bytes(tmp_path, monkeypatch):
    """The child names a cached part's key instead of sending its BRep; the parent reads its
    own copy, and the model is the same as with the bytes."""
    from procedura_brep.program import sandbox
    payloads = []
    real = sandbox._read_result
    monkeypatch.setattr(sandbox, "_read_result", lambda *a: payloads.append(real(*a)) or payloads[-1])
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        cold = w.compile(LAMP)
        warm = w.compile(LAMP)
    finally:
        w.close()
    assert all("brep" in p and "cached" not in p for p in payloads[0]["parts"])
    assert all(p == {**p, "cached": True} and "brep" not in p for p in payloads[1]["parts"])
    assert [p.from_cache for p in warm.parts] == [True, True, True]
    assert [p.digest for p in warm.parts] == [p.digest for p in cold.parts]


def test_a_parts_digest_and_shape_follow_its_bytes_and_name(tmp_path):
    """The digest's BRep hash is memoised with the bytes it hashed, and read-back shapes are
    shared by part name and bytes: the same part in the next model, never two parts of one."""
    from dataclasses import replace
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        one, two = w.compile(LAMP), w.compile(LAMP)
    finally:
        w.close()
    post, arm = one.part("post"), one.part("arm")
    before = post.digest
    post.brep = arm.brep
    assert post.digest != before and post.digest == replace(arm, placement=post.placement).digest
    assert two.part("base").local_shape() is one.part("base").local_shape()
    twin = replace(one.part("base"), name="base_twin", _shape=None, _brep_sha=None)
    assert twin.local_shape() is not one.part("base").local_shape()


def _first_and_plain(tmp_path, src: str):
    """A fresh worker's first compile of ``src`` (shared out), then one without the cache."""
    w = Worker(cache_dir=tmp_path / "cache")
    try:
        return w.compile(src), w.compile(src, CompileOptions(cache=False))
    finally:
        w.close()


def _volume(model, name: str) -> float:
    return kernel.volume(model.part(name).local_shape())


def test_a_first_compile_is_shared_out_and_builds_the_same_bytes(tmp_path):
    """A worker's first compile of six or more parts runs in shares first (the prebuild): the
    compile proper then finds every part in the cache, and the parts are byte for byte those
    of a compile without the cache."""
    from procedura_brep.testing.programs import tower
    first, plain = _first_and_plain(tmp_path, tower(8))
    assert first.ok and first.timings["cache_hits"] == 8 and rebuilt(first) == set()
    assert [p.brep for p in first.parts] == [p.brep for p in plain.parts]
    assert [p.placement.tolist() for p in first.parts] == [p.placement.tolist() for p in plain.parts]


def test_a_share_leaves_out_a_part_that_reads_mutable_state_and_one_that_fails(tmp_path):
    """p4 appends to a module list p5 reads, and they land in different shares: p5 is not
    prebuilt (its solid depends on p4 having run), so it comes out as a plain compile builds
    it; a part that raises in its share is reported once, by the compile proper."""
    from procedura_brep.testing.programs import tower
    src = (tower(8, helpers="SIZES = [40]\n")
           .replace("def p4():\n    return block(4)", "def p4():\n    SIZES.append(24)\n    return block(4)")
           .replace("def p5():\n    return block(5)",
                    "def p5():\n    return block(5) + Box(SIZES[-1], 2, 2)")
           .replace("def p6():\n    return block(6)", "def p6():\n    return block(6) + undefined_name"))
    first, plain = _first_and_plain(tmp_path, src)
    assert [f.part for f in first.findings if f.code == "part-exception"] == ["p6"], first.findings
    assert "undefined_name" in next(f.message for f in first.findings if f.part == "p6")
    assert abs(_volume(first, "p5") - _volume(plain, "p5")) < 1e-6
    assert "p5" in rebuilt(first) and first.timings["cache_hits"] >= 5
