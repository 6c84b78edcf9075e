"""The same program gives the same bytes in two separate processes (every file of the run
directory; report.json apart from its timings), and the STEP colour-section canonicalisation
that makes STEP reproducible keeps the file valid."""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from procedura_brep import materials
from procedura_brep.export import step_order
from procedura_brep.export.step import read_step_parts

PROGRAM = Path(__file__).with_name("posts.py")
#: Text formats we own; each must be byte-identical across processes.
TEXT_FILES = ("model.step", "model.obj", "model.mtl", "model.usda", "urdf/robot.urdf",
              "urdf/robot.mujoco.urdf", "model.xml", "mates.json")
RGB_TOL = 1 / 255


def _untimed(doc: Any) -> Any:
    """``doc`` without its timings: every ``timings`` object and every ``*_s`` (seconds) field."""
    if isinstance(doc, dict):
        return {k: _untimed(v) for k, v in doc.items() if k != "timings" and not k.endswith("_s")}
    if isinstance(doc, list):
        return [_untimed(v) for v in doc]
    return doc


def _build(out: Path) -> None:
    proc = subprocess.run([sys.executable, "-m", "procedura_brep.cli", "build", str(PROGRAM),
                           "-o", str(out)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("repro")
    a, b = root / "a", root / "b"
    _build(a)
    _build(b)
    return a, b


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_text_formats_identical_across_processes(two_runs: tuple[Path, Path]) -> None:
    a, b = two_runs
    for rel in TEXT_FILES:
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), f"{rel} differs between processes"


def test_every_file_identical_across_processes(two_runs: tuple[Path, Path]) -> None:
    """Binary files too (GLB, STL meshes); report.json compared without its timings."""
    a, b = two_runs
    files = sorted(p.relative_to(a).as_posix() for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b).as_posix() for p in b.rglob("*") if p.is_file())
    assert "model.glb" in files and any(f.endswith(".stl") for f in files)
    for rel in files:
        if rel == "report.json":
            ra, rb = (_untimed(json.loads((d / rel).read_text())) for d in (a, b))
            assert ra == rb
        elif rel == "summary.md":  # its last section is the timings
            sa, sb = ((d / rel).read_text().split("## Timings")[0] for d in (a, b))
            assert sa == sb
        else:
            assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel


def test_step_still_reads_back(two_runs: tuple[Path, Path]) -> None:
    """The canonicalised STEP re-reads through XCAF with every name and colour."""
    a, _ = two_runs
    parts = read_step_parts((a / "model.step").read_bytes())
    want = {"plate": "cast_iron", "post_a": "brass", "post_b": "copper", "post_c": "titanium",
            "post_d_part": "orange_plastic", "post_e": "nylon", "arm": "painted_steel"}
    assert [p.name for p in parts] == list(want)
    for p in parts:
        assert p.rgb is not None
        assert max(abs(x - y) for x, y in zip(p.rgb, materials.get(want[p.name]).rgb)) <= RGB_TOL


def _shuffle_tail(text: str, seed: int) -> str:
    """The same STEP content with the colour section's records renumbered and laid out in a
    random order (what a different process's hash order looks like)."""
    begin = text.index("\nDATA;\n") + len("\nDATA;\n")
    end = text.rindex("ENDSEC;")
    records = [r for r, _ in step_order._split_records(text[begin:end])]
    first = next(k for k, r in enumerate(records)
                 if "MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION" in r)
    ids = [int(step_order._ID.match(r).group(1)) for r in records[first:]]
    new = ids[:]
    random.Random(seed).shuffle(new)
    # OCCT adds each part's presentation root first: keep a root at the start of the section
    root = next(k for k, r in enumerate(records[first:]) if "PRESENTATION_REPRESENTATION" in r)
    at = new.index(ids[0])
    new[root], new[at] = new[at], new[root]
    mapping = dict(zip(ids, new))
    tail = []
    for r in records[first:]:
        m = step_order._ID.match(r)
        tail.append((mapping[int(m.group(1))],
                     step_order._renumber(r[m.end():], mapping)))
    head = "".join(r + ";\n" for r in records[:first])
    body = "".join(f"#{i} = {b};\n" for i, b in sorted(tail))
    return text[:begin] + head + body + text[end:]


