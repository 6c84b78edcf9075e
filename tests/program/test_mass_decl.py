"""``@part(mass=...)`` and ``@part(hollow=...)``: declared in the program, validated where they
are written, carried from the sandbox to the parent, read from params, and kept out of the
part cache's key (a mass edit rebuilds no solid)."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep.errors import ProgramFormatError
from procedura_brep.program import api
from procedura_brep.program.edit import set_params
from procedura_brep.program.model import to_json
from procedura_brep.program.sandbox import CompileOptions, Worker
from procedura_brep.program.trust import ResultError, model_from_json
from procedura_brep.testing.models import compiled, rebuilt

LAMP = (Path(__file__).parent / "lamp.py").read_text()
ARM = '@part(detail="major", material="painted_aluminium", '
BASE = '@part(detail="silhouette", material="cast_iron", '


def lamp(arm: str = "", base: str = "", params: str = "") -> str:
    """The lamp with extra ``@part`` arguments on the arm and the base, and extra params."""
    src = LAMP.replace(ARM, ARM + arm).replace(BASE, BASE + base)
    return src.replace("# === params ===\n", "# === params ===\n" + params, 1)


def test_mass_and_hollow_reach_the_parent_from_params(worker):
    src = lamp(arm="mass=arm_kg, ", base="hollow=base_wall, ",
               params="arm_kg = 0.35  # kg, the arm with its lamp head\n"
                      "base_wall = 2.0  # mm, cast shell wall\n")
    model = compiled(src, worker=worker)
    assert (model.part("arm").mass, model.part("arm").hollow) == (0.35, None)
    assert (model.part("base").mass, model.part("base").hollow) == (None, 2.0)
    assert (model.part("post").mass, model.part("post").hollow) == (None, None)
    again = model_from_json(to_json(model))  # the parent's reading of the child's result
    assert again.part("arm").mass == 0.35 and again.part("base").hollow == 2.0


@pytest.mark.parametrize("args, says", [
    ("mass=0, ", "mass=0 must be a positive number in kg"),
    ("mass=-2.0, ", "mass=-2.0 must be a positive number in kg"),
    ('mass="arm_kg", ', "mass='arm_kg' must be a positive number in kg (or a param holding one, unquoted"),
    ("hollow=float('nan'), ", "hollow=nan must be a positive number in mm"),
    ("mass=True, ", "mass=True must be a positive number"),
    ("mass=1.0, hollow=2.0, ", "mass=1.0 and hollow=2.0: give one of them"),
])
def test_a_bad_declaration_is_a_format_error_naming_the_value_and_line(worker, args, says):
    src = lamp(arm=args)
    model = worker.compile(src, CompileOptions(name="lamp", cache=False))
    assert not model.ok and not model.parts
    f = model.findings[0]
    assert f.code == "declaration" and says in f.message, f
    assert f.line == src.split("\n").index(next(ln for ln in src.split("\n") if ln.startswith(ARM))) + 1


def test_the_api_raises_the_format_error_itself():
    with pytest.raises(ProgramFormatError, match=r"hollow=0 must be a positive number in mm"):
        api.part(hollow=0)


def test_a_painted_part_keeps_its_hollow_and_its_blocks_declare_none(worker):
    src = lamp(arm="hollow=1.5, ").replace(
        "# === frames ===",
        '@paint("arm", material="rubber", description="grip")\n'
        "def arm_grip():\n"
        "    return Pos(70, 0, 0) * Box(20, 20, 20)\n\n# === frames ===")
    model = compiled(src, worker=worker)
    assert model.part("arm").hollow == 1.5 and model.part("arm").unpainted
    assert model.part("arm_grip").block_of == "arm" and model.part("arm_grip").hollow is None


@pytest.mark.parametrize("field, value", [("mass", -1.0), ("hollow", 0), ("mass", "2"), ("hollow", True)])
def test_the_parent_refuses_a_result_with_a_bad_mass_or_wall(worker, field, value):
    data = to_json(compiled(LAMP, worker=worker))
    data["parts"][2][field] = value
    with pytest.raises(ResultError, match=rf"part arm\.{field}"):
        model_from_json(data)


@pytest.fixture(scope="module")
def cached_worker(tmp_path_factory):
    w = Worker(cache_dir=tmp_path_factory.mktemp("cache"))
    yield w
    w.close()


def test_a_mass_edit_rebuilds_no_solid_and_reaches_the_model(cached_worker):
    src = lamp(arm="mass=arm_kg, ", base="hollow=base_wall, ",
               params="arm_kg = 0.35  # kg\nbase_wall = 2.0  # mm\n")
    first = compiled(src, worker=cached_worker)
    assert rebuilt(first) == {"base", "post", "arm"}
    edited = set_params(src, {"arm_kg": 0.5, "base_wall": 3.0})
    second = compiled(edited, worker=cached_worker)
    assert rebuilt(second) == set()  # every solid from the part cache
    assert second.part("arm").mass == 0.5 and second.part("base").hollow == 3.0
    assert {p.name: p.cache_key for p in second.parts} == {p.name: p.cache_key for p in first.parts}
