"""Connectivity gate (paper eq. 4): visible floaters by span, not volume.

Pieces are the connected pieces of each part's welded tessellation (union-find over shared
vertices, so a part that is two disjoint solids is two pieces; the shells of one solid, such as
an inner void, are joined since a solid is one body). Two pieces join when their exact
B-rep solids are within :data:`~procedura_brep.gates.geometry.CONNECT_MM`: bounding boxes grown by
that distance are checked first (a sort-and-sweep along the most spread axis, near-linear), then a
cheap positive test (two mesh vertices,
which lie on the exact surfaces, within the distance, for single-piece parts), and only then
``BRepExtrema_DistShapeShape``, whose result is cached by the two parts' digests, asked of the
pairs in order of their cost (face pairs whose boxes meet, :func:`.common.face_pairs`) and only
while the two pieces are still apart. Then::

    rho_i = span(c_i) / span(M)        span = largest side of the axis-aligned bbox
    body  = the component of largest volume
    N_vis = |{ i != body : rho_i >= TOL.span_tau }|
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledModel, Finding
from .common import face_boxes, face_pairs
from .geometry import CONNECT_MM, Piece, box_pairs, part_geometry, solid_distance, vertices_touch
from .policy import GateResult, result


@dataclass
class Component:
    """One connected component of the shipped geometry (pieces joined by contact)."""

    pieces: list[Piece]
    lo: np.ndarray
    hi: np.ndarray
    volume: float
    rho: float = 0.0

    @property
    def parts(self) -> list[str]:
        return sorted({p.part for p in self.pieces})

    @property
    def span(self) -> float:
        return float(np.max(self.hi - self.lo)) if len(self.lo) else 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"parts": self.parts, "pieces": len(self.pieces), "rho": round(self.rho, 6),
                "span_mm": round(self.span, 6), "volume_mm3": round(self.volume, 6),
                "bbox": [np.round(self.lo, 4).tolist(), np.round(self.hi, 4).tolist()]}


@dataclass
class Connectivity:
    """All components, the body's index, N_vis and the visible floaters (worst first)."""

    components: list[Component]
    body: int
    n_vis: int
    floaters: list[Component]
    span: float

    def as_dict(self) -> dict[str, Any]:
        return {"n_vis": self.n_vis, "components": len(self.components), "span_mm": round(self.span, 6),
                "tau": TOL.span_tau, "contact_mm": CONNECT_MM,
                "floaters": [c.as_dict() for c in self.floaters]}


class _UF:
    def __init__(self, n: int) -> None:
        self.p = list(range(n))

    def find(self, i: int) -> int:
        while self.p[i] != i:
            self.p[i] = self.p[self.p[i]]
            i = self.p[i]
        return i

    def union(self, a: int, b: int) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.p[max(ra, rb)] = min(ra, rb)


def analyse(model: CompiledModel, *, tau: float = TOL.span_tau, contact: float = CONNECT_MM,
            touching: frozenset[frozenset[str]] = frozenset()) -> Connectivity:
    """Components, body and N_vis of ``model``'s shipped geometry.

    Args:
        touching: part pairs already proven to touch (e.g. by the mate gate's registration
            area, whose band is within ``contact``); for single-piece parts they are joined
            without an exact distance query.
    """
    geos = [part_geometry(p) for p in model.parts]
    pieces: list[tuple[int, Piece]] = [(g, pc) for g, geo in enumerate(geos) for pc in geo.pieces]
    uf = _UF(len(pieces))
    boxes = [(pc.lo, pc.hi) for _, pc in pieces]
    # sort and sweep (geometry.box_pairs): only pieces whose boxes, grown by `contact`, overlap
    cand = box_pairs(np.array([b[0] for b in boxes]).reshape(-1, 3),
                     np.array([b[1] for b in boxes]).reshape(-1, 3), contact)
    # two passes: the cheap proofs of contact first (same solid, a registered mate, a shared
    # vertex), so the exact distance is asked only of pairs still in different components
    _join_blocks(model, pieces, uf)
    exact = []
    for i, j in cand.tolist():
        gi, pi = pieces[i]
        gj, pj = pieces[j]
        if uf.find(i) == uf.find(j):
            continue
        if gi == gj and pi.solid == pj.solid:
            uf.union(i, j)  # shells of one solid (e.g. an inner void) are one body
        elif len(geos[gi].pieces) == 1 and len(geos[gj].pieces) == 1 and (
                frozenset((geos[gi].name, geos[gj].name)) in touching
                or vertices_touch(geos[gi], geos[gj], boxes[i], boxes[j], contact)):
            uf.union(i, j)  # single-piece parts: a registered mate or a shared vertex proves contact
        else:
            exact.append((i, j))
    # cheapest first: a query is skipped once its pieces are joined by others, and the closure
    # is the same in any order, so a slow pair (two helical threads: 100 s) is asked last and
    # often never (its screw and nut already joined through the carriage in 9 s)
    exact.sort(key=lambda ij: (face_pairs(face_boxes(geos[pieces[ij[0]][0]]),
                                          face_boxes(geos[pieces[ij[1]][0]])), ij))
    for i, j in exact:
        if uf.find(i) == uf.find(j):
            continue
        (gi, pi), (gj, pj) = pieces[i], pieces[j]
        if solid_distance(geos[gi], pi.solid, geos[gj], pj.solid) <= contact:
            uf.union(i, j)
    groups: dict[int, list[Piece]] = {}
    for i, (_, pc) in enumerate(pieces):
        groups.setdefault(uf.find(i), []).append(pc)
    comps = [Component(ps, np.min([p.lo for p in ps], 0), np.max([p.hi for p in ps], 0),
                       abs(float(sum(p.volume for p in ps)))) for ps in groups.values()]
    if not comps:
        return Connectivity([], -1, 0, [], 0.0)
    span = float(np.max(np.max([c.hi for c in comps], 0) - np.min([c.lo for c in comps], 0)))
    for c in comps:
        c.rho = c.span / span if span > 0 else 0.0
    body = int(np.argmax([c.volume for c in comps]))
    floaters = sorted((c for k, c in enumerate(comps) if k != body and c.rho >= tau),
                      key=lambda c: -c.rho)
    return Connectivity(comps, body, len(floaters), floaters, span)


