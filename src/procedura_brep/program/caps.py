"""Size caps on what a program may return (runs inside the sandbox child, before the result
leaves it).

A hostile or careless program can return geometry that is valid but far too big to mesh, gate
or export (``Sphere(1e5)``, ``Cylinder(1e6, 1)``, a compound of 10 000 boxes). The child checks
every part right after its function returns, before the expensive validity checks, and the
whole placed model before it is serialised; a part over a cap is a finding naming the part, the
figure and the cap (``config.SANDBOX``), never a result the parent has to survive.

Counts (solids, faces) are exact and cheap (topology exploration). The extent is the part's
axis-aligned box (not the optimal one). Triangles are *estimated* per face at the fixed meshing
tolerance: a plane costs about two triangles per boundary edge; a curved face costs ``2 A / s^2``
with ``s`` the chord that meets both the linear and the angular deflection for the face's
radius of curvature (a cylinder or cone, curved one way only, ``2 * angle * R / s``), times
:data:`CURVED_FACTOR`, measured against BRepMesh at the same settings (sphere R = 3000 mm: 94 k
estimated before the factor, 301 k meshed; cylinder, cone, torus and filleted box: ratios of
0.8 to 4.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL, SandboxLimits

#: BRepMesh makes about this many times the ideal chord-grid count on curved faces.
CURVED_FACTOR = 3.0


@dataclass(frozen=True)
class Figures:
    """What one part's shape costs."""

    solids: int
    faces: int
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    triangles: int

    @property
    def extent(self) -> float:
        return max(h - l for l, h in zip(self.lo, self.hi)) if self.faces else 0.0


def figures_json(fig: Figures) -> dict[str, Any]:
    """``fig`` as a JSON-safe dict (:func:`figures_from_json` reads it back)."""
    return {"solids": fig.solids, "faces": fig.faces, "lo": list(fig.lo), "hi": list(fig.hi),
            "triangles": fig.triangles}


def figures_from_json(d: Any) -> Figures | None:
    """:func:`figures_json`'s dict read back, or None when ``d`` is not one."""
    ok = (isinstance(d, dict) and all(isinstance(d.get(k), int) for k in ("solids", "faces", "triangles"))
          and all(isinstance(d.get(k), list) and len(d[k]) == 3
                  and all(isinstance(x, (int, float)) for x in d[k]) for k in ("lo", "hi")))
    if not ok:
        return None
    return Figures(d["solids"], d["faces"], tuple(float(x) for x in d["lo"]),  # type: ignore[arg-type]  # 3 numbers: checked above
                   tuple(float(x) for x in d["hi"]), d["triangles"])  # type: ignore[arg-type]  # 3 numbers: checked above


def _count(shape: Any, kind: Any) -> int:
    from OCP.TopExp import TopExp_Explorer
    n = 0
    exp = TopExp_Explorer(shape, kind)
    while exp.More():
        n += 1
        exp.Next()
    return n


def _chord(radius: float) -> float:
    """The mesh chord on a surface of curvature ``radius`` at the fixed tessellation settings."""
    r = max(radius, 1e-9)
    return max(min(math.sqrt(8.0 * r * TOL.mesh_linear_mm),
                   2.0 * r * math.sin(TOL.mesh_angular_rad / 2.0)), 1e-9)


def _face_triangles(face: Any) -> float:
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepTools import BRepTools
    from OCP.GeomAbs import GeomAbs_SurfaceType as S
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS
    f = TopoDS.Face(face) if hasattr(TopoDS, "Face") else TopoDS.Face_s(face)
    surf = BRepAdaptor_Surface(f, False)
    kind = surf.GetType()
    if kind == S.GeomAbs_Plane:
        return 2.0 * _count(f, TopAbs_EDGE) + 2.0
    umin, umax, vmin, vmax = BRepTools.UVBounds_s(f)
    if kind == S.GeomAbs_Cylinder:
        r = surf.Cylinder().Radius()
        return float(CURVED_FACTOR * 2.0 * abs(umax - umin) * r / _chord(r) + 2.0)
    if kind == S.GeomAbs_Cone:
        cone = surf.Cone()
        v = max(abs(vmin), abs(vmax))
        r = abs(cone.RefRadius()) + v * abs(math.sin(cone.SemiAngle()))
        return float(CURVED_FACTOR * 2.0 * abs(umax - umin) * r / _chord(r) + 2.0)
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(f, props)
    area = abs(props.Mass())
    if kind == S.GeomAbs_Sphere:
        r = surf.Sphere().Radius()
    elif kind == S.GeomAbs_Torus:
        r = surf.Torus().MinorRadius()
    else:  # free-form: the face's own size stands in for its curvature radius
        (x0, y0, z0), (x1, y1, z1) = _bbox(f)
        r = max(min(x1 - x0, y1 - y0, z1 - z0), max(x1 - x0, y1 - y0, z1 - z0) / 4.0, 1e-6)
    return float(CURVED_FACTOR * 2.0 * area / _chord(r) ** 2 + 2.0)


