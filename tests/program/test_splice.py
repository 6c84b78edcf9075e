"""The five-block part reply and the splice that adds it to a program."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from procedura_brep import kernel
from procedura_brep.program.sections import parse_sections
from procedura_brep.program.splice import SpliceError, empty_program, parse_reply, replace_part, splice
from procedura_brep.testing.tapes import part_replies

ROOT = Path(__file__).parents[2]
LAMP = (Path(__file__).parent / "lamp.py").read_text()

BASE = '''## params
```python
base_t = 12.0  # mm, base thickness
spigot_d = 12.0  # mm, spigot
```
## helpers
```python
def bottom():
    return (Align.CENTER, Align.CENTER, Align.MIN)
```
## body
```python
@part(detail="silhouette", material="cast_iron", description="base")
def base():
    return Box(120, 120, base_t, align=bottom())
```
## frames
```python
frames("base", top=Location((0, 0, base_t)))
```
## mates
none
'''

POST = '''The post sits on the base.

### Params
spigot_d = 12.0  # mm, spigot
post_h = 80.0  # mm, post height

### Helpers
def bottom():
    return (Align.CENTER, Align.CENTER, Align.MAX)

### Body
@part(material="steel", description="post")
def post():
    return Cylinder(10, post_h, align=bottom()) + Pos(0, 0, -1) * Box(30, 30, 2)

### Frames
frames("post", foot=Location((0, 0, 0)))

### Mates
mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")

That is all.
'''


def test_parse_reply_is_tolerant_of_fences_headings_and_prose():
    fenced = parse_reply(BASE)
    assert fenced.params.splitlines()[0].startswith("base_t = 12.0") and fenced.mates == ""
    assert fenced.body.startswith("@part(")
    bare = parse_reply(POST)
    assert bare.mates.startswith('mate("post.foot"') and "That is all" not in bare.mates
    assert "The post sits" not in bare.params
    one_fence = "Sure:\n```python\n# === params ===\nx = 1.0  # mm\n# === helpers ===\n# === body ===\n" \
                "@part()\ndef a():\n    return Box(x, x, x)\n# === frames ===\nframes('a', top=Location())\n" \
                "# === mates ===\n```\nDone."
    r = parse_reply(one_fence)
    assert r.params == "x = 1.0  # mm" and r.helpers == "" and "def a()" in r.body and r.mates == ""


def test_a_missing_or_repeated_block_is_named():
    with pytest.raises(SpliceError, match="missing block.*frames"):
        parse_reply(BASE.replace("## frames", "## framez"))
    with pytest.raises(SpliceError, match="helpers block: the helpers block appears twice"):
        parse_reply(BASE + "\n## helpers\n```python\n```\n")


def test_splice_dedupes_params_and_renames_a_colliding_helper():
    one = splice(empty_program("lamp"), BASE)
    two = splice(one.source, POST)
    assert two.part == "post" and two.dropped_params == ["spigot_d"]
    assert two.renames == {"bottom": "bottom_2"}
    tree = ast.parse(two.source)
    fns = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert set(fns) == {"bottom", "bottom_2", "base", "post"}
    uses = lambda fn: {c.func.id for c in ast.walk(fns[fn]) if isinstance(c, ast.Call)  # noqa: E731 - a one-line probe
                       and isinstance(c.func, ast.Name)}
    assert "bottom_2" in uses("post") and "bottom" in uses("base") and "bottom_2" not in uses("base")
    assert ast.unparse(fns["bottom_2"]).endswith("Align.MAX)")
    sec = parse_sections(two.source)
    assert list(sec.params) == ["base_t", "spigot_d", "post_h"]
    # an identical helper is dropped, not renamed
    same = splice(one.source, POST.replace("Align.MAX", "Align.MIN"))
    assert same.dropped_helpers == ["bottom"] and same.renames == {}


def test_param_clash_names_both_values():
    one = splice(empty_program(), BASE)
    with pytest.raises(SpliceError, match=r"spigot_d = 14.0 clashes with the program's spigot_d = 12.0 \(line \d+\)"):
        splice(one.source, POST.replace("spigot_d = 12.0", "spigot_d = 14.0"))


@pytest.mark.parametrize("change,message", [
    (lambda r: r.replace('frames("post"', 'frames("base"'), "frames of 'base' do not belong to part 'post'"),
    (lambda r: r.replace('mate("post.foot"', 'mate("base.foot"'), "mates of 'base' do not belong"),
    (lambda r: r.replace("def post():", "def base():").replace('"post', '"base'), "already in the program"),
    (lambda r: r.replace("@part(", "@parts("), "exactly one function decorated with @part"),
    (lambda r: r.replace("### Frames\nframes(\"post\", foot=Location((0, 0, 0)))", "### Frames\nnone"),
     "publishes no frames"),
    (lambda r: r.replace("post_h = 80.0", "post_h = = 80.0"), "params block line 2: syntax error"),
])
def test_malformed_replies_are_refused_with_the_block(change, message):
    one = splice(empty_program(), BASE)
    with pytest.raises(SpliceError, match=message):
        splice(one.source, change(POST))


def test_after_inserts_at_the_plan_position_in_every_section_and_line_map_points_back():
    one = splice(empty_program(), BASE)
    two = splice(one.source, POST)
    cap = POST.replace("post", "cap").replace('"cap.foot", "base.top"', '"cap.foot", "base.top"')
    three = splice(two.source, cap, after="base")
    names = [n.name for n in ast.parse(three.source).body if isinstance(n, ast.FunctionDef)
             and any(isinstance(d, ast.Call) for d in n.decorator_list)]
    assert names == ["base", "cap", "post"]
    lines = three.source.split("\n")
    frames = [i for i, t in enumerate(lines) if t.startswith("frames(")]
    assert [lines[i][8:12] for i in frames] == ["base", "cap\"", "post"]
    mates = [t for t in lines if t.startswith("mate(")]
    assert mates[0].startswith('mate("cap.foot"') and mates[1].startswith('mate("post.foot"')
    # every inserted non-blank line maps back to the same text in its reply block
    blocks = parse_reply(cap)
    assert three.line_map
    for line, (block, k) in three.line_map.items():
        text = blocks.block(block).split("\n")[k - 1]
        assert lines[line - 1] == text.replace("bottom", three.renames.get("bottom", "bottom"))
    assert {b for b, _ in three.line_map.values()} >= {"params", "body", "frames", "mates"}
    with pytest.raises(SpliceError, match="not a part"):
        splice(two.source, cap, after="nope")


def test_splicing_golden_arm_part_by_part_builds_the_golden_model(worker):
    golden = (ROOT / "golden" / "arm" / "program.py").read_text()
    program = empty_program("Robot arm, spliced one part at a time.")
    replies = part_replies(golden)
    assert len(replies) == 13
    dropped = 0
    for reply in replies:
        result = splice(program, reply)
        program, dropped = result.source, dropped + len(result.dropped_params) + len(result.dropped_helpers)
    assert dropped > 0  # shared params and helpers were repeated by later parts, and de-duplicated
    want, got = worker.compile(golden), worker.compile(program)
    assert got.ok, [f.message for f in got.findings]
    assert [p.name for p in got.parts] == [p.name for p in want.parts]
    for a, b in zip(want.parts, got.parts):
        assert (a.material, a.detail) == (b.material, b.detail)
        assert kernel.volume(b.local_shape()) == pytest.approx(kernel.volume(a.local_shape()), rel=1e-9)
    assert [(m.name, m.type, m.parent, m.child, m.nominal) for m in got.mates] == \
           [(m.name, m.type, m.parent, m.child, m.nominal) for m in want.mates]


def test_code_with_a_syntax_error_is_not_trimmed_away_as_prose():
    bad = POST.replace('fit="location")', 'fit="location"')  # unclosed call in the mates block
    one = splice(empty_program(), BASE)
    with pytest.raises(SpliceError, match="mates block line 1: syntax error"):
        splice(one.source, bad)


def test_replace_part_keeps_its_place_and_the_other_parts_bytes():
    two = splice(splice(empty_program(), BASE).source, POST).source
    cap = POST.replace("post", "cap")
    three = splice(two, cap).source
    new_post = POST.replace("Cylinder(10, post_h", "Cylinder(12, post_h").replace("spigot_d = 12.0", "spigot_d = 13.0")
    with pytest.raises(SpliceError, match="spigot_d = 13.0 clashes"):  # the cap's mate reads it too
        replace_part(three, new_post)
    out = replace_part(three, POST.replace("Cylinder(10, post_h", "Cylinder(12, post_h"))
    names = [n.name for n in ast.parse(out.source).body if isinstance(n, ast.FunctionDef)
             and any(isinstance(d, ast.Call) for d in n.decorator_list)]
    assert names == ["base", "post", "cap"]
    assert "Cylinder(12, post_h" in out.source and "Cylinder(10, post_h" not in out.source.split("def cap")[0]
    assert out.source.count('frames("post"') == 1 and out.source.count('mate("post.foot"') == 1
    for part in ("base", "cap"):  # other parts' text is unchanged
        seg = lambda src, part=part: src.split(f"def {part}():")[1].split("\n\n")[0]  # noqa: E731 - a one-line probe
        assert seg(out.source) == seg(three)
    root = replace_part(three, BASE.replace("Box(120", "Box(130"))
    assert root.source.index("def base()") < root.source.index("def post()")
    assert root.source.index('frames("base"') < root.source.index('frames("post"')
    with pytest.raises(SpliceError, match="cannot replace part 'lid'"):
        replace_part(three, POST.replace("post", "lid"))


def test_replace_part_may_change_a_param_only_it_reads():
    two = splice(splice(empty_program(), BASE).source, POST).source
    out = replace_part(two, POST.replace("post_h = 80.0", "post_h = 95.0"))
    assert out.changed_params == ["post_h"] and "post_h = 95.0  # mm, post height" in out.source
    assert out.source.count("post_h =") == 1
    # the post's own mate is the only reader of spigot_d: the compiler re-cuts the base's socket
    assert replace_part(two, POST.replace("spigot_d = 12.0", "spigot_d = 14.0")).changed_params == ["spigot_d"]
    with pytest.raises(SpliceError, match="base_t = 10.0 clashes"):  # the base reads it
        replace_part(two, POST.replace("### Params\n", "### Params\nbase_t = 10.0  # mm\n"))


def test_a_coupling_splices_with_its_driven_part_and_leaves_with_it(worker):
    """Issue 27.5: a part reply's mates block may hold couple(...) calls whose driven mate is
    the part's own; splicing the transmission program part by part builds the same couplings,
    and replacing the driven part replaces its coupling (no duplicate)."""
    source = (Path(__file__).parent / "transmission.py").read_text()
    program = empty_program("A pinion, a wheel, a rack, a screw and a nut.")
    replies = part_replies(source)
    wheel = next(r for r in replies if "def wheel()" in r)
    assert 'couple("wheel_hub", "pinion_hub", "gear"' in wheel
    for reply in replies:
        program = splice(program, reply).source
    want, got = worker.compile(source), worker.compile(program)
    assert got.ok, [f.message for f in got.findings]
    def rows(model):
        return [{k: v for k, v in c.as_dict().items() if k != "line"} for c in model.couplings]
    assert rows(got) == rows(want) and len(rows(got)) == 3
    again = replace_part(program, wheel).source
    assert again.count('couple("wheel_hub"') == 1 and worker.compile(again).ok
    # a coupling in another part's reply is refused, naming whose mate it drives
    stray = wheel.replace('couple("wheel_hub"', 'couple("nut_slide"', 1)
    with pytest.raises(SpliceError, match="couple\\('nut_slide', ...\\) must follow a mate of part "
                                          "'wheel'.*'nut_slide' is a mate of 'nut'"):
        replace_part(program, stray)
