"""The material library: declarations validated with ranges, JSON round trip, lookups."""

from __future__ import annotations

import pytest

from procedura_brep import materials
from procedura_brep.config import MATERIAL
from procedura_brep.materials import (
    MaterialError,
    declare,
    library_from_json,
    library_to_json,
)

LIB = materials.default_library()


def test_a_declaration_starts_from_its_base_and_overrides_what_it_names():
    m = declare("hull_paint", library=LIB, base="painted_steel", rgb=(0.8, 0.1, 0.1), roughness=0.4,
                wear=0.2)
    base = LIB["painted_steel"]
    assert m.rgb == (0.8, 0.1, 0.1) and m.roughness == 0.4 and m.wear == 0.2
    assert (m.metalness, m.density, m.material_class) == (base.metalness, base.density, base.material_class)
    assert m.albedo == m.rgb


def test_without_a_base_every_value_is_required():
    with pytest.raises(MaterialError, match="without base=... it needs roughness, density"):
        declare("tyre", library=LIB, rgb=(0.1, 0.1, 0.1), metalness=0.0, material_class="elastomer")
    m = declare("tyre", library=LIB, rgb=(0.1, 0.1, 0.1), metalness=0.0, roughness=0.9, density=1150,
                material_class="elastomer")
    assert m.wear == 0.0 and m.density == 1150.0


@pytest.mark.parametrize("kw, message", [
    ({"rgb": (1.2, 0, 0)}, r"rgb\[0\] = 1.2 is outside the allowed range \[0, 1\]"),
    ({"rgb": (0.5, 0.5)}, r"rgb = \(0.5, 0.5\) must be three numbers"),
    ({"roughness": -0.1}, r"roughness = -0.1 is outside the allowed range \[0, 1\]"),
    ({"metalness": True}, r"metalness = True must be a number in \[0, 1\]"),
    ({"wear": float("nan")}, r"wear = nan must be a number"),
    ({"density": 78500}, r"density = 78500 kg/m\^3 is outside the allowed range \[1, 25000\] kg/m\^3"),
    ({"material_class": "metall"}, r"material_class = 'metall' is not one of metal, polymer"),
    ({"base": "unobtanium"}, r"base 'unobtanium' is not a known material; use one of: steel"),
])
def test_every_value_is_range_checked_and_the_message_states_value_and_range(kw, message):
    with pytest.raises(MaterialError, match=message):
        declare("paint", library=LIB, **{"base": "steel", **kw})


def test_names_are_snake_case_and_never_shadow_a_builtin():
    with pytest.raises(MaterialError, match="must be snake_case"):
        declare("Red Paint", library=LIB, base="steel")
    with pytest.raises(MaterialError, match="'steel' is a built-in material"):
        declare("steel", library=LIB, base="steel", rgb=(1, 0, 0))
    lib = {**LIB, "red": declare("red", library=LIB, base="steel")}
    with pytest.raises(MaterialError, match="'red' is declared twice"):
        declare("red", library=lib, base="steel")


def test_the_density_range_lives_in_config():
    lo, hi = MATERIAL.density_range
    assert declare("dense", library=LIB, base="steel", density=hi).density == hi
    with pytest.raises(MaterialError):
        declare("dense", library=LIB, base="steel", density=hi + 1)
    assert declare("foam", library=LIB, base="nylon", density=lo).density == lo


def test_json_round_trip_checks_every_field():
    m = declare("hull_paint", library=LIB, base="painted_steel", rgb=(0.8, 0.1, 0.1), wear=0.3)
    rows = library_to_json({"hull_paint": m})
    assert library_from_json(rows) == {"hull_paint": m}
    rows[0]["roughness"] = 3
    with pytest.raises(MaterialError, match="roughness = 3 is outside"):
        library_from_json(rows)
    with pytest.raises(MaterialError, match="exactly the fields"):
        library_from_json([{"name": "x"}])


def test_lookup_lists_the_library():
    lib = {**LIB, "hull_paint": declare("hull_paint", library=LIB, base="steel")}
    assert materials.get("hull_paint", lib).name == "hull_paint"
    with pytest.raises(MaterialError, match="unknown material 'hul_paint' \\(did you mean 'hull_paint'\\?\\); use one of: .*hull_paint"):
        materials.get("hul_paint", lib)
