"""The OCCT boundary for the parent process: raw OCP, no build123d (imports in ~1 s).

Every OCCT exception is wrapped into :class:`KernelError` here. Shapes cross the process
boundary as OCCT binary BRep bytes; transforms as 4x4 numpy matrices in millimetres.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from functools import lru_cache
from types import ModuleType
from typing import Any, TypeAlias

import numpy as np

from .config import TOL
from .errors import KernelError

# A TopoDS_Shape (or a subclass): OCP ships no stubs or py.typed, so OCCT objects are Any here.
Shape: TypeAlias = Any


def _ocp() -> dict[str, ModuleType]:  # lazy: keeps `procedura-brep --help` instant
    from OCP import (
        BinTools,
        Bnd,
        BRep,
        BRepAlgoAPI,
        BRepBndLib,
        BRepCheck,
        BRepGProp,
        BRepMesh,
        GProp,
        TopAbs,
        TopExp,
        TopLoc,
        TopoDS,
        gp,
    )
    return {"BinTools": BinTools, "BRepBndLib": BRepBndLib, "BRepCheck": BRepCheck,
            "BRepGProp": BRepGProp, "BRepMesh": BRepMesh, "Bnd": Bnd, "GProp": GProp,
            "TopAbs": TopAbs, "TopExp": TopExp, "TopLoc": TopLoc, "TopoDS": TopoDS, "gp": gp,
            "BRep": BRep, "BRepAlgoAPI": BRepAlgoAPI}


def warm_up() -> None:
    """Import the OCP modules this process needs (overlaps with the worker's start-up)."""
    _ocp()
    from OCP import STEPCAFControl, XCAFDoc  # noqa: F401 - the STEP writer's modules


def read_brep(data: bytes) -> Shape:
    """A TopoDS_Shape from OCCT binary BRep bytes."""
    o = _ocp()
    shape = o["TopoDS"].TopoDS_Shape()
    try:
        o["BinTools"].BinTools.Read_s(shape, io.BytesIO(data))
    except Exception as exc:  # OCCT raises Standard_Failure subclasses
        raise KernelError(f"reading BRep failed: {exc}") from exc
    if shape.IsNull():
        raise KernelError("reading BRep gave an empty shape")
    return shape


def write_brep(shape: Shape) -> bytes:
    """OCCT binary BRep bytes of ``shape``."""
    o = _ocp()
    buf = io.BytesIO()
    o["BinTools"].BinTools.Write_s(shape, buf)
    return buf.getvalue()


def bake_location(shape: Shape) -> Shape:
    """``shape`` with its location applied to its geometry and an empty location.

    Part solids cross process boundaries and enter STEP as plain local geometry; a shape that
    still carries a location (e.g. ``Pos(...) * Box(...)``) would become an XCAF reference.
    """
    if shape.Location().IsIdentity():
        return shape
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    o = _ocp()
    bare = shape.Located(o["TopLoc"].TopLoc_Location())
    op = BRepBuilderAPI_Transform(bare, shape.Location().Transformation(), True)
    if not op.IsDone():
        raise KernelError("baking a shape's location into its geometry failed")
    return op.Shape()


def trsf(matrix: np.ndarray) -> Any:
    """gp_Trsf of a rigid 4x4 matrix (mm)."""
    o = _ocp()
    t = o["gp"].gp_Trsf()
    m = np.asarray(matrix, dtype=float)
    t.SetValues(*m[0, :4], *m[1, :4], *m[2, :4])
    return t


def located(shape: Shape, matrix: np.ndarray) -> Shape:
    """``shape`` moved by the rigid transform ``matrix`` (shares geometry, no copy)."""
    o = _ocp()
    return shape.Moved(o["TopLoc"].TopLoc_Location(trsf(matrix)))


def volume(shape: Shape) -> float:
    """Solid volume, mm^3 (sums every solid of a compound)."""
    o = _ocp()
    props = o["GProp"].GProp_GProps()
    o["BRepGProp"].BRepGProp.VolumeProperties_s(shape, props)
    return float(props.Mass())


def area(shape: Shape) -> float:
    """Surface area, mm^2."""
    o = _ocp()
    props = o["GProp"].GProp_GProps()
    o["BRepGProp"].BRepGProp.SurfaceProperties_s(shape, props)
    return float(props.Mass())


def bbox(shape: Shape, *, optimal: bool = True) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """((xmin, ymin, zmin), (xmax, ymax, zmax)) in mm; exact (optimal) by default."""
    o = _ocp()
    box = o["Bnd"].Bnd_Box()
    if optimal:
        o["BRepBndLib"].BRepBndLib.AddOptimal_s(shape, box, False, False)
    else:
        o["BRepBndLib"].BRepBndLib.Add_s(shape, box, True)
    lo, hi = box.CornerMin(), box.CornerMax()
    return (lo.X(), lo.Y(), lo.Z()), (hi.X(), hi.Y(), hi.Z())


def distance(a: Shape, b: Shape) -> float:
    """Exact least distance (mm) between two shapes (BRepExtrema: ~ms to ~70 ms a curved
    pair); inf when OCCT cannot tell."""
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    ext = BRepExtrema_DistShapeShape(a, b)
    return float(ext.Value()) if ext.IsDone() else float("inf")


def segment_distance(shape: Shape, p0: np.ndarray, p1: np.ndarray) -> float:
    """Exact least distance (mm) from the segment ``p0``-``p1`` to ``shape`` (:func:`distance`)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    gp = _ocp()["gp"]
    return distance(BRepBuilderAPI_MakeEdge(gp.gp_Pnt(*map(float, p0)), gp.gp_Pnt(*map(float, p1))).Edge(),
                    shape)


def solids(shape: Shape) -> list[Shape]:
    """The solids of ``shape`` (a compound, a solid ...), in explorer order; empty if none."""
    from OCP.TopAbs import TopAbs_SOLID
    return _explore(shape, TopAbs_SOLID)


def faces(shape: Shape) -> list[Shape]:
    """The faces of ``shape``, in explorer order, each cast to a ``TopoDS_Face``."""
    o = _ocp()
    return [_face(o["TopoDS"], f) for f in _explore(shape, o["TopAbs"].TopAbs_FACE)]


def share_triangulation(source: Shape, target: Shape) -> None:
    """Give ``target``'s faces the triangulations of ``source``'s, face by face in explorer
    order: two shapes read from the same BRep bytes (twins), ``source`` meshed. Whatever reads
    a face's triangulation then sees ``target`` as meshed too: a face's box
    (:func:`bbox` with ``optimal=False``) is the box of its nodes, not of its whole surface.

    Raises:
        KernelError: the two shapes do not have the same number of faces.
    """
    o = _ocp()
    src, dst = faces(source), faces(target)
    if len(src) != len(dst):
        raise KernelError(f"cannot share a triangulation between shapes of {len(src)} and "
                          f"{len(dst)} faces")
    builder = o["BRep"].BRep_Builder()
    for a, b in zip(src, dst):
        tri = o["BRep"].BRep_Tool.Triangulation_s(a, o["TopLoc"].TopLoc_Location())
        if tri is not None:
            builder.UpdateFace(b, tri)


def _explore(shape: Shape, kind: Any) -> list[Shape]:
    from OCP.TopExp import TopExp_Explorer
    out: list[Shape] = []
    exp = TopExp_Explorer(shape, kind)
    while exp.More():
        out.append(exp.Current())
        exp.Next()
    return out


def is_valid(shape: Shape) -> bool:
    """BRepCheck validity."""
    return bool(_ocp()["BRepCheck"].BRepCheck_Analyzer(shape).IsValid())


def common_volume(a: Shape, b: Shape) -> float:
    """Volume of ``a & b`` (interference), mm^3."""
    o = _ocp()
    op = o["BRepAlgoAPI"].BRepAlgoAPI_Common(a, b)
    if not op.IsDone():
        raise KernelError("boolean common failed")
    return volume(op.Shape())


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh in mm: ``vertices`` (N, 3) float64, ``faces`` (M, 3) int64."""

    vertices: np.ndarray
    faces: np.ndarray


class MeshTooLargeError(KernelError):
    """Meshing a shape would exceed ``TOL.mesh_max_triangles`` (raised before it is meshed)."""


def mesh_deflection(shape: Shape) -> float:
    """The linear deflection (mm) the size rule gives ``shape``:
    ``max(TOL.mesh_linear_mm, TOL.mesh_linear_rel * bbox diagonal)``."""
    o = _ocp()
    box = o["Bnd"].Bnd_Box()
    # from the geometry, never from an existing triangulation: the same shape always gets the
    # same deflection, meshed before or not
    o["BRepBndLib"].BRepBndLib.Add_s(shape, box, False)
    if box.IsVoid():
        return TOL.mesh_linear_mm
    lo, hi = box.CornerMin(), box.CornerMax()
    diag = float(np.linalg.norm([hi.X() - lo.X(), hi.Y() - lo.Y(), hi.Z() - lo.Z()]))
    if not np.isfinite(diag):
        diag = 0.0
    return max(TOL.mesh_linear_mm, TOL.mesh_linear_rel * diag)


def _face(TopoDS: Any, shape: Shape) -> Shape:
    """``shape`` downcast to a face (OCP spells the cast ``Face`` or ``Face_s``)."""
    return TopoDS.TopoDS.Face(shape) if hasattr(TopoDS.TopoDS, "Face") else TopoDS.TopoDS.Face_s(shape)


def _mesh(shape: Shape, linear: float, angular: float, parallel: bool) -> int:
    """Mesh ``shape`` afresh (old triangulations removed); the raw triangle count."""
    o = _ocp()
    from OCP.BRepTools import BRepTools
    BRepTools.Clean_s(shape)
    try:
        o["BRepMesh"].BRepMesh_IncrementalMesh(shape, linear, False, angular, parallel)
    except Exception as exc:  # OCCT raises Standard_Failure subclasses
        raise KernelError(f"meshing failed: {exc}") from exc
    count = 0
    TopAbs, TopExp, TopoDS = o["TopAbs"], o["TopExp"], o["TopoDS"]
    exp = TopExp.TopExp_Explorer(shape, TopAbs.TopAbs_FACE)
    while exp.More():
        tri = o["BRep"].BRep_Tool.Triangulation_s(_face(TopoDS, exp.Current()),
                                                   o["TopLoc"].TopLoc_Location())
        exp.Next()
        if tri is not None:
            count += tri.NbTriangles()
    return count


def estimate_triangles(shape: Shape, *, linear: float, angular: float = TOL.mesh_angular_rad) -> int:
    """An estimate of the triangles :func:`tessellate` makes at these settings, read from the
    B-rep without meshing (:mod:`procedura_brep.mesh_budget`)."""
    from .mesh_budget import estimate_triangles as estimate
    try:
        return estimate(shape, linear=linear, angular=angular)
    except Exception as exc:  # OCCT raises Standard_Failure subclasses
        raise KernelError(f"estimating the mesh size failed: {exc}") from exc


def tessellate(shape: Shape, *, linear: float | None = None, angular: float = TOL.mesh_angular_rad,
               parallel: bool = False, name: str = "shape",
               max_triangles: int | None = None) -> Mesh:
    """Mesh ``shape``; vertices are in the shape's located (world) frame.

    ``linear`` defaults to the size rule :func:`mesh_deflection` (0.1 mm up to parts 1 m
    across, 1e-4 of the bbox diagonal beyond). The triangle count is estimated first
    (:func:`estimate_triangles`) and a shape over ``max_triangles`` (default
    ``TOL.mesh_max_triangles``) is refused before the real mesh is built. Degenerate
    (zero-area) triangles are dropped and coincident vertices welded, so component counts are
    topological. ``parallel`` stays False in any process that may later fork.

    Raises:
        MeshTooLargeError: the estimated or actual count exceeds the cap; the message names
            ``name``, the figure, the cap and the deflection used.
    """
    o = _ocp()
    BRep, TopAbs, TopExp, TopoDS = o["BRep"], o["TopAbs"], o["TopExp"], o["TopoDS"]
    lin = mesh_deflection(shape) if linear is None else float(linear)
    cap = TOL.mesh_max_triangles if max_triangles is None else max_triangles

    def refuse(count: int, how: str) -> MeshTooLargeError:
        return MeshTooLargeError(
            f"part {name}: its mesh would have {count:,} triangles ({how}) at {lin:.3g} mm "
            f"deflection, over the cap of {cap:,} (TOL.mesh_max_triangles); simplify the part "
            f"(fewer or larger curved features)")

    estimate = estimate_triangles(shape, linear=lin, angular=angular)
    if estimate > cap:
        raise refuse(estimate, "estimated from its geometry")
    _mesh(shape, lin, angular, parallel)
    verts: list[np.ndarray] = []
    tris: list[np.ndarray] = []
    offset = 0
    exp = TopExp.TopExp_Explorer(shape, TopAbs.TopAbs_FACE)
    while exp.More():
        face = _face(TopoDS, exp.Current())
        loc = o["TopLoc"].TopLoc_Location()
        tri = BRep.BRep_Tool.Triangulation_s(face, loc)
        exp.Next()
        if tri is None:
            continue
        t = loc.Transformation()
        n = tri.NbNodes()
        pts = np.empty((n, 3))
        for i in range(1, n + 1):
            p = tri.Node(i).Transformed(t)
            pts[i - 1] = (p.X(), p.Y(), p.Z())
        idx = np.empty((tri.NbTriangles(), 3), dtype=np.int64)
        reverse = face.Orientation() == TopAbs.TopAbs_REVERSED
        for i in range(1, tri.NbTriangles() + 1):
            a, b, c = tri.Triangle(i).Get()
            idx[i - 1] = (a, c, b) if reverse else (a, b, c)
        verts.append(pts)
        tris.append(idx - 1 + offset)
        offset += n
    if not verts:
        return Mesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
    mesh = clean_mesh(np.vstack(verts), np.vstack(tris))
    if len(mesh.faces) > cap:  # counted after OCCT's zero-area triangles are dropped
        raise refuse(len(mesh.faces), "counted")
    return mesh


def placed_mesh(mesh: Mesh, placement: np.ndarray, *, scale: float = 1.0) -> Mesh:
    """``mesh`` moved by the 4x4 rigid ``placement``, then scaled (1e-3: mm to m)."""
    m = np.asarray(placement, dtype=float)
    v = mesh.vertices @ m[:3, :3].T + m[:3, 3]
    return Mesh(v * scale if scale != 1.0 else v, mesh.faces)


def clean_mesh(vertices: np.ndarray, faces: np.ndarray, *, weld: float = TOL.mesh_weld_mm,
               min_area: float = TOL.degenerate_area_mm2) -> Mesh:
    """Weld vertices closer than ``weld`` and drop triangles with area below ``min_area``."""
    key = np.round(vertices / weld).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    v = vertices[first]
    f = inverse.reshape(-1)[faces]
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    keep = (0.5 * np.linalg.norm(cross, axis=1) > min_area) & (f[:, 0] != f[:, 1]) & \
        (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return Mesh(v, f[keep])


@lru_cache(maxsize=1)
def version() -> str:
    """The OCCT version string."""
    from OCP import Standard
    return str(getattr(Standard, "Standard_Version", lambda: "unknown"))
