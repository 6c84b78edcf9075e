"""Part pieces: a part is one connected solid unless its function declares otherwise.

A part's mesh pieces (:class:`~procedura_brep.gates.geometry.Piece`) are grouped: the shells of
one B-rep solid are one group, and two solids of the part whose exact distance is at most
``TOL.connect_mm`` join (box sweep first, then ``BRepExtrema``). A part declared with
``@part(..., pieces=N)`` may have ``N`` groups; the ``N`` of largest volume are its body and
every other group is a *detached piece*: a ``part-pieces`` finding names its box. A detached
piece (a seat pad left in its counterbore when the part moved, a bolt head far from its hole)
does not count as bearing area in the mate gate (:func:`body_faces`).

This check has no span threshold: the connectivity gate's ``tau`` (1 % of the model span) is the
paper's and applies to N_vis only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledModel, CompiledPart, Finding
from .geometry import LRU, PartGeometry, box_pairs, part_geometry, solid_distance
from .policy import GateResult, result

_GROUPS: LRU = LRU()


@dataclass
class PartPieces:
    """The piece groups of one part, largest volume first, and how many it declares."""

    part: str
    declared: int
    groups: list[list[int]]
    volumes: list[float]
    boxes: list[tuple[np.ndarray, np.ndarray]]

    @property
    def extra(self) -> list[int]:
        """Indices (into ``groups``) of the detached pieces."""
        return list(range(self.declared, len(self.groups)))

    @property
    def body_pieces(self) -> set[int]:
        return {i for g in self.groups[:self.declared] for i in g}

    def as_dict(self) -> dict[str, Any]:
        return {"pieces": len(self.groups), "declared": self.declared,
                "detached": [{"bbox": [np.round(self.boxes[k][0], 4).tolist(),
                                       np.round(self.boxes[k][1], 4).tolist()],
                              "volume_mm3": round(self.volumes[k], 6)} for k in self.extra]}


def declared_pieces(part: CompiledPart) -> int:
    """The part's declared piece count (``@part(pieces=N)``; 1 when absent)."""
    return max(1, int(getattr(part, "pieces", 1) or 1))


def part_pieces(part: CompiledPart, geo: PartGeometry | None = None) -> PartPieces:
    """Group ``part``'s pieces by contact (cached by digest and declaration)."""
    geo = geo or part_geometry(part)
    declared = declared_pieces(part)
    key = (geo.digest, declared)
    hit = _GROUPS.get(key)
    if hit is not None and hit.part == part.name:
        return hit
    pcs = geo.pieces
    parent = list(range(len(pcs)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    if len(pcs) > 1:
        lo = np.array([p.lo for p in pcs])
        hi = np.array([p.hi for p in pcs])
        for i, j in box_pairs(lo, hi, TOL.connect_mm).tolist():
            ri, rj = find(i), find(j)
            if ri == rj:
                continue
            if pcs[i].solid == pcs[j].solid or solid_distance(geo, pcs[i].solid, geo,
                                                              pcs[j].solid) <= TOL.connect_mm:
                parent[max(ri, rj)] = min(ri, rj)
    groups: dict[int, list[int]] = {}
    for i in range(len(pcs)):
        groups.setdefault(find(i), []).append(i)
    gl = sorted(groups.values(), key=lambda g: -abs(sum(pcs[i].volume for i in g)))
    vols = [abs(float(sum(pcs[i].volume for i in g))) for g in gl]
    boxes = [(np.min([pcs[i].lo for i in g], 0), np.max([pcs[i].hi for i in g], 0)) for g in gl]
    return _GROUPS.put(key, PartPieces(part.name, declared, gl, vols, boxes))


def body_faces(part: CompiledPart, geo: PartGeometry | None = None) -> np.ndarray:
    """Mask of ``geo``'s triangles on the part's body (detached pieces excluded)."""
    geo = geo or part_geometry(part)
    pp = part_pieces(part, geo)
    if not pp.extra:
        return np.ones(len(geo.faces), dtype=bool)
    return np.isin(geo.labels, sorted(pp.body_pieces))


def _box(lo: np.ndarray, hi: np.ndarray) -> str:
    a, b = (", ".join(f"{x:.1f}" for x in v) for v in (lo, hi))
    return f"({a})..({b}) mm"


def pieces_gate(model: CompiledModel) -> tuple[list[Finding], GateResult]:
    """One ``part-pieces`` finding per detached piece (at most ``TOL.part_piece_findings`` per
    part, then one counting the rest); ``measured`` maps part name to :meth:`PartPieces.as_dict`
    for every part with more pieces than it declares."""
    findings: list[Finding] = []
    measured: dict[str, Any] = {}
    for part in model.parts:
        pp = part_pieces(part)
        if not pp.extra:
            continue
        measured[part.name] = pp.as_dict()
        n = len(pp.groups)
        body = _box(*pp.boxes[0])
        for k in pp.extra[:TOL.part_piece_findings]:
            findings.append(Finding(
                "part-pieces",
                f"{part.name} is {n} disconnected pieces (declared {pp.declared}): a piece at "
                f"bbox {_box(*pp.boxes[k])} ({pp.volumes[k]:.3g} mm^3) is detached from its body "
                f"at {body}; join it to the body (overlap or touch within {TOL.connect_mm} mm) or "
                f"declare @part(..., pieces={n})",
                part=part.name, line=part.lines[0] or None, value=float(n),
                limit=float(pp.declared)))
        rest = len(pp.extra) - TOL.part_piece_findings
        if rest > 0:
            findings.append(Finding(
                "part-pieces", f"{part.name}: {rest} more detached piece(s) not listed",
                part=part.name, line=part.lines[0] or None, value=float(n),
                limit=float(pp.declared)))
    return findings, result("pieces", findings, measured)


def clear() -> None:
    _GROUPS.clear()
