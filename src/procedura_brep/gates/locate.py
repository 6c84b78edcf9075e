"""Where a finding happens, in words the model and a person can act on.

A gate that finds an overlap knows a world point inside it. :func:`describe` turns that point
into the part's own coordinates (the ones its function is written in) and names the part's
nearest face by kind and size ("cylindrical face r 10 mm, axis +Z"), so a message can say which
feature to move without the reader reconstructing the placement.

Only :mod:`procedura_brep.kernel` (raw OCP) is used, lazily; only for findings (a few calls).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..program.model import CompiledPart


def local_point(part: CompiledPart, point: np.ndarray) -> np.ndarray:
    """``point`` (world mm) in ``part``'s own coordinates."""
    inv = np.linalg.inv(np.asarray(part.placement, float))
    return inv[:3, :3] @ np.asarray(point, float) + inv[:3, 3]


def direction_name(v: np.ndarray) -> str:
    """``"+Z"`` for a unit vector along a world axis (to 1e-3), else ``"(0.707, 0.707, 0)"``."""
    v = np.round(np.asarray(v, float), 3) + 0.0
    names = {(0, 0, 1): "+Z", (0, 0, -1): "-Z", (0, 1, 0): "+Y", (0, -1, 0): "-Y",
             (1, 0, 0): "+X", (-1, 0, 0): "-X"}
    return names.get(tuple(int(x) for x in v) if np.allclose(v, np.round(v)) else (), "") or \
        "(" + ", ".join(f"{x:.3g}" for x in v) + ")"


def nearest_face(shape: Any, point: np.ndarray) -> str:
    """The kind and size of ``shape``'s face nearest ``point`` (both in one frame), e.g.
    ``"planar face, normal +Z"`` or ``"cylindrical face r 10 mm, axis +Z"``; "" if none."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape, BRepExtrema_IsInFace
    from OCP.GeomAbs import GeomAbs_SurfaceType as S
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopoDS import TopoDS

    vertex = BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, point))).Vertex()
    ext = BRepExtrema_DistShapeShape(vertex, shape)
    if not ext.IsDone() or ext.NbSolution() < 1:
        return ""
    faces = [TopoDS.Face(ext.SupportOnShape2(i)) for i in range(1, ext.NbSolution() + 1)
             if ext.SupportTypeShape2(i) == BRepExtrema_IsInFace]
    if not faces:  # nearest to an edge or a vertex: the faces that meet there
        faces = _faces_at(shape, vertex, float(ext.Value()))
    for face in faces:
        surf = BRepAdaptor_Surface(face)
        kind = surf.GetType()

        def d(ax) -> np.ndarray:
            x = ax.Direction()
            return np.array([x.X(), x.Y(), x.Z()])
        if kind == S.GeomAbs_Plane:
            n = d(surf.Plane().Axis()) * (-1 if face.Orientation() == TopAbs_REVERSED else 1)
            return f"planar face, normal {direction_name(n)}"
        if kind == S.GeomAbs_Cylinder:
            c = surf.Cylinder()
            return f"cylindrical face r {c.Radius():.4g} mm, axis {direction_name(d(c.Axis()))}"
        if kind == S.GeomAbs_Cone:
            return f"conical face, axis {direction_name(d(surf.Cone().Axis()))}"
        if kind == S.GeomAbs_Sphere:
            return f"spherical face r {surf.Sphere().Radius():.4g} mm"
        if kind == S.GeomAbs_Torus:
            return f"toroidal face, axis {direction_name(d(surf.Torus().Axis()))}"
        return "freeform face"
    return ""


def _faces_at(shape: Any, vertex: Any, dist: float) -> list[Any]:
    """The faces of ``shape`` within ``dist`` (plus a micrometre) of ``vertex``."""
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from .. import kernel

    p = np.array(kernel.bbox(vertex, optimal=False)[0])
    out = []
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More() and len(out) < 2:
        face = TopoDS.Face(exp.Current())
        exp.Next()
        lo, hi = (np.array(c) for c in kernel.bbox(face, optimal=False))
        if np.any(p < lo - dist - 1e-3) or np.any(p > hi + dist + 1e-3):
            continue
        ext = BRepExtrema_DistShapeShape(vertex, face)
        if ext.IsDone() and ext.Value() <= dist + 1e-3:
            out.append(face)
    return out


def describe(part: CompiledPart, point: np.ndarray) -> str:
    """``"<part> (own coordinates x, y, z mm, near its <face>)"`` for a world ``point``."""
    p = local_point(part, point)
    face = ""
    try:
        face = nearest_face(part.local_shape(), p)
    except Exception:  # noqa: BLE001  a kernel failure only loses the face's name
        face = ""
    xyz = ", ".join(f"{x:.1f}" for x in p)
    return f"{part.name} at ({xyz}) in its own coordinates" + (f", near its {face}" if face else "")
