"""Per-part geometry the gates share: world mesh, pieces, boxes, edge angles, exact contacts.

Everything here is cached by :attr:`CompiledPart.digest` (the local BRep plus the placement), so
re-running the gates after the agent adds one part re-tessellates only that part. Contacts between
two parts are cached by the pair of digests. Lengths are mm.

Only :mod:`procedura_brep.kernel` (raw OCP) is imported, lazily; never build123d.
"""

from __future__ import annotations

import logging
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledPart

log = logging.getLogger(__name__)

#: Two pieces whose exact B-rep distance is at most this touch (connectivity). Larger than
#: ``TOL.contact_mm`` on purpose: ISO 286 fits leave radial gaps of 5-30 um and a seated child
#: sits on its parent face at distance 0, so 0.05 mm treats every fit clearance as contact while a
#: visible gap (0.1 mm and up, what a person sees as "floating") is not. Lead: move to
#: ``config.Tolerances.connect_mm``.
CONNECT_MM: float = TOL.connect_mm

#: Entries kept in each per-digest cache (parts, pair distances, mate measurements).
CACHE_SIZE: int = 4096

Box = tuple[np.ndarray, np.ndarray]


#: Every gate cache made (:class:`LRU` registers itself): what :func:`clear_caches` forgets.
_CACHES: list[LRU] = []


class LRU(OrderedDict):
    """A tiny bounded mapping: the oldest entry goes when ``CACHE_SIZE`` is exceeded. Each one
    registers itself with :func:`clear_caches` (so this module imports none of the gates whose
    caches it clears)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _CACHES.append(self)

    def put(self, key: Any, value: Any) -> Any:
        self[key] = value
        self.move_to_end(key)
        while len(self) > CACHE_SIZE:
            self.popitem(last=False)
        return value


@dataclass
class Piece:
    """One connected piece of a part's welded tessellation (union-find over shared vertices).

    Attributes:
        part: owning part name.
        index: piece number within the part.
        solid: index of the part's B-rep solid this piece belongs to.
        lo: bbox min corner (3,), world mm.
        hi: bbox max corner (3,), world mm.
        volume: signed volume enclosed by the piece's triangles, mm^3 (negative for a void shell).
        triangles: triangle count.
    """

    part: str
    index: int
    solid: int
    lo: np.ndarray
    hi: np.ndarray
    volume: float
    triangles: int

    @property
    def span(self) -> float:
        return float(np.max(self.hi - self.lo))


@dataclass
class PartGeometry:
    """Cached world-space geometry of one compiled part."""

    name: str
    digest: str
    vertices: np.ndarray
    faces: np.ndarray
    labels: np.ndarray
    pieces: list[Piece]
    solids: list[Any]
    solid_boxes: list[Box]
    lo: np.ndarray
    hi: np.ndarray
    _edges: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    @property
    def triangles(self) -> int:
        return int(len(self.faces))

    def edge_angles(self) -> tuple[np.ndarray, np.ndarray]:
        """(dihedral angle in degrees, edge length mm) for every interior mesh edge (cached).

        The dihedral here is the angle between the two adjacent face normals: 0 on a flat face,
        90 on a box edge. Boundary and non-manifold edges are ignored.
        """
        if self._edges is None:
            self._edges = dihedral_edges(self.vertices, self.faces)
        return self._edges


_PARTS: LRU = LRU()
_DIST: LRU = LRU()


def clear_caches() -> None:
    """Forget the gates' own caches: part geometries (built on the part meshes), distances,
    commons, piece groupings and mate measures. The part meshes themselves are the model's,
    shared with exports and renders, and stay: :func:`procedura_brep.program.model.clear_mesh_cache`
    forgets them (a cold measurement needs both)."""
    for cache in _CACHES:
        cache.clear()


def face_components(n_vertices: int, faces: np.ndarray) -> tuple[int, np.ndarray]:
    """(count, label per face): faces joined where they share a (welded) vertex."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if len(faces) == 0:
        return 0, np.zeros(0, dtype=np.int64)
    m = len(faces)
    rows = np.repeat(np.arange(m), 3)
    graph = coo_matrix((np.ones(3 * m), (rows, m + faces.reshape(-1))), shape=(m + n_vertices,) * 2)
    _, labels = connected_components(graph, directed=False)
    face_labels = labels[:m]
    uniq, dense = np.unique(face_labels, return_inverse=True)
    return int(len(uniq)), dense.reshape(-1)


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Signed volume enclosed by triangles (divergence theorem), mm^3."""
    if len(faces) == 0:
        return 0.0
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def dihedral_edges(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(angle deg, length mm) per manifold interior edge of a welded triangle mesh."""
    if len(faces) < 2:
        return np.zeros(0), np.zeros(0)
    e = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    owner = np.repeat(np.arange(len(faces)), 3)
    order = np.lexsort((e[:, 1], e[:, 0]))
    e, owner = e[order], owner[order]
    _, start, count = np.unique(e, axis=0, return_index=True, return_counts=True)
    two = start[count == 2]
    fa, fb = owner[two], owner[two + 1]
    n = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    cos = np.clip(np.einsum("ij,ij->i", n[fa], n[fb]), -1.0, 1.0)
    ends = e[two]
    length = np.linalg.norm(vertices[ends[:, 0]] - vertices[ends[:, 1]], axis=1)
    return np.degrees(np.arccos(cos)), length


