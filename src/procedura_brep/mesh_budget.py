"""How many triangles meshing a shape will make, estimated from its B-rep without meshing it.

Meshing is what explodes (a probe mesh, even 9x coarser, of ``Sphere(1e5)`` at 0.1 mm ran out of
5 GB), so the estimate reads only the geometry. For a deflection ``delta`` and an angular
deflection ``a``, an arc of curvature radius ``R`` is cut into segments spanning the angle
``theta(R) = min(a, 2 acos(1 - delta / R))`` (``a`` when ``delta >= R``), i.e. of length
``h(R) = R theta(R)``. A face is covered by ``n_u x n_v`` cells of two triangles, where ``n_u``
is its length along ``u`` divided by ``h`` of the curvature along ``u`` (1 for a straight
direction), and likewise for ``v``:

* plane: 1 x 1 (its boundary nodes are counted with the edges);
* cylinder and cone: around ``R dU / h(R)`` (the cone's largest radius), 1 along the axis;
* sphere: ``R dU / h(R)`` x ``R dV / h(R)``;
* torus: around the axis with the outer radius ``R + r``, around the tube with ``r``;
* anything else (B-spline, revolution, extrusion, offset): both directions sampled on a 5 x 5
  grid of the face's parameter box (lengths from the first derivatives, normal curvatures from
  the second), keeping the largest count of any parameter line.

Each edge adds two triangles per segment (one per face using it) (``length / h`` of its curvature: exact for lines and
circles, sampled otherwise). The estimate is meant to be within a small factor of OCCT's count
(tests compare it with real meshes; :data:`CALIBRATION` scales it to an upper estimate) and is
cheap: no triangulation is built.
"""

from __future__ import annotations

import math
from typing import Any  # OCCT objects: OCP ships no stubs or py.typed

#: Samples per parameter direction for faces and edges without a closed form.
SAMPLES = 5
#: A curvature below this (1/mm) is straight.
FLAT_CURVATURE = 1e-12
#: The cell count times this is the estimate: OCCT's mesher places more nodes than the
#: deflection alone requires. Measured raw ratios (cell estimate / OCCT's count at the size
#: rule): sphere 0.50-0.63, torus 0.39, cone 0.35, loft 0.33, filleted box 0.78, plate with 81
#: holes 0.74, helical sweep 0.73, cylinder 1.11; times 3 every one is >= 1 (0.99 for the loft).
CALIBRATION = 3.0


def segment_length(radius: float, linear: float, angular: float) -> float:
    """``h(R)``: length of one mesh segment on an arc of radius ``radius`` (mm)."""
    if radius <= 0 or not math.isfinite(radius):
        return math.inf
    theta = angular if linear >= radius else min(angular, 2.0 * math.acos(1.0 - linear / radius))
    return radius * max(theta, 1e-12)


def _segments(length: float, radius: float, linear: float, angular: float) -> float:
    h = segment_length(radius, linear, angular)
    return length / h if math.isfinite(h) else 0.0


