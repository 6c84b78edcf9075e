"""A conservative sphere cover of a part's surface, for the sweep's near-contact prefilter.

Points are laid on every triangle of the part's shipped tessellation (world coordinates, rest
pose; the size rule's deflection, :func:`procedura_brep.kernel.mesh_deflection`) no further
apart than half a cell and binned into cubic cells of side ``TOL.sweep_cell_mm``, or coarser for a
part whose surface would need more than ``TOL.sweep_max_cells`` cells. Each occupied cell becomes
one sphere about the cell centre whose radius covers the cell (half its diagonal), the point
spacing and the tessellation's deviation from the exact surface, so every point of the exact
surface lies inside a sphere.

For a moved part, the faces whose rotation about the joint axis sweeps no volume are left out:
planes normal to the axis (they slide in their own plane, whatever their outline), and
cylinders, cones, spheres and tori about the axis bounded only by circles about it and seams (a
pin, a round hub: they map onto themselves). A point changes from outside to inside the moved
solid only when a boundary point passes over it, so only the other faces can start or deepen an
interference (:func:`invariant_under_rotation`).

For a slide along a unit direction ``u`` (a prismatic joint, the slide of a cylindrical one) the
moved part moves ``+u`` as the joint value rises, and the sweep runs from the lower limit up.
Overlap grows only where a *leading* face of the moved part (outward normal with a positive
component along ``u``) passes over the fixed part's interior, and such a face can first enter
the fixed part only through an *opposing* face of it (outward normal against ``u``): faces
whose normals are all perpendicular to ``u`` (planes containing ``u``, cylinders along ``u``)
slide within themselves. So from a pose where the two parts do not overlap, the moved part's
cover keeps only faces that may lead and the fixed part's only faces that may oppose
(:func:`faces_along`): a bearing block touching its rail on three faces along the motion has
no cells there at all, while its front face and a stop block's back face do
(:func:`side_of_motion`).

Two posed solids whose covers do not meet have disjoint surfaces: they are apart, or one lies
wholly inside the other (which a sweep that moves no point by more than ``TOL.sweep_step_mm`` a
step can only reach through a pose where the surfaces met).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..config import TOL
from ..mates.placement import plane_basis

#: Two directions are parallel (and a point is on an axis) within these tolerances.
PARALLEL_EPS = 1e-9
ON_AXIS_MM = 1e-6
#: At most this many subdivisions of one triangle edge (bounds the points of a huge face: a
#: part whose longest edge needs more gets coarser cells, :func:`cell_side`).
MAX_SUBDIV = 400


@dataclass(frozen=True)
class Cover:
    """Sphere centres (n, 3) in world mm at rest and their common radius, mm."""

    centres: np.ndarray
    radius: float


def _triangles(face, o) -> np.ndarray:
    loc = o["TopLoc"].TopLoc_Location()
    tri = o["BRep"].BRep_Tool.Triangulation_s(face, loc)
    if tri is None:
        return np.zeros((0, 3, 3))
    t = loc.Transformation()
    pts = np.array([(p.X(), p.Y(), p.Z()) for p in
                    (tri.Node(i).Transformed(t) for i in range(1, tri.NbNodes() + 1))])
    idx = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)], dtype=np.int64) - 1
    return pts[idx]


#: A cell grid of at most this many cells is marked in a flat boolean array (one pass, no
#: sort); a larger one (a huge part at fine cells) falls back to sorting the cell codes.
MAX_GRID = 1 << 26
#: The most points laid in one batch (bounds the memory of one batch).
BATCH_POINTS = 1 << 20


def _cells(tris: np.ndarray, h: float, cell: float) -> np.ndarray:
    """Integer keys (n, 3) of the cells of side ``cell`` holding points laid on triangles
    (n, 3, 3) so that no surface point is further than ``h`` from one (sorted as their codes).

    Each triangle with an edge longer than ``h`` gets a barycentric grid of ``n + 1`` points a
    side (``n = ceil(longest edge / h)``); the points of every triangle with one ``n`` are laid
    together, a coordinate at a time (one matrix product each), and their cells marked in a
    grid spanning the triangles' box."""
    if not len(tris):
        return np.zeros((0, 3), dtype=np.int64)
    edge = np.max(np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2), axis=1)
    subdiv = np.clip(np.ceil(edge / h).astype(int), 1, MAX_SUBDIV)
    lo = np.floor(tris.reshape(-1, 3).min(axis=0) / cell).astype(np.int64) - 1
    span = np.floor(tris.reshape(-1, 3).max(axis=0) / cell).astype(np.int64) - lo + 2
    total = int(np.prod(span))
    grid = np.zeros(total, dtype=bool) if total <= MAX_GRID else None
    found: list[np.ndarray] = []

    def mark(xs: np.ndarray, ys: np.ndarray, zs: np.ndarray) -> None:
        code = np.floor(xs / cell).astype(np.int64) - lo[0]
        code *= span[1]
        code += np.floor(ys / cell).astype(np.int64) - lo[1]
        code *= span[2]
        code += np.floor(zs / cell).astype(np.int64) - lo[2]
        if grid is not None:
            grid[code.ravel()] = True
        else:
            found.append(np.unique(code))

    verts = tris.reshape(-1, 3)
    mark(verts[:, 0], verts[:, 1], verts[:, 2])
    for n in np.unique(subdiv):
        if n <= 1:
            continue
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = (i + j) <= n
        bary_t = np.ascontiguousarray(
            np.column_stack([i[keep], j[keep], n - i[keep] - j[keep]]).T / n)  # (3, k)
        group = tris[subdiv == n]  # (g, 3, 3)
        step = max(1, BATCH_POINTS // bary_t.shape[1])
        for s in range(0, len(group), step):
            g = group[s:s + step]
            mark(g[:, :, 0] @ bary_t, g[:, :, 1] @ bary_t, g[:, :, 2] @ bary_t)  # (g, k) each
    c = np.flatnonzero(grid) if grid is not None else np.unique(np.concatenate(found))
    kz = c % span[2]
    ky = (c // span[2]) % span[1]
    kx = c // (span[2] * span[1])
    return np.column_stack([kx, ky, kz]) + lo


def _circle_about(curve, point: np.ndarray, axis: np.ndarray) -> bool:
    return _coaxial(curve.Circle().Axis(), point, axis)


def _coaxial(ax1, point: np.ndarray, axis: np.ndarray) -> bool:
    d = ax1.Direction()
    u = np.array([d.X(), d.Y(), d.Z()])
    if abs(abs(float(u @ axis)) - 1.0) > PARALLEL_EPS:
        return False
    loc = ax1.Location()
    q = np.array([loc.X(), loc.Y(), loc.Z()]) - point
    return float(np.linalg.norm(q - (q @ axis) * axis)) <= ON_AXIS_MM


def invariant_under_rotation(face, point: np.ndarray, axis: np.ndarray, o) -> bool:
    """Whether a rotation about the line (``point``, unit ``axis``) sweeps no volume with
    ``face``: a plane normal to the axis (whatever its outline: it slides in its own plane), or
    a surface of revolution about the axis bounded only by circles about it and seams (it maps
    onto itself)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_CurveType
    from OCP.GeomAbs import GeomAbs_SurfaceType as S
    surf = BRepAdaptor_Surface(face)
    kind = surf.GetType()
    if kind == S.GeomAbs_Plane:
        return abs(abs(float(np.array(_dir(surf.Plane().Axis().Direction())) @ axis)) - 1) <= PARALLEL_EPS
    elif kind == S.GeomAbs_Cylinder:
        ok = _coaxial(surf.Cylinder().Axis(), point, axis)
    elif kind == S.GeomAbs_Cone:
        ok = _coaxial(surf.Cone().Axis(), point, axis)
    elif kind == S.GeomAbs_Torus:
        ok = _coaxial(surf.Torus().Axis(), point, axis)
    elif kind == S.GeomAbs_Sphere:
        c = surf.Sphere().Location()
        q = np.array([c.X(), c.Y(), c.Z()]) - point
        ok = float(np.linalg.norm(q - (q @ axis) * axis)) <= ON_AXIS_MM
    else:
        ok = False
    if not ok:
        return False
    brep_tool = o["BRep"].BRep_Tool
    exp = o["TopExp"].TopExp_Explorer(face, o["TopAbs"].TopAbs_EDGE)
    while exp.More():
        edge = o["TopoDS"].TopoDS.Edge(exp.Current())
        exp.Next()
        if brep_tool.Degenerated_s(edge) or brep_tool.IsClosed_s(edge, face):
            continue  # a pole or a seam
        curve = BRepAdaptor_Curve(edge)
        if curve.GetType() != GeomAbs_CurveType.GeomAbs_Circle or not _circle_about(curve, point, axis):
            return False
    return True


def side_of_motion(face, u: np.ndarray, o) -> tuple[bool, bool]:
    """(may lead, may oppose): whether ``face``'s outward normal may have a positive, or a
    negative, component along the unit direction ``u``. A plane answers exactly; a cylinder
    (or a surface of linear extrusion) along ``u`` neither leads nor opposes; any other
    surface is assumed to do both (conservative)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_SurfaceType as S
    from OCP.TopAbs import TopAbs_REVERSED
    surf = BRepAdaptor_Surface(face)
    kind = surf.GetType()
    if kind == S.GeomAbs_Plane:
        n = np.array(_dir(surf.Plane().Axis().Direction()))
        if face.Orientation() == TopAbs_REVERSED:
            n = -n
        c = float(n @ u)
        return c > PARALLEL_EPS, c < -PARALLEL_EPS
    if kind == S.GeomAbs_Cylinder:
        along = abs(abs(float(np.array(_dir(surf.Cylinder().Axis().Direction())) @ u)) - 1.0)
        return (False, False) if along <= PARALLEL_EPS else (True, True)
    if kind == S.GeomAbs_SurfaceOfExtrusion:
        along = abs(abs(float(np.array(_dir(surf.Direction())) @ u)) - 1.0)
        return (False, False) if along <= PARALLEL_EPS else (True, True)
    return True, True


def faces_along(u: np.ndarray, sign: int):
    """A face filter for :func:`cover`: faces that may lead (``sign`` +1) or oppose (-1) a
    motion along ``u`` (:func:`side_of_motion`)."""
    u = np.asarray(u, float) / float(np.linalg.norm(u))

    def keep(face, o) -> bool:
        lead, oppose = side_of_motion(face, u, o)
        return lead if sign > 0 else oppose
    return keep


def _dir(d) -> tuple[float, float, float]:
    return (d.X(), d.Y(), d.Z())


def cell_side(tris: np.ndarray, cell: float = TOL.sweep_cell_mm, max_cells: int | None = None) -> float:
    """The cell side for triangles (n, 3, 3): ``cell``, or coarser so that the surface area
    needs at most about ``max_cells`` cells and no triangle edge needs more than
    :data:`MAX_SUBDIV` points at half a cell apart (so the spacing bound always holds)."""
    if not len(tris):
        return cell
    max_cells = TOL.sweep_max_cells if max_cells is None else max_cells
    area = 0.5 * float(np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]),
                                      axis=1).sum())
    edge = float(np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2).max())
    if not (np.isfinite(area) and np.isfinite(edge)):
        return cell
    return max(cell, math.sqrt(area / max_cells), 2.0 * edge / MAX_SUBDIV)