def _solids(shape: Any) -> list[Any]:
    """The solids of ``shape``, or the shape itself when it holds none."""
    from .. import kernel
    return kernel.solids(shape) or [shape]


def part_geometry(part: CompiledPart) -> PartGeometry:
    """The cached :class:`PartGeometry` of ``part`` (tessellated once per digest)."""
    key = part.digest
    hit = _PARTS.get(key)
    if hit is not None and hit.name == part.name:
        return hit
    from .. import kernel

    shape = part.shape()
    mesh = part.mesh()
    v, f = mesh.vertices, mesh.faces
    solids = _solids(shape)
    boxes = [tuple(np.array(c) for c in kernel.bbox(s, optimal=False)) for s in solids]
    n, labels = face_components(len(v), f)
    pieces: list[Piece] = []
    if n:
        # group faces by piece with one sort (linear in faces, not pieces x faces)
        order = np.argsort(labels, kind="stable")
        starts = np.searchsorted(labels[order], np.arange(n + 1))
        tri = v[f]
        plo, phi = tri.min(axis=1), tri.max(axis=1)
        vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6.0
        los = np.array([plo[order[starts[i]:starts[i + 1]]].min(axis=0) for i in range(n)])
        his = np.array([phi[order[starts[i]:starts[i + 1]]].max(axis=0) for i in range(n)])
        owner = _solids_of(los, his, boxes)
        for i in range(n):
            idx = order[starts[i]:starts[i + 1]]
            pieces.append(Piece(part.name, i, int(owner[i]), los[i], his[i],
                                float(vol[idx].sum()), int(len(idx))))
    if len(v):
        lo, hi = v.min(axis=0), v.max(axis=0)
    else:
        lo = hi = part.placement[:3, 3].astype(float)
    geo = PartGeometry(part.name, key, v, f, labels, pieces, solids, boxes, lo, hi)
    log.debug("tessellated %s: %d triangles, %d pieces", part.name, len(f), n)
    return _PARTS.put(key, geo)


def _solids_of(lo: np.ndarray, hi: np.ndarray, boxes: list[Box]) -> np.ndarray:
    """Per piece box, the solid whose (loose) bbox best contains it (near-linear: box sweep)."""
    if len(boxes) <= 1:
        return np.zeros(len(lo), dtype=np.int64)
    slo = np.array([b[0] for b in boxes])
    shi = np.array([b[1] for b in boxes])
    out = np.zeros(len(lo), dtype=np.int64)
    best = np.full(len(lo), np.inf)
    pairs = box_pairs(lo, hi, 0.0, slo, shi)
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        score = (np.maximum(slo[j] - lo[i], 0).sum(1) + np.maximum(hi[i] - shi[j], 0).sum(1))
        order = np.lexsort((score, i))
        first = np.unique(i[order], return_index=True)[1]
        out[i[order][first]] = j[order][first]
        best[i[order][first]] = score[order][first]
    return out