def _sampled_face(surf: Any, u0: float, u1: float, v0: float, v1: float, linear: float,
                  angular: float) -> tuple[float, float]:
    from OCP.gp import gp_Pnt, gp_Vec

    us = [u0 + (u1 - u0) * (i + 0.5) / SAMPLES for i in range(SAMPLES)]
    vs = [v0 + (v1 - v0) * (j + 0.5) / SAMPLES for j in range(SAMPLES)]
    du, dv = (u1 - u0) / SAMPLES, (v1 - v0) / SAMPLES
    rows_u = [0.0] * SAMPLES  # segments along u on each v line
    rows_v = [0.0] * SAMPLES  # segments along v on each u line
    p, su, sv, suu, svv, suv = gp_Pnt(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec(), gp_Vec()
    for i, u in enumerate(us):
        for j, v in enumerate(vs):
            surf.D2(u, v, p, su, sv, suu, svv, suv)
            n = su.Crossed(sv)
            if n.Magnitude() <= 0:
                continue
            n.Normalize()
            lu, lv = su.Magnitude(), sv.Magnitude()
            ku = abs(suu.Dot(n)) / (lu * lu) if lu > 0 else 0.0
            kv = abs(svv.Dot(n)) / (lv * lv) if lv > 0 else 0.0
            if ku > FLAT_CURVATURE:
                rows_u[j] += _segments(lu * du, 1.0 / ku, linear, angular)
            if kv > FLAT_CURVATURE:
                rows_v[i] += _segments(lv * dv, 1.0 / kv, linear, angular)
    return max(rows_u), max(rows_v)


def face_cells(face: Any, linear: float, angular: float) -> float:
    """``n_u * n_v`` for one face (see the module docstring)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepTools import BRepTools
    from OCP.GeomAbs import GeomAbs_SurfaceType as T

    surf = BRepAdaptor_Surface(face)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    du, dv = abs(u1 - u0), abs(v1 - v0)
    kind = surf.GetType()
    if kind == T.GeomAbs_Plane:
        nu = nv = 0.0
    elif kind == T.GeomAbs_Cylinder:
        r = surf.Cylinder().Radius()
        nu, nv = _segments(r * du, r, linear, angular), 0.0
    elif kind == T.GeomAbs_Cone:
        cone = surf.Cone()
        s = math.sin(cone.SemiAngle())
        r = max(abs(cone.RefRadius() + v0 * s), abs(cone.RefRadius() + v1 * s))
        nu, nv = _segments(r * du, r, linear, angular), 0.0
    elif kind == T.GeomAbs_Sphere:
        r = surf.Sphere().Radius()
        nu, nv = _segments(r * du, r, linear, angular), _segments(r * dv, r, linear, angular)
    elif kind == T.GeomAbs_Torus:
        tor = surf.Torus()
        big, small = tor.MajorRadius() + tor.MinorRadius(), tor.MinorRadius()
        nu = _segments(big * du, big, linear, angular)
        nv = _segments(small * dv, small, linear, angular)
    else:
        nu, nv = _sampled_face(surf, u0, u1, v0, v1, linear, angular)
    return max(1.0, math.ceil(nu)) * max(1.0, math.ceil(nv))


def edge_segments(edge: Any, linear: float, angular: float) -> float:
    """Mesh segments along one edge."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GeomAbs import GeomAbs_CurveType as C
    from OCP.gp import gp_Pnt, gp_Vec

    curve = BRepAdaptor_Curve(edge)
    t0, t1 = curve.FirstParameter(), curve.LastParameter()
    kind = curve.GetType()
    if kind == C.GeomAbs_Line:
        return 1.0
    if kind == C.GeomAbs_Circle:
        r = curve.Circle().Radius()
        return max(1.0, _segments(r * abs(t1 - t0), r, linear, angular))
    total = 0.0
    p, d1, d2 = gp_Pnt(), gp_Vec(), gp_Vec()
    length = GCPnts_AbscissaPoint.Length_s(curve)
    for i in range(SAMPLES):
        curve.D2(t0 + (t1 - t0) * (i + 0.5) / SAMPLES, p, d1, d2)
        speed = d1.Magnitude()
        k = d1.Crossed(d2).Magnitude() / speed ** 3 if speed > 0 else 0.0
        if k > FLAT_CURVATURE:
            total += _segments(length / SAMPLES, 1.0 / k, linear, angular)
    return max(1.0, total)


def estimate_triangles(shape: Any, *, linear: float, angular: float) -> int:
    """Estimated triangle count of meshing ``shape`` at these deflections (no meshing)."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    face = TopoDS.Face_s if hasattr(TopoDS, "Face_s") else TopoDS.Face
    edge = TopoDS.Edge_s if hasattr(TopoDS, "Edge_s") else TopoDS.Edge
    cells = segs = 0.0
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        cells += face_cells(face(exp.Current()), linear, angular)
        exp.Next()
    exp = TopExp_Explorer(shape, TopAbs_EDGE)  # each edge once per face using it (~twice)
    while exp.More():
        segs += edge_segments(edge(exp.Current()), linear, angular)
        exp.Next()
    return int(math.ceil(CALIBRATION * (2.0 * cells + segs)))