@dataclass(frozen=True)
class Face:
    """One meshed face of a part, as :func:`surface` reads it: the face, its triangles (n, 3, 3)
    world mm, how far its exact surface may lie from them (0 on a plane) and its axis when it
    is a cylinder (else zeros)."""

    face: object
    tris: np.ndarray
    dev: float
    axis: np.ndarray


def faces(shape) -> list[Face]:
    """Every face of the located ``shape``, meshed with the shipped tessellation's settings (a
    no-op where the shape is already meshed so), with its triangles: read once per part and
    filtered by :func:`surface` for each joint."""
    from ..kernel import _ocp, mesh_deflection
    o = _ocp()
    linear = mesh_deflection(shape)
    o["BRepMesh"].BRepMesh_IncrementalMesh(shape, linear, False, TOL.mesh_angular_rad, False)
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_SurfaceType
    out = []
    exp = o["TopExp"].TopExp_Explorer(shape, o["TopAbs"].TopAbs_FACE)
    while exp.More():
        face = o["TopoDS"].TopoDS.Face(exp.Current())
        exp.Next()
        surf = BRepAdaptor_Surface(face)
        kind = surf.GetType()
        ax = (np.array(_dir(surf.Cylinder().Axis().Direction()))
              if kind == GeomAbs_SurfaceType.GeomAbs_Cylinder else np.zeros(3))
        out.append(Face(face, _triangles(face, o),
                        0.0 if kind == GeomAbs_SurfaceType.GeomAbs_Plane else float(linear), ax))
    return out


