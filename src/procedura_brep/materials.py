"""Materials: the built-in library and a program's own PBR declarations.

Each entry has a base colour (albedo, sRGB in 0..1, as written to STEP and MTL ``Kd``),
metalness and roughness (glTF / UsdPreviewSurface / MTL ``Pm`` ``Pr``), a density in kg/m^3
for mass properties, a coarse class, and a wear amount (0 new .. 1 worn; carried to the
exports' metadata and to the materials stage of the agent). Densities of the built-in table
are typical handbook values (e.g. steel 7850, aluminium alloy 2700, cast iron 7200, ABS 1050).

The built-in table :data:`MATERIALS` is the default library. A program may declare its own
entries with ``material(name, base=..., rgb=..., ...)`` (:func:`declare` validates them); the
compiled model carries the library it was built with (built-ins plus declarations), and every
export, render and mass property reads materials from that library, never from this table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, Literal, get_args

from .config import MATERIAL
from .errors import ProceduraError
from .text import did_you_mean

MaterialClass = Literal["metal", "polymer", "elastomer", "ceramic", "composite", "wood", "glass"]
CLASSES: tuple[str, ...] = get_args(MaterialClass)
MAX_NAME = 64


class MaterialError(ProceduraError, ValueError):
    """A material declaration or lookup that cannot be used (the message names the value and
    the allowed range or the known names)."""


@dataclass(frozen=True)
class Material:
    """A PBR material with a density.

    Attributes:
        name: the key programs use.
        rgb: base colour (albedo), each channel in [0, 1].
        metalness: 0 dielectric .. 1 metal.
        roughness: 0 mirror .. 1 matte.
        density: kg/m^3.
        material_class: coarse class, one of :data:`CLASSES`.
        wear: 0 new .. 1 worn.
    """

    name: str
    rgb: tuple[float, float, float]
    metalness: float
    roughness: float
    density: float
    material_class: str
    wear: float = 0.0

    @property
    def albedo(self) -> tuple[float, float, float]:
        return self.rgb

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["rgb"] = list(self.rgb)
        return d


def _m(name: str, rgb: tuple[int, int, int], metal: float, rough: float, density: float,
       cls: str) -> Material:
    return Material(name, (rgb[0] / 255, rgb[1] / 255, rgb[2] / 255), metal, rough, density, cls)


MATERIALS: dict[str, Material] = {m.name: m for m in [
    _m("steel", (140, 143, 148), 1.0, 0.45, 7850, "metal"),
    _m("brushed_steel", (170, 172, 176), 1.0, 0.35, 7850, "metal"),
    _m("stainless_steel", (190, 192, 196), 1.0, 0.25, 8000, "metal"),
    _m("painted_steel", (200, 70, 40), 0.0, 0.5, 7850, "metal"),
    _m("black_oxide_steel", (40, 40, 44), 0.8, 0.5, 7850, "metal"),
    _m("cast_iron", (70, 72, 76), 0.9, 0.7, 7200, "metal"),
    _m("aluminium", (200, 202, 205), 1.0, 0.4, 2700, "metal"),
    _m("anodized_aluminium", (60, 65, 75), 0.9, 0.45, 2700, "metal"),
    _m("painted_aluminium", (235, 235, 230), 0.0, 0.45, 2700, "metal"),
    _m("gold_foil", (212, 175, 55), 1.0, 0.3, 2700, "metal"),
    _m("brass", (181, 150, 70), 1.0, 0.35, 8500, "metal"),
    _m("copper", (184, 115, 51), 1.0, 0.35, 8960, "metal"),
    _m("titanium", (150, 150, 155), 1.0, 0.4, 4430, "metal"),
    _m("abs_plastic", (30, 30, 32), 0.0, 0.6, 1050, "polymer"),
    _m("orange_plastic", (240, 120, 20), 0.0, 0.5, 1050, "polymer"),
    _m("nylon", (230, 228, 220), 0.0, 0.7, 1150, "polymer"),
    _m("rubber", (25, 25, 25), 0.0, 0.9, 1200, "elastomer"),
    _m("carbon_fiber", (35, 35, 38), 0.2, 0.35, 1600, "composite"),
    _m("solar_cell", (20, 35, 90), 0.3, 0.2, 2330, "ceramic"),
    _m("glass", (180, 200, 210), 0.0, 0.05, 2500, "glass"),
    _m("wood", (150, 110, 70), 0.0, 0.8, 700, "wood"),
]}


def get(name: str, library: Mapping[str, Material] | None = None) -> Material:
    """The material called ``name`` in ``library`` (default: the built-in table), or a
    :class:`MaterialError` listing every name."""
    lib = MATERIALS if library is None else library
    try:
        return lib[name]
    except (KeyError, TypeError):
        raise MaterialError(f"unknown material {name!r:.60}{did_you_mean(name, lib)}; use one of: "
                            f"{', '.join(lib)}") from None


def default_library() -> dict[str, Material]:
    """A fresh copy of the built-in table (the library of a program that declares nothing)."""
    return dict(MATERIALS)


def _unit(what: str, value: Any, *, low: float = 0.0, high: float = 1.0, unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise MaterialError(f"{what} = {value!r:.40} must be a number in [{low:g}, {high:g}]{unit}")
    if not low <= value <= high:
        raise MaterialError(f"{what} = {value:g}{unit} is outside the allowed range [{low:g}, {high:g}]{unit}")
    return float(value)


def _rgb(what: str, value: Any) -> tuple[float, float, float]:
    if not isinstance(value, (tuple, list)) or len(value) != 3:
        raise MaterialError(f"{what} = {value!r:.60} must be three numbers (r, g, b), each in [0, 1]")
    r, g, b = (_unit(f"{what}[{i}]", v) for i, v in enumerate(value))
    return (r, g, b)


def check(m: Material) -> Material:
    """``m`` if every field is in range, else a :class:`MaterialError` naming the field."""
    where = f"material {m.name!r:.60}"
    if not isinstance(m.name, str) or not m.name or len(m.name) > MAX_NAME or not (
            m.name[0].isascii() and m.name[0].islower()) or not all(
            c.isascii() and (c.islower() or c.isdigit() or c == "_") for c in m.name):
        raise MaterialError(f"material name {m.name!r:.60} must be snake_case [a-z][a-z0-9_]*, at "
                            f"most {MAX_NAME} characters")
    lo, hi = MATERIAL.density_range
    if m.material_class not in CLASSES:
        raise MaterialError(f"{where}: material_class = {m.material_class!r:.40} is not one of "
                            f"{', '.join(CLASSES)}")
    return Material(m.name, _rgb(f"{where}: rgb", m.rgb), _unit(f"{where}: metalness", m.metalness),
                    _unit(f"{where}: roughness", m.roughness),
                    _unit(f"{where}: density", m.density, low=lo, high=hi, unit=" kg/m^3"),
                    m.material_class, _unit(f"{where}: wear", m.wear))


def declare(name: str, *, library: Mapping[str, Material], base: str | None = None,
            rgb: Any = None, metalness: Any = None, roughness: Any = None, density: Any = None,
            material_class: Any = None, wear: Any = None) -> Material:
    """A new library entry: ``base``'s values (a name in ``library``) overridden by the ones
    given; without ``base`` every value but ``wear`` is required.

    Raises:
        MaterialError: a bad name, a name already in ``library``, an unknown base, a missing
            value, or a value out of range (the message states the value and the range).
    """
    if isinstance(name, str) and name in library:
        what = "a built-in material" if name in MATERIALS else "declared twice"
        raise MaterialError(f"material {name!r} is {what}; choose another name (base={name!r} "
                            f"starts from its values)")
    given = {"rgb": rgb, "metalness": metalness, "roughness": roughness, "density": density,
             "material_class": material_class, "wear": wear}
    if base is not None:
        if not isinstance(base, str) or base not in library:
            raise MaterialError(f"material {name!r:.60}: base {base!r:.60} is not a known material; "
                                f"use one of: {', '.join(library)}")
        start = library[base].as_dict()
    else:
        missing = [k for k, v in given.items() if v is None and k != "wear"]
        if missing:
            raise MaterialError(f"material {name!r:.60}: without base=... it needs {', '.join(missing)}")
        start = {"wear": 0.0}
    values = {**start, **{k: v for k, v in given.items() if v is not None}, "name": name}
    return check(Material(values["name"], values["rgb"], values["metalness"], values["roughness"],
                          values["density"], values["material_class"], values["wear"]))


def library_to_json(library: Mapping[str, Material]) -> list[dict[str, Any]]:
    """The library as JSON-safe rows (in order)."""
    return [m.as_dict() for m in library.values()]


def library_from_json(rows: Any) -> dict[str, Material]:
    """Read :func:`library_to_json`'s rows back, checking every field.

    Raises:
        MaterialError: a row that is not a material, a bad field, a duplicated name.
    """
    if not isinstance(rows, list):
        raise MaterialError(f"a material library is a list of entries, got {type(rows).__name__}")
    out: dict[str, Material] = {}
    fields = ("name", "rgb", "metalness", "roughness", "density", "material_class", "wear")
    for i, row in enumerate(rows):
        if not isinstance(row, dict) or set(row) != set(fields):
            raise MaterialError(f"material entry {i} must have exactly the fields {', '.join(fields)}")
        m = check(Material(*(row[f] for f in fields)))
        if m.name in out:
            raise MaterialError(f"material {m.name!r} appears twice in the library")
        out[m.name] = m
    return out


def used(library: Mapping[str, Material], names: Any) -> dict[str, Material]:
    """The entries of ``library`` named in ``names`` (the materials a model's parts use)."""
    want = set(names)
    return {k: v for k, v in library.items() if k in want}
