"""Golden-file tests: each golden program compiles to exactly its recorded summary, and each
recorded parametric edit rebuilds to its recorded summary. Requirements (part counts, mate types,
joint counts) are checked directly too, so a regenerated golden cannot silently lose them.

Update the files on purpose only: ``PROCEDURA_UPDATE_GOLDEN=1 python -m pytest tests/golden``.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import pytest

from .harness import GOLDEN_DIR, check, compare, dumps, summarize, updating

PROGRAMS = ("rover", "arm", "vise", "gearbox")
#: Minimum requirements per program: parts, distinct static mate types, kinematic mate counts.
REQUIRED = {
    "rover": {"parts": 25, "static_types": 5, "revolute": 6 + 4, "prismatic": 0, "spherical": 0},
    "arm": {"parts": 12, "static_types": 2, "revolute": 5, "prismatic": 2, "spherical": 0},
    "vise": {"parts": 8, "static_types": 2, "revolute": 0, "prismatic": 1, "spherical": 1},
    "gearbox": {"parts": 10, "static_types": 2, "revolute": 3, "prismatic": 0, "spherical": 0},
}


def set_params(source: str, values: dict) -> str:
    from procedura_brep.program.edit import set_params as edit
    return edit(source, values)


def _source(name: str) -> str:
    return (GOLDEN_DIR / name / "program.py").read_text(encoding="utf-8")


def _edits(name: str) -> list[Path]:
    return sorted((GOLDEN_DIR / name / "edits").glob("*.json"))


_CACHE: dict[str, object] = {}


def _compiled(name: str, worker):
    if name not in _CACHE:
        from procedura_brep.program import compile_source
        _CACHE[name] = compile_source(_source(name), name=name, worker=worker)
    return _CACHE[name]


@pytest.fixture(scope="module", params=PROGRAMS)
def golden(request, worker):
    name = request.param
    return name, _compiled(name, worker)


def test_program_compiles_clean(golden):
    name, model = golden
    assert [f.as_dict() for f in model.findings] == []
    assert model.parts and model.parts[0].name == model.parts[0].name.lower()


def test_matches_expected(golden):
    name, model = golden
    check(GOLDEN_DIR / name / "expected.json", summarize(model))


def test_requirements(golden):
    name, model = golden
    req = REQUIRED[name]
    kinds = Counter(m.type for m in model.mates)
    static_types = {m.type for m in model.mates if m.kind == "static"}
    assert len(model.parts) >= req["parts"], [p.name for p in model.parts]
    assert len(static_types) >= req["static_types"], static_types
    for joint in ("revolute", "prismatic", "spherical"):
        assert kinds[joint] >= req[joint], (joint, dict(kinds))
    names = [p.name for p in model.parts]
    assert len(set(names)) == len(names)
    assert all(n.replace("_", "").isalnum() and n == n.lower() for n in names)
    placed = {names[0]} | {m.child for m in model.mates}
    assert placed == set(names), "every part but the root is some mate's child"
    assert '"""' in _source(name).splitlines()[0] and "hand-written" in _source(name).lower()


def test_rover_specifics(worker):
    model = _compiled("rover", worker)
    wheels = [m for m in model.mates if m.child.startswith("wheel_")]
    assert len(wheels) == 6
    from procedura_brep import kernel
    lows = []
    for m in wheels:
        assert m.type == "revolute" and m.options["limits"] is None
        z = m.world_frame[:3, 2]
        assert abs(z[2]) < 1e-9 and abs(z[0]) < 1e-9 and abs(abs(z[1]) - 1) < 1e-9  # lateral axle
        lows.append(kernel.bbox(model.part(m.child).shape())[0][2])
    assert max(lows) - min(lows) < 1e-3, lows  # all six wheels touch one ground plane
    assert min(lows) <= min(kernel.bbox(p.shape())[0][2] for p in model.parts) + 1e-3
    limited = [m for m in model.mates if m.type == "revolute" and m.options["limits"] is not None]
    assert len(limited) >= 4  # rockers and bogies (and the camera head)


