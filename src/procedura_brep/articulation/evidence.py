"""Geometric evidence for articulation: symmetry axes per part, contact regions between parts.

Symmetry axes: the area-weighted second moment (covariance) of a part's surface triangles about
their area centroid. A solid of revolution has two equal eigenvalues; the eigenvector of the
third, distinct one is its axis. When all three are equal (a cube, a sphere) there is no unique
axis; when all differ there is none either. "Equal" means within ``TOL.symmetry_eig_rel`` of
the largest eigenvalue.

Contacts: for part pairs whose boxes touch, the face-to-face contact area: coplanar,
opposite-facing triangles within ``TOL.contact_mm`` are intersected exactly in their plane
(see :func:`contact_area`). That sees flat contact only; where a mate joins the pair, its bearing
area as the mate gate measures it (:func:`procedura_brep.gates.mate_gate.bearing_area`: curved
seats too, a saddle on a tube) is the pair's contact when it is larger, so the evidence and the
mate gate never disagree on a mated seat.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from ..config import TOL
from ..kernel import Mesh, bbox
from ..mates.placement import plane_basis
from ..program.model import CompiledModel


def _tri_data(mesh: Mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    v = mesh.vertices[mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    return v, area, v.mean(axis=1)


def symmetry_axis(mesh: Mesh) -> dict[str, Any]:
    """``{"kind": "axis"|"isotropic"|"none", "axis": [...], "point": [...], "eigenvalues": [...]}``
    from the area-weighted covariance of the surface (exact per-triangle second moments)."""
    v, area, cen = _tri_data(mesh)
    total = float(area.sum())
    c = (area[:, None] * cen).sum(axis=0) / total
    cov = np.zeros((3, 3))
    for k in range(3):  # exact second moment of a triangle: (sum vi vi^T + (sum vi)(sum vi)^T)/12
        d = v[:, k] - c
        cov += np.einsum("n,ni,nj->ij", area, d, d)
    s = (v - c).sum(axis=1)
    cov = (cov + np.einsum("n,ni,nj->ij", area, s, s)) / (12.0 * total)
    w, vec = np.linalg.eigh(cov)
    tol = TOL.symmetry_eig_rel * float(w.max())
    out: dict[str, Any] = {"point": c.tolist(), "eigenvalues": w.tolist()}
    if w[2] - w[0] <= tol:
        return {**out, "kind": "isotropic", "axis": None}
    if w[1] - w[0] <= tol:
        return {**out, "kind": "axis", "axis": vec[:, 2].tolist()}
    if w[2] - w[1] <= tol:
        return {**out, "kind": "axis", "axis": vec[:, 0].tolist()}
    return {**out, "kind": "none", "axis": None}


def boxes_touch(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray],
                margin: float) -> bool:
    """Whether boxes ``a`` and ``b`` (each ``(lo, hi)``) meet or lie within ``margin`` (mm)."""
    (alo, ahi), (blo, bhi) = a, b
    return all(alo[i] <= bhi[i] + margin and blo[i] <= ahi[i] + margin for i in range(3))


def _faces_in_box(mesh: Mesh, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Indices of the triangles whose own box meets the box [lo, hi]."""
    tri = mesh.vertices[mesh.faces]
    return np.nonzero(np.all((tri.min(axis=1) <= hi) & (tri.max(axis=1) >= lo), axis=1))[0]


def _planes(tris: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit normals, plane offsets and areas of triangles (n, 3, 3)."""
    cross = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    n = cross / np.where(norm > 0, norm, 1.0)[:, None]
    return n, np.einsum("ij,ij->i", n, tris[:, 0]), 0.5 * norm


def contact_area(a: Mesh, b: Mesh, *, band: float = TOL.contact_mm) -> float:
    """Area (mm^2) where ``a``'s surface lies on ``b``'s surface, face to face.

    Contact between rigid parts that touch is planar (seats, flanges, faces): triangles of ``a``
    and ``b`` inside the overlap of their boxes are grouped by plane; where a plane of ``a``
    meets an opposite-facing plane of ``b`` within ``band``, the area is the exact 2-D
    intersection of the two triangle sets in that plane (shapely). Curved surfaces separated
    by a fit clearance do not count as contact.
    """
    from shapely import Polygon, intersection, unary_union
    lo = np.maximum(a.vertices.min(axis=0), b.vertices.min(axis=0)) - band
    hi = np.minimum(a.vertices.max(axis=0), b.vertices.max(axis=0)) + band
    if np.any(lo > hi):
        return 0.0
    ta = a.vertices[a.faces[_faces_in_box(a, lo, hi)]]
    tb = b.vertices[b.faces[_faces_in_box(b, lo, hi)]]
    if not len(ta) or not len(tb):
        return 0.0
    na, da, aa = _planes(ta)
    nb, db, ab = _planes(tb)
    keep_a, keep_b = aa > 0, ab > 0
    total = 0.0
    done = np.zeros(len(ta), dtype=bool)
    for i in np.nonzero(keep_a)[0]:
        if done[i]:
            continue
        same = keep_a & ~done & (na @ na[i] > TOL.contact_plane_cos) & (np.abs(da - da[i]) <= band)
        done |= same
        opp = keep_b & (nb @ na[i] < -TOL.contact_plane_cos) & (np.abs(db + da[i]) <= band)
        if not opp.any():
            continue
        basis = plane_basis(na[i])
        pa = unary_union([Polygon(t @ basis.T) for t in ta[same]])
        pb = unary_union([Polygon(t @ basis.T) for t in tb[opp]])
        total += float(intersection(pa, pb).area)
    return total


def mates_evidence(model: CompiledModel) -> dict[str, Any]:
    """``{"parts": {name: {"symmetry": ...}}, "contacts": [{"a", "b", "area_mm2", "face_mm2",
    "bearing_mm2", "mates"}]}``: ``face_mm2`` the flat face-to-face area, ``bearing_mm2`` the
    bearing area of the mates joining the pair (``mates``), ``area_mm2`` the larger."""
    from ..gates.mate_gate import bearing_area
    meshes = {p.name: p.mesh() for p in model.parts}
    boxes = {p.name: bbox(p.shape(), optimal=False) for p in model.parts}
    parts = {n: {"symmetry": symmetry_axis(m)} for n, m in meshes.items()}
    joined: dict[frozenset[str], list[Any]] = {}
    for m in model.mates:
        joined.setdefault(frozenset((m.child, m.parent)), []).append(m)
    contacts = []
    for a, b in itertools.combinations(meshes, 2):
        mates = joined.get(frozenset((a, b)), [])
        touch = boxes_touch(boxes[a], boxes[b], TOL.contact_mm)
        if not mates and not touch:
            continue
        face = contact_area(meshes[a], meshes[b]) if touch else 0.0
        bearing = sum(bearing_area(model, m) for m in mates)
        if max(face, bearing) > 0:
            contacts.append({"a": a, "b": b, "area_mm2": max(face, bearing), "face_mm2": face,
                             "bearing_mm2": bearing, "mates": [m.name for m in mates]})
    return {"parts": parts, "contacts": contacts}