def surface(shape, *, axis: tuple[np.ndarray, np.ndarray] | None = None,
            keep=None, meshed: list[Face] | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(triangles (n, 3, 3) of the located, meshed ``shape``'s covered faces, world mm; per
    triangle, how far its exact face may lie from it, mm: the tessellation's linear deflection,
    or 0 on a plane, which its triangles lie in exactly; per triangle, the axis of its face when
    it is a cylinder (its chords deviate only across that axis), else zeros; per triangle, the
    index of its face in ``faces(shape)``): the faces :func:`cover` would cover. ``meshed`` is
    ``faces(shape)`` when the caller has it."""
    from ..kernel import _ocp
    o = _ocp()
    tris, devs, axes, ids = [], [], [], []
    for k, f in enumerate(faces(shape) if meshed is None else meshed):
        if axis is not None and invariant_under_rotation(f.face, axis[0], axis[1], o):
            continue
        if keep is not None and not keep(f.face, o):
            continue
        tris.append(f.tris)
        devs.append(np.full(len(f.tris), f.dev))
        axes.append(np.broadcast_to(f.axis, (len(f.tris), 3)))
        ids.append(np.full(len(f.tris), k, dtype=np.int64))
    if not tris:
        return np.zeros((0, 3, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    return np.vstack(tris), np.concatenate(devs), np.vstack(axes), np.concatenate(ids)


def cover_of(tris: np.ndarray, linear: float, cell: float) -> Cover:
    """The sphere cover of triangles (n, 3, 3) meshed at deflection ``linear`` with cells of
    side ``cell`` (see the module doc)."""
    h = cell / 2.0
    keys = _cells(tris, h, cell)
    centres = (keys + 0.5) * cell
    return Cover(np.asarray(centres, float), float(cover_radius(cell, linear)))


def cover_radius(cell: float, linear: float) -> float:
    """The sphere radius of a cover with cells of side ``cell`` over a mesh of deflection
    ``linear``: half the cell's diagonal, the point spacing (half a cell) and the deflection."""
    return cell * math.sqrt(3.0) / 2.0 + cell / 2.0 + linear


def cover(shape, *, axis: tuple[np.ndarray, np.ndarray] | None = None,
          keep=None, cell: float = TOL.sweep_cell_mm, max_cells: int | None = None) -> Cover:
    """The sphere cover of the located, meshed ``shape``; with ``axis`` = (point, unit
    direction), the faces invariant under rotation about it are left out; with ``keep`` (a
    ``keep(face, ocp) -> bool`` filter such as :func:`faces_along`), only the faces it keeps
    are covered. ``cell`` is the finest cell side; :func:`cell_side` widens it to keep about
    ``max_cells`` (default ``TOL.sweep_max_cells``) cells."""
    tris, devs, _, _ = surface(shape, axis=axis, keep=keep)
    return cover_of(tris, float(devs.max(initial=0.0)), cell_side(tris, cell, max_cells))


__all__ = ["Cover", "Face", "cell_side", "cover", "cover_of", "cover_radius", "faces", "faces_along",
           "invariant_under_rotation", "nearest_to_origin", "side_of_motion", "surface"]


def radial_range(tris: np.ndarray, devs: np.ndarray, point: np.ndarray, axis: np.ndarray
                 ) -> tuple[float, float]:
    """(least, greatest) distance (mm) from the line through ``point`` along unit ``axis`` of
    the exact surface meshed as ``tris`` (n, 3, 3) with per-triangle deviations ``devs``; both
    conservative: the least is lowered and the greatest raised by each triangle's deviation.

    A bounded solid that the line passes through meets it on its boundary, so these bound the
    solid too. Every motion about or along the line (a turn about it, a slide along it, a screw
    motion of both) keeps each point's distance from it, so two parts whose ranges do not
    overlap (a screw inside a carriage's clearance bore) never meet under such a motion
    (:func:`radial_apart`). A triangle's distance is that of its projection across the line:
    0 when the projected triangle covers the line's point, else the nearest of its edges.
    """
    if len(tris) == 0:
        return math.inf, -math.inf
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    rel = np.asarray(tris, float) - np.asarray(point, float)
    e1, e2 = plane_basis(a)
    p = np.stack([rel @ e1, rel @ e2], axis=-1)  # (n, 3, 2): the triangles across the line
    far = float((np.linalg.norm(p, axis=-1).max(axis=1) + devs).max())
    near = nearest_to_origin(p) - devs
    return max(float(near.min()), 0.0), far


def nearest_to_origin(p: np.ndarray) -> np.ndarray:
    """Per plane triangle (n, 3, 2), its least distance from the origin: 0 when it covers the
    origin, else that of its nearest edge (a triangle across a line: its distance from it)."""
    q0, q1 = p, np.roll(p, -1, axis=1)
    d = q1 - q0
    dd = np.einsum("nij,nij->ni", d, d)
    t = np.clip(np.divide(-np.einsum("nij,nij->ni", q0, d), dd, out=np.zeros_like(dd),
                          where=dd > 0), 0.0, 1.0)
    edge = np.linalg.norm(q0 + t[..., None] * d, axis=-1).min(axis=1)
    # the origin inside the projected triangle: the three edge cross products share a sign
    cr = q0[..., 0] * d[..., 1] - q0[..., 1] * d[..., 0]  # cross(d, -q0) sign convention
    inside = np.all(cr >= 0, axis=1) | np.all(cr <= 0, axis=1)
    return np.where(inside, 0.0, edge)


def radial_apart(a: tuple[float, float], b: tuple[float, float], margin: float = 0.0) -> bool:
    """Whether two radial ranges (:func:`radial_range`) leave a gap wider than ``margin``: one
    part lies wholly inside a cylinder about the line that the other lies wholly outside."""
    return a[1] + margin < b[0] or b[1] + margin < a[0]