def test_arm_specifics(worker):
    model = _compiled("arm", worker)
    chain = [m for m in model.mates if m.type == "revolute"]
    assert len(chain) >= 5 and all(m.options["limits"] is not None for m in chain)
    fingers = [m for m in model.mates if m.type == "prismatic"]
    assert len(fingers) == 2 and all(m.options["limits"] is not None for m in fingers)
    a, b = (m.world_frame[:3, 2] for m in fingers)
    assert a @ b < -0.999  # the fingers close towards each other


def test_vise_specifics(worker):
    model = _compiled("vise", worker)
    sph = [m for m in model.mates if m.type == "spherical"]
    assert len(sph) == 1 and sph[0].options["cone"] > 0
    assert sum(m.type == "prismatic" for m in model.mates) == 1


def test_gearbox_specifics(worker):
    model = _compiled("gearbox", worker)
    shafts = [m for m in model.mates if m.type == "revolute"]
    assert len(shafts) == 3 and all(abs(m.world_frame[2, 2] - 1) < 1e-9 for m in shafts)  # +Z
    assert [(c.type, c.driver, c.driven) for c in model.couplings] == [
        ("gear", "input_shaft_seat", "countershaft_seat"),
        ("gear", "countershaft_seat", "output_shaft_seat")]
    assert [c.inputs["driver_teeth"] for c in model.couplings] == ["z1", "z3"]
    total = model.couplings[0].ratio * model.couplings[1].ratio
    p = model.params
    assert total == pytest.approx(p["z1"] / p["z2"] * p["z3"] / p["z4"])  # 1/9, same sense
    bolts = [m for m in model.mates if m.child.startswith("bolt_")]
    assert len(bolts) == 4 and {m.parent for m in bolts} == {"cover"}


EDIT_CASES = [(n, p) for n in PROGRAMS for p in _edits(n)]


def test_every_program_has_two_edits():
    for name in PROGRAMS:
        assert len(_edits(name)) >= 2, name


@pytest.mark.parametrize("name,path", EDIT_CASES, ids=[f"{n}-{p.stem}" for n, p in EDIT_CASES])
def test_edit(name, path, worker):
    from procedura_brep.program import compile_source
    spec = json.loads(path.read_text(encoding="utf-8"))
    source = set_params(_source(name), spec["set"])
    assert source != _source(name)
    model = compile_source(source, name=name, worker=worker)
    actual = summarize(model)
    if updating():
        path.write_text(dumps({"set": spec["set"], "expect": actual}), encoding="utf-8")
        return
    from .harness import unified_diff
    diffs = compare(spec["expect"], actual)
    assert not diffs, ("\n".join(diffs[:40]) + "\n\n" + unified_diff(spec["expect"], actual, path.name))
    base = summarize(_compiled(name, worker))
    assert actual["counts"] == base["counts"]  # an edit changes sizes, never the structure
    assert compare(base, actual), f"edit {spec['set']} changed nothing"


def test_harness_reports_differences():
    e = {"parts": [{"name": "a", "volume_mm3": 1000.0, "bbox_mm": [[0, 0, 0], [1, 1, 1]]}],
         "mates": [{"name": "m", "origin_mm": [0.0, 0.0, 0.0], "type": "key"}]}
    a = json.loads(json.dumps(e))
    assert compare(e, a) == []
    a["parts"][0]["volume_mm3"] = 1000.0 * (1 + 1e-7)
    a["parts"][0]["bbox_mm"][1][2] = 1.0005
    assert compare(e, a) == []
    a["parts"][0]["volume_mm3"] = 1001.0
    a["mates"][0]["origin_mm"][2] = 1e-3
    a["mates"][0]["type"] = "pin"
    diffs = compare(e, a)
    assert len(diffs) == 3 and diffs[0].startswith("mates[m].origin_mm")
    assert any("parts[a].volume_mm3: expected 1000.0 vs 1001.0" == d for d in diffs)


def test_docs_example_compiles(worker):
    """The complete example in docs/program-format.md compiles clean (the docs cannot rot)."""
    from procedura_brep.program import compile_source
    text = (GOLDEN_DIR.parent / "docs" / "program-format.md").read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    example = next(b for b in blocks if "# === assembly ===" in b)
    model = compile_source(example, name="lamp", worker=worker)
    assert [f.as_dict() for f in model.findings] == []
    assert [p.name for p in model.parts] == ["base", "post", "arm"]
    assert [m.type for m in model.mates] == ["peg_socket", "revolute"]
