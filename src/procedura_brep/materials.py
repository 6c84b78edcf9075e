"""The material library: one documented table shared by STEP colours, PBR exports and mass.

Each entry has a base colour (linear-ish sRGB in 0..1, as written to STEP and MTL ``Kd``),
metalness and roughness (glTF / UsdPreviewSurface / MTL ``Pm`` ``Pr``), and a density in kg/m^3
for mass properties. Densities are typical handbook values (e.g. steel 7850, aluminium alloy
2700, cast iron 7200, ABS 1050). A part names its material by key; an unknown key is an error
that lists the keys.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Material:
    """A PBR material with a density.

    Attributes:
        name: the key programs use.
        rgb: base colour, each channel in [0, 1].
        metalness: 0 dielectric .. 1 metal.
        roughness: 0 mirror .. 1 matte.
        density: kg/m^3.
        material_class: coarse class: metal, polymer, elastomer, ceramic, composite, wood, glass.
    """

    name: str
    rgb: tuple[float, float, float]
    metalness: float
    roughness: float
    density: float
    material_class: str


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


def get(name: str) -> Material:
    """The material called ``name``, or a ValueError listing every key."""
    try:
        return MATERIALS[name]
    except KeyError:
        raise ValueError(f"unknown material {name!r}; use one of: {', '.join(MATERIALS)}") from None
