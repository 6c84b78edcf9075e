"""Stable, well-separated part colours and the colour legend.

A part's colour comes from a hash of its name into a fixed palette of saturated colours. Names
are placed in the order given (the program's part order, which a staged run only appends to),
and a name whose slot is taken, or too close to a taken colour, moves on to the next free slot
(probing over an interleaved order), so no two parts of one model share a colour while the
palette lasts, and adding a part never recolours the parts before it: the renders of one run
keep each part's colour from its first appearance to the end.
Beyond :data:`PALETTE` (36 entries) colours repeat in a darker tier; the legend still lists
every name.
"""

from __future__ import annotations

import colorsys
import hashlib

RGB = tuple[int, int, int]


def _build_palette() -> list[RGB]:
    hues = [i / 12 for i in range(12)]
    # Three tiers (saturation, value); hue order interleaved so neighbours in the list differ.
    tiers = [(0.85, 0.95), (0.55, 0.80), (0.95, 0.60)]
    order = [0, 6, 3, 9, 1, 7, 4, 10, 2, 8, 5, 11]
    out: list[RGB] = []
    for s, v in tiers:
        for k in order:
            r, g, b = colorsys.hsv_to_rgb(hues[k] + (0.04 if v < 0.7 else 0.0), s, v)
            out.append((round(r * 255), round(g * 255), round(b * 255)))
    return out


PALETTE: list[RGB] = _build_palette()
"""Fixed part colours (sRGB 0..255), none grey, so the background and clay never collide."""


MIN_SEPARATION: float = 300.0
"""Initial minimum "redmean" distance between the colours of two parts of one model."""


def _slot(name: str) -> int:
    return int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:8], "big")


def _distance(a: RGB, b: RGB) -> float:
    """A cheap perceptual distance ("redmean" weighted RGB), 0..~765."""
    rm = (a[0] + b[0]) / 2
    dr, dg, db = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return ((2 + rm / 256) * dr * dr + 4 * dg * dg + (2 + (255 - rm) / 256) * db * db) ** 0.5


def part_colors(names: list[str] | tuple[str, ...]) -> dict[str, RGB]:
    """A distinct palette colour per part name (deterministic; a name's colour depends only on
    the names before it, so appending a name never changes the others').

    Names are visited in the order given; each takes the first slot, probing from its hashed slot,
    whose colour is at least a separation threshold from every colour already taken; the
    threshold starts at :data:`MIN_SEPARATION` and relaxes as the palette fills.
    """
    n = len(PALETTE)
    taken: list[int] = []
    out: dict[str, RGB] = {}
    for name in dict.fromkeys(names):
        start = _slot(name) % n
        if len(taken) >= n:  # palette exhausted: a darker repeat; the legend still names it
            r, g, b = PALETTE[start]
            out[name] = (r * 2 // 3, g * 2 // 3, b * 2 // 3)
            continue
        free = [(start + k) % n for k in range(n) if (start + k) % n not in taken]
        sep = MIN_SEPARATION
        while True:
            pick = next((i for i in free if all(_distance(PALETTE[i], PALETTE[j]) >= sep
                                                for j in taken)), None)
            if pick is not None:
                break
            sep *= 0.8
        taken.append(pick)
        out[name] = PALETTE[pick]
    return {name: out[name] for name in names}


def hex_color(rgb: RGB) -> str:
    """``(255, 0, 16)`` -> ``"#ff0010"``."""
    return "#{:02x}{:02x}{:02x}".format(*rgb)