def _bbox(shape: Any) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    if box.IsVoid():
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    lo, hi = box.CornerMin(), box.CornerMax()
    return (lo.X(), lo.Y(), lo.Z()), (hi.X(), hi.Y(), hi.Z())


def measure(shape: Any, limits: SandboxLimits) -> Figures:
    """Count and estimate ``shape`` (a TopoDS_Shape), stopping early once a cap is exceeded."""
    from OCP.TopAbs import TopAbs_FACE, TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    solids = _count(shape, TopAbs_SOLID)
    lo, hi = _bbox(shape)
    faces = 0
    tri = 0.0
    if solids <= limits.max_part_solids and max(h - l for l, h in zip(lo, hi)) <= limits.max_extent_mm:
        exp = TopExp_Explorer(shape, TopAbs_FACE)
        while exp.More() and faces <= limits.max_part_faces and tri <= limits.max_part_triangles:
            faces += 1
            tri += _face_triangles(exp.Current())
            exp.Next()
    else:
        faces = _count(shape, TopAbs_FACE)
        tri = float("nan")
    return Figures(solids, faces, lo, hi, int(tri) if math.isfinite(tri) else -1)


def part_violation(name: str, fig: Figures, limits: SandboxLimits) -> str | None:
    """The one-line reason ``name`` is over a cap, or None."""
    size = " x ".join(f"{h - l:.4g}" for l, h in zip(fig.lo, fig.hi))
    if fig.solids > limits.max_part_solids:
        return (f"part {name}: {fig.solids} solids exceed the cap of {limits.max_part_solids} "
                f"solids per part (SANDBOX.max_part_solids); fuse them or split the part")
    if fig.extent > limits.max_extent_mm:
        return (f"part {name}: its bounding box {size} mm exceeds the extent cap of "
                f"{limits.max_extent_mm:g} mm (SANDBOX.max_extent_mm); model in millimetres at real size")
    if fig.faces > limits.max_part_faces:
        return (f"part {name}: more than {limits.max_part_faces} faces, the cap per part "
                f"(SANDBOX.max_part_faces); simplify the part")
    if fig.triangles > limits.max_part_triangles:
        return (f"part {name}: an estimated {fig.triangles} mesh triangles or more at the "
                f"{TOL.mesh_linear_mm:g} mm meshing tolerance exceed the cap of "
                f"{limits.max_part_triangles} per part (SANDBOX.max_part_triangles); simplify the part")
    return None


def model_violation(figures: dict[str, Figures], placements: dict[str, np.ndarray],
                    limits: SandboxLimits) -> str | None:
    """The one-line reason the placed model as a whole is over a cap, or None."""
    if len(figures) > limits.max_parts:
        return f"the model has {len(figures)} parts; the cap is {limits.max_parts} (SANDBOX.max_parts)"
    solids = sum(f.solids for f in figures.values())
    if solids > limits.max_model_solids:
        return f"the model has {solids} solids; the cap is {limits.max_model_solids} (SANDBOX.max_model_solids)"
    faces = sum(f.faces for f in figures.values())
    if faces > limits.max_model_faces:
        return f"the model has {faces} faces; the cap is {limits.max_model_faces} (SANDBOX.max_model_faces)"
    tri = sum(max(f.triangles, 0) for f in figures.values())
    if tri > limits.max_model_triangles:
        return (f"the model needs an estimated {tri} mesh triangles; the cap is "
                f"{limits.max_model_triangles} (SANDBOX.max_model_triangles)")
    corners = []
    for name, fig in figures.items():
        if name not in placements or not fig.faces:
            continue
        box = np.array([[x, y, z, 1.0] for x in (fig.lo[0], fig.hi[0]) for y in (fig.lo[1], fig.hi[1])
                        for z in (fig.lo[2], fig.hi[2])])
        corners.append((placements[name] @ box.T).T[:, :3])
    if corners:
        pts = np.vstack(corners)
        ext = pts.max(axis=0) - pts.min(axis=0)
        if float(ext.max()) > limits.max_extent_mm:
            size = " x ".join(f"{e:.4g}" for e in ext)
            return (f"the placed model spans {size} mm, over the extent cap of "
                    f"{limits.max_extent_mm:g} mm (SANDBOX.max_extent_mm)")
    return None
