"""The five-section format, param edits, and program-level compile errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep.errors import EditError, ProgramFormatError
from procedura_brep.program.edit import parse_assignment, set_params
from procedura_brep.program.sections import parse_sections

LAMP = (Path(__file__).parent / "lamp.py").read_text()


def line_of(text: str, needle: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if needle in ln)


def test_parse_finds_sections_and_params():
    sec = parse_sections(LAMP)
    assert list(sec.starts) == ["params", "helpers", "parts", "frames", "assembly"]
    assert list(sec.params) == ["base_w", "base_t", "post_d", "post_h", "spigot_d", "pin_d"]
    assert sec.params["post_d"].comment.startswith("# mm")


def test_missing_section_reports_line():
    src = LAMP.replace("# === frames ===\n", "")
    with pytest.raises(ProgramFormatError, match="section 'assembly' is out of order") as exc:
        parse_sections(src)
    assert exc.value.line == line_of(src, "# === assembly ===")


def test_missing_last_section():
    src = LAMP.replace("# === assembly ===\n", "")
    with pytest.raises(ProgramFormatError, match=r"missing section marker\(s\) # === assembly ==="):
        parse_sections(src)


def test_duplicated_section_reports_both_lines():
    src = LAMP + "\n# === params ===\n"
    with pytest.raises(ProgramFormatError, match="appears twice") as exc:
        parse_sections(src)
    assert exc.value.line == len(src.splitlines())


def test_out_of_order():
    src = LAMP.replace("# === helpers ===", "# === TMP ===").replace("# === parts ===", "# === helpers ===") \
        .replace("# === TMP ===", "# === parts ===")
    with pytest.raises(ProgramFormatError, match="out of order"):
        parse_sections(src)


def test_params_section_holds_only_assignments():
    src = LAMP.replace("pin_d = 8.0", "def f(): pass\npin_d = 8.0")
    with pytest.raises(ProgramFormatError, match="only `name = value"):
        parse_sections(src)


def test_edit_changes_only_that_line():
    new = set_params(LAMP, {"post_d": 24, "base_t": 14.5})
    old_lines, new_lines = LAMP.splitlines(), new.splitlines()
    changed = [i for i, (a, b) in enumerate(zip(old_lines, new_lines)) if a != b]
    assert len(old_lines) == len(new_lines) and len(changed) == 2
    assert "post_d = 24.0   # mm, post diameter" in new
    assert "base_t = 14.5   # mm, base thickness" in new


def test_edit_unknown_param_lists_params():
    with pytest.raises(EditError, match="unknown param.*wheel_d.*params: base_w, base_t, post_d"):
        set_params(LAMP, {"wheel_d": 3})


@pytest.mark.parametrize("text", ["post_d", "post_d=abc", "post_d=nan", "post_d=1e999"])
def test_bad_assignment(text):
    with pytest.raises(EditError):
        parse_assignment(text)


def test_module_level_error_has_line(worker):
    src = LAMP.replace("# === helpers ===", "# === helpers ===\nx = 1 / 0")
    m = worker.compile(src)
    f = m.findings[0]
    assert f.code == "module-exception" and "ZeroDivisionError" in f.message
    assert f.line == line_of(src, "x = 1 / 0")


def test_unmated_part_and_unknown_frame(worker):
    src = LAMP.replace('mate("arm.pivot", "post.head"', 'mate("arm.pivot", "post.nose"')
    m = worker.compile(src)
    assert any("publishes no frame 'nose'" in f.message and "head" in f.message for f in m.findings)
    assert any(f.code == "unmated" and f.part == "arm" for f in m.findings)


def test_root_cannot_be_a_child(worker):
    src = LAMP + 'mate("base.top", "arm.pivot", "seat_face", nominal="post_d", name="root_child")\n'
    m = worker.compile(src)
    assert any(f.code == "plan-order" and "root part" in f.message for f in m.findings)


def test_parent_must_be_placed_first(worker):
    src = LAMP.replace('mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")\n', "")
    src += 'mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")\n'
    m = worker.compile(src)
    assert any(f.code == "plan-order" and "'post' is not placed yet" in f.message for f in m.findings)


def test_a_failed_mate_is_the_cause_its_children_name(worker):
    """A mate that fails before placing (a mistyped frame) leaves its child unplaced; the mates
    below it say so and name it, instead of asking to reorder mates already in plan order."""
    m = worker.compile(LAMP.replace('mate("post.foot"', 'mate("post.fot"', 1))
    codes = [(f.code, f.mate) for f in m.findings]
    assert codes[0] == ("mate", "post_fot") and ("unplaced", "arm_pivot") in codes, codes
    below = next(f for f in m.findings if f.code == "unplaced")
    assert "it hangs below mate post_fot, which failed" in below.message
    assert not any(f.code == "plan-order" for f in m.findings)


def test_located_part_keeps_its_local_geometry_and_step_names(worker):
    """A part returned as ``Pos(...) * Box(...)`` (a located shape) with no features keeps its
    offset; every part's local solid carries no location (STEP names stay on products)."""
    import re

    from procedura_brep import kernel
    from procedura_brep.export.step import step_bytes
    src = LAMP.replace("    return Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))",
                       "    return Pos(0, 0, 3) * Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))")
    src = src.replace('limits=(-45, 45))', 'limits=(-45, 45), features=False)')
    m = worker.compile(src)
    assert m.ok, m.findings
    arm = m.part("arm").local_shape()
    assert arm.Location().IsIdentity()
    lo, hi = kernel.bbox(arm)
    assert lo[2] == pytest.approx(-2.0, abs=1e-6) and hi[2] == pytest.approx(8.0, abs=1e-6)
    text = step_bytes(m).decode("ascii")
    assert re.findall(r"PRODUCT\(\s*'([^']*)'", text) == ["model", "base", "post", "arm"]


def test_param_expressions_are_numbers_params_and_math(worker):
    ok = LAMP.replace("base_t = 12.0   # mm", "base_t = base_w / 10 + math.sqrt(4.0) * 0   # mm")
    assert worker.compile(ok).ok
    bad = LAMP.replace("base_t = 12.0   # mm", "base_t = Box(1, 1, 12).volume   # mm")
    m = worker.compile(bad)
    assert m.findings[0].code == "format" and m.findings[0].line == line_of(bad, "base_t = Box")
    assert "params hold only numbers, earlier params, arithmetic and math" in m.findings[0].message
    for expr in ("Box(1, 1, 12)", "later_param * 2", "'12'"):
        m = worker.compile(LAMP.replace("base_t = 12.0   # mm", f"base_t = {expr}   # mm"))
        assert not m.ok and m.findings[0].code == "format", expr