def _join_blocks(model: CompiledModel, pieces: list[tuple[int, Piece]], uf: _UF) -> None:
    """A colour block (``@paint``) is attached to its painted part: every piece of a block
    joins the first piece of the part it was cut from."""
    first: dict[int, int] = {}
    for k, (g, _) in enumerate(pieces):
        first.setdefault(g, k)
    index = {p.name: g for g, p in enumerate(model.parts)}
    for k, (g, _) in enumerate(pieces):
        owner = index.get(model.parts[g].block_of or "")
        if owner is not None and owner in first:
            uf.union(first[owner], k)


def _fmt_box(c: Component) -> str:
    lo, hi = (", ".join(f"{x:.1f}" for x in v) for v in (c.lo, c.hi))
    return f"bbox ({lo})..({hi}) mm"


def floater_findings(conn: Connectivity, *, code: str = "floater", severity: str = "error",
                     top: int | None = None) -> list[Finding]:
    """One finding per visible floater (worst first, at most ``top``), naming parts and bbox."""
    out = []
    for c in conn.floaters[:top]:
        names = ", ".join(c.parts)
        out.append(Finding(
            code, f"{names} float(s) free of the body: span {c.span:.3g} mm = {c.rho:.1%} of the "
            f"model (tau {TOL.span_tau:.0%}), {_fmt_box(c)}; attach it with a mate or close the gap "
            f"(contact within {CONNECT_MM} mm)",
            part=c.parts[0] if len(c.parts) == 1 else None, value=c.rho, limit=TOL.span_tau,
            severity=severity))
    return out


def connectivity_gate(model: CompiledModel, *, baseline: int | None = None) -> tuple[list[Finding], GateResult]:
    """Run the connectivity gate.

    Args:
        model: the compiled model.
        baseline: the running N_vis before this change (delta-aware build mode). When given,
            floaters are errors only if N_vis rises above ``baseline``; otherwise they are warnings.
            None (finish/check mode) makes every visible floater an error.

    Returns:
        (findings, result); ``result.measured`` holds :meth:`Connectivity.as_dict`.
    """
    return judge(analyse(model), baseline=baseline)


def judge(conn: Connectivity, *, baseline: int | None = None) -> tuple[list[Finding], GateResult]:
    """The connectivity verdict on an analysis: every visible floater is an error, or with a
    ``baseline`` (delta-aware build mode) only when N_vis rises above it (else a warning)."""
    worse = baseline is None or conn.n_vis > baseline
    findings = floater_findings(conn, severity="error" if worse else "warning")
    if baseline is not None and worse:
        findings.insert(0, Finding(
            "floater-increase", f"visible floaters rose from {baseline} to {conn.n_vis}",
            value=float(conn.n_vis), limit=float(baseline)))
    measured = conn.as_dict()
    if baseline is not None:
        measured["baseline"] = baseline
    return findings, result("connectivity", findings, measured)
