"""Exact-geometry interference between parts (MuJoCo only sees convex hulls).

Interference of two solids is the OCCT boolean common; its *thickness* is estimated as
``2 V / S`` (V volume, S surface area of the common solid), which is exact for a thin slab and
an under-estimate for chunky overlaps. Pairs are prefiltered by bounding boxes.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from .. import kernel
from ..articulation.evidence import boxes_touch
from ..articulation.tree import Articulation
from ..program.model import CompiledModel

#: Boxes closer than this (mm) are tested with the exact boolean.
BOX_MARGIN_MM = 0.01


@dataclass(frozen=True)
class Overlap:
    """Interference between two parts: volume mm^3 and thickness mm."""

    a: str
    b: str
    volume: float
    depth: float


def overlap(a_name: str, a_shape, b_name: str, b_shape) -> Overlap:
    """Exact interference of two located shapes."""
    if not boxes_touch(kernel.bbox(a_shape, optimal=False), kernel.bbox(b_shape, optimal=False),
                       BOX_MARGIN_MM):
        return Overlap(a_name, b_name, 0.0, 0.0)
    return exact_overlap(a_name, a_shape, b_name, b_shape)


def exact_overlap(a_name: str, a_shape, b_name: str, b_shape) -> Overlap:
    """Exact interference of two located shapes, without a box prefilter."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    op = BRepAlgoAPI_Common(a_shape, b_shape)
    if not op.IsDone():
        return Overlap(a_name, b_name, 0.0, 0.0)
    common = op.Shape()
    vol = abs(kernel.volume(common))
    if vol <= 0:
        return Overlap(a_name, b_name, 0.0, 0.0)
    area = kernel.area(common)
    return Overlap(a_name, b_name, vol, 2.0 * vol / area if area > 0 else 0.0)


def adjacent_links(art: Articulation) -> set[frozenset[str]]:
    """Link pairs joined by a joint."""
    return {frozenset((j.parent, j.child)) for j in art.joints}


def rest_overlaps(model: CompiledModel, art: Articulation) -> list[Overlap]:
    """Interference between parts of non-adjacent links at rest."""
    adj = adjacent_links(art)
    shapes = {p.name: p.shape() for p in model.parts}
    out = []
    for a, b in itertools.combinations([p.name for p in model.parts], 2):
        la, lb = art.part_link[a], art.part_link[b]
        if la == lb or frozenset((la, lb)) in adj:
            continue
        o = overlap(a, shapes[a], b, shapes[b])
        if o.volume > 0:
            out.append(o)
    return out
