"""Exact-geometry interference between parts (MuJoCo only sees convex hulls).

Interference of two solids is the OCCT boolean common; its *thickness* is estimated as
``2 V / S`` (V volume, S surface area of the common solid), which is exact for a thin slab and
an under-estimate for chunky overlaps. Pairs are prefiltered by bounding boxes.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .. import kernel
from ..articulation.tree import Articulation, Joint
from ..mates.placement import delta
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


def _boxes_touch(a, b) -> bool:
    (alo, ahi), (blo, bhi) = a, b
    return all(alo[i] <= bhi[i] + BOX_MARGIN_MM and blo[i] <= ahi[i] + BOX_MARGIN_MM for i in range(3))


def overlap(a_name: str, a_shape, b_name: str, b_shape) -> Overlap:
    """Exact interference of two located shapes."""
    if not _boxes_touch(kernel.bbox(a_shape, optimal=False), kernel.bbox(b_shape, optimal=False)):
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


def rest_overlaps(model: CompiledModel, art: Articulation, *, adjacent: bool = False) -> list[Overlap]:
    """Interference between parts of different links at rest (non-adjacent links only unless
    ``adjacent``)."""
    adj = adjacent_links(art)
    shapes = {p.name: p.shape() for p in model.parts}
    out = []
    for a, b in itertools.combinations([p.name for p in model.parts], 2):
        la, lb = art.part_link[a], art.part_link[b]
        if la == lb or (not adjacent and frozenset((la, lb)) in adj):
            continue
        o = overlap(a, shapes[a], b, shapes[b])
        if o.volume > 0:
            out.append(o)
    return out


def joint_motion(joint: Joint, q: float | list[float]) -> np.ndarray:
    """World 4x4 motion (mm) of the child subtree when ``joint`` moves to ``q`` (rad or m from
    the compiled pose)."""
    f = joint.frame
    if joint.type == "prismatic":
        d = delta("prismatic", float(q) * 1000.0)  # type: ignore[arg-type]
    elif joint.type == "spherical":
        d = delta("spherical", [float(np.degrees(v)) for v in q])  # type: ignore[union-attr]
    else:
        d = delta("revolute", float(np.degrees(q)))  # type: ignore[arg-type]
    return f @ d @ np.linalg.inv(f)


def moved_overlaps(model: CompiledModel, art: Articulation, joint: Joint,
                   q: float) -> dict[tuple[str, str], Overlap]:
    """Interference between the joint's moving subtree (moved to ``q``) and every other part."""
    moving = {p for lk in art.subtree(joint.child) for p in art.link(lk).parts}
    motion = joint_motion(joint, q)
    out = {}
    for a in sorted(moving):
        pa = model.part(a)
        sa = kernel.located(pa.local_shape(), motion @ pa.placement)
        for p in model.parts:
            if p.name in moving:
                continue
            o = overlap(a, sa, p.name, p.shape())
            out[(a, p.name)] = o
    return out