def box_pairs(lo: np.ndarray, hi: np.ndarray, gap: float, lo2: np.ndarray | None = None,
              hi2: np.ndarray | None = None) -> np.ndarray:
    """Index pairs of boxes that overlap once grown by ``gap`` (sort and sweep, output-sensitive).

    With one set, returns ``(i, j)`` with ``i < j``; with a second set (``lo2``, ``hi2``), pairs
    ``(i in set 1, j in set 2)``. The sweep runs along the axis where the boxes are most spread
    out relative to their size, so boxes in a row along any axis cost O(n log n + pairs).
    """
    lo, hi = np.asarray(lo, float).reshape(-1, 3), np.asarray(hi, float).reshape(-1, 3)
    two = lo2 is not None
    blo = np.asarray(lo2, float).reshape(-1, 3) if two else lo
    bhi = np.asarray(hi2, float).reshape(-1, 3) if two else hi
    if not len(lo) or not len(blo):
        return np.zeros((0, 2), dtype=np.int64)
    allc = np.vstack([lo + hi, blo + bhi]) / 2.0
    size = np.vstack([hi - lo, bhi - blo]).mean(axis=0) + gap
    axis = int(np.argmax((allc.max(0) - allc.min(0)) / np.maximum(size, 1e-12)))
    out: list[np.ndarray] = []

    def emit(alo: np.ndarray, ahi: np.ndarray, clo: np.ndarray, chi: np.ndarray,
             swap: bool, strict: bool) -> None:
        # pairs (a, c) where c's start lies in a's grown interval along the axis
        order = np.argsort(clo[:, axis], kind="stable")
        keys = clo[order, axis]
        first = np.searchsorted(keys, alo[:, axis] - gap, side="right" if strict else "left")
        last = np.searchsorted(keys, ahi[:, axis] + gap, side="right")
        for i in np.nonzero(last > first)[0]:
            cand = order[first[i]:last[i]]
            ok = np.all(clo[cand] - gap <= ahi[i], axis=1) & np.all(alo[i] - gap <= chi[cand], axis=1)
            sel = cand[ok]
            if len(sel):
                col = np.full(len(sel), i)
                out.append(np.stack([sel, col] if swap else [col, sel], 1))

    if two:
        emit(lo, hi, blo, bhi, False, False)   # set-2 boxes starting inside a set-1 box
        emit(blo, bhi, lo, hi, True, True)     # set-1 boxes starting strictly inside a set-2 box
        if not out:
            return np.zeros((0, 2), dtype=np.int64)
        return np.unique(np.vstack(out).astype(np.int64), axis=0)
    order = np.argsort(lo[:, axis], kind="stable")
    keys = lo[order, axis]
    last = np.searchsorted(keys, hi[order, axis] + gap, side="right")
    for k in np.nonzero(last > np.arange(len(order)) + 1)[0]:
        i, cand = order[k], order[k + 1:last[k]]
        ok = np.all(lo[cand] - gap <= hi[i], axis=1) & np.all(lo[i] - gap <= hi[cand], axis=1)
        sel = cand[ok]
        if len(sel):
            out.append(np.sort(np.stack([np.full(len(sel), i), sel], 1), axis=1))
    return np.vstack(out).astype(np.int64) if out else np.zeros((0, 2), dtype=np.int64)


def boxes_near(a: Box, b: Box, gap: float) -> bool:
    """True when two boxes overlap once each is grown by ``gap``."""
    return bool(np.all(a[0] - gap <= b[1]) and np.all(b[0] - gap <= a[1]))


def exact_distance(shape_a: Any, shape_b: Any) -> float:
    """Minimum distance between two B-rep shapes, mm (:func:`procedura_brep.kernel.distance`)."""
    from .. import kernel
    return kernel.distance(shape_a, shape_b)


def solid_distance(ga: PartGeometry, ia: int, gb: PartGeometry, ib: int) -> float:
    """Cached exact distance between solid ``ia`` of ``ga`` and solid ``ib`` of ``gb``."""
    key = (ga.digest, ia, gb.digest, ib) if ga.digest <= gb.digest else (gb.digest, ib, ga.digest, ia)
    hit = _DIST.get(key)
    if hit is None:
        hit = _DIST.put(key, exact_distance(ga.solids[ia], gb.solids[ib]))
    return hit


def vertices_touch(ga: PartGeometry, gb: PartGeometry, box_a: Box, box_b: Box, gap: float) -> bool:
    """Cheap positive contact test: some mesh vertex of ``ga`` lies within ``gap`` of one of ``gb``.

    Mesh vertices lie on the exact surfaces, so True proves the solids are within ``gap``; False
    proves nothing (a small face resting inside a large one shares no vertex with it).
    Only vertices inside the overlap of the two boxes (grown by ``gap``) are compared.
    """
    from scipy.spatial import cKDTree

    lo = np.maximum(box_a[0], box_b[0]) - gap
    hi = np.minimum(box_a[1], box_b[1]) + gap
    va = ga.vertices[np.all((ga.vertices >= lo) & (ga.vertices <= hi), axis=1)]
    vb = gb.vertices[np.all((gb.vertices >= lo) & (gb.vertices <= hi), axis=1)]
    if not len(va) or not len(vb):
        return False
    dist, _ = cKDTree(vb).query(va, k=1, distance_upper_bound=gap)
    return bool(np.isfinite(dist).any())