def test_canonical_order_ignores_the_writers_order(two_runs: tuple[Path, Path]) -> None:
    a, _ = two_runs
    text = (a / "model.step").read_text()
    shuffled = [_shuffle_tail(text, seed) for seed in range(3)]
    assert len(set(shuffled)) > 1  # the shuffles really differ
    for s in shuffled:
        assert step_order.canonical_step(s) == text
        assert [p.name for p in read_step_parts(s.encode())] == \
            [p.name for p in read_step_parts(text.encode())]


def test_tail_referenced_from_geometry_is_left_alone(caplog) -> None:
    """A layout the rule does not cover is kept as written (valid, not reordered), with a
    warning, rather than failing the export."""
    text = ("ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1 = FOO(#3);\n"
            "#2 = STYLED_ITEM('color',(),#1);\n#3 = COLOUR_RGB('',1.,0.,0.);\nENDSEC;\n"
            "END-ISO-10303-21;\n")
    with pytest.raises(step_order.KernelError, match="referenced by geometry"):
        step_order._canonical(text)
    with caplog.at_level("WARNING", logger="procedura_brep.export.step_order"):
        assert step_order.canonical_step(text) == text
    assert "left in OCCT's order" in caplog.text


def test_semicolons_in_strings_do_not_split_records() -> None:
    data = "#1 = A('x;y');\n#2 = B('it''s; fine',#1);\n"
    assert [r for r, _ in step_order._split_records(data)] == \
        ["#1 = A('x;y')", "#2 = B('it''s; fine',#1)"]
    assert step_order._refs("B('#9',#1)") == [1]


def test_a_reference_inside_a_geometry_string_is_not_one() -> None:
    """The geometry section is checked for references into the colour section on its text with
    its strings left out: a name that reads '#3' refers to nothing."""
    text = ("ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1 = FOO('part #3');\n"
            "#2 = STYLED_ITEM('color',(#3),#1);\n#3 = COLOUR_RGB('',1.,0.,0.);\nENDSEC;\n"
            "END-ISO-10303-21;\n")
    out = step_order._canonical(text)
    assert "#1 = FOO('part #3');" in out and "COLOUR_RGB" in out
    data = "#1 = A('x;y');\n#2 = B(#1);"
    assert [off for _, off in step_order._split_records(data)] == [len("#1 = A('x;y');"), len(data)]


def test_the_colour_section_is_found_in_the_text_not_inside_a_string() -> None:
    """The section's start is searched for in the text (the geometry before it is never parsed
    record by record): a line inside a geometry string that reads like a presentation record is
    not its start, nor is one that does not begin a record."""
    data = ("#1 = FOO('a name;\n#7 = STYLED_ITEM(''x'',(),#1);');\n#4 = BAR(#1,\n"
            "#8 = STYLED_ITEM(#1));\n#2 = STYLED_ITEM('color',(#3),#1);\n#3 = COLOUR_RGB('',1.,0.,0.);\n")
    at = step_order._section_start(data)
    assert at is not None and data[at:].startswith("#2 = STYLED_ITEM('color'")
    assert step_order._section_start("#1 = FOO('STYLED_ITEM(');\n") is None
    text = f"ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n{data}ENDSEC;\nEND-ISO-10303-21;\n"
    out = step_order._canonical(text)
    assert out.startswith(text[:text.index("#2 = STYLED_ITEM")])
    assert "#2 = STYLED_ITEM('color',(#3),#1);\n#3 = COLOUR_RGB('',1.,0.,0.);\nENDSEC;" in out
