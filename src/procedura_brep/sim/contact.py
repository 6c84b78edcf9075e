"""Exact-geometry interference between parts (MuJoCo only sees convex hulls).

At rest (B3) the scan is the interference gate's own (:func:`rest_scan`): every pair of parts,
the shared bounded common, the same fit allowance. For the B2 sweeps, :func:`exact_overlap`
measures one posed pair: the OCCT boolean common, its *thickness* estimated as ``2 V / S`` (V
volume, S surface area of the common solid), exact for a thin slab and an under-estimate for
chunky overlaps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import kernel
from ..articulation.evidence import boxes_touch
from ..articulation.tree import Articulation
from ..program.model import CompiledModel

#: Boxes closer than this (mm) are tested with the exact boolean.
BOX_MARGIN_MM = 0.01


@dataclass(frozen=True)
class Overlap:
    """Interference between two parts: volume mm^3, thickness mm and, when they overlap, the
    common itself (for :meth:`point`)."""

    a: str
    b: str
    volume: float
    depth: float
    common: Any = field(default=None, repr=False, compare=False)

    def point(self) -> np.ndarray | None:
        """A point of the common (world mm: its vertex nearest its box centre), or None; read
        on demand, not for every pose a sweep checks."""
        return None if self.common is None else _point(self.common)


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
    return Overlap(a_name, b_name, vol, 2.0 * vol / area if area > 0 else 0.0, common)


def _point(shape) -> np.ndarray | None:
    """The vertex of ``shape`` nearest the centre of its box (world mm), or None."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    pts = []
    exp = TopExp_Explorer(shape, TopAbs_VERTEX)
    while exp.More() and len(pts) < 10000:
        p = BRep_Tool.Pnt_s(TopoDS.Vertex(exp.Current()))
        pts.append((p.X(), p.Y(), p.Z()))
        exp.Next()
    if not pts:
        return None
    arr = np.asarray(pts, float)
    lo, hi = kernel.bbox(shape, optimal=False)
    c = (np.asarray(lo) + np.asarray(hi)) / 2.0
    return arr[int(np.argmin(np.linalg.norm(arr - c, axis=1)))]


def adjacent_links(art: Articulation) -> set[frozenset[str]]:
    """Link pairs joined by a joint."""
    return {frozenset((j.parent, j.child)) for j in art.joints}


def rest_scan(model: CompiledModel) -> list:
    """Every overlapping pair of parts at rest, judged by the interference gate's rule
    (:func:`procedura_brep.gates.interference.scan`: same pairs, same fit allowance, same
    bounded common), so B3 and the gate agree."""
    from ..gates.interference import scan

    return scan(model)


def rest_overlaps(model: CompiledModel, art: Articulation | None = None) -> list[Overlap]:
    """The pairs at rest that no declared fit allows (any links, adjacent or not)."""
    return [Overlap(r.a, r.b, r.volume or 0.0, r.depth) for r in rest_scan(model) if not r.allowed]
