"""The per-part cache: only the edited part and the partners whose features change recompile."""

from __future__ import annotations

from pathlib import Path

from procedura_brep import kernel
from procedura_brep.program.edit import set_params
from procedura_brep.program.sandbox import CompileOptions, Worker

LAMP = (Path(__file__).parent / "lamp.py").read_text()


def rebuilt(model) -> set[str]:
    return {k.split(":", 1)[1] for k in model.timings if k.startswith("part:")}


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
