"""Shared meshes for every exporter: exact visual tessellation and convex collision pieces.

Visual meshes come from :func:`procedura_brep.kernel.tessellate` (serial mesher, deflection
scaled with the part's size) and are cached by part digest, so every format in a bundle writes
the same triangles. Meshes handed to MuJoCo (URDF/MJCF STL files) go through :func:`sim_mesh`,
which keeps them under MuJoCo's STL limit (``TOL.sim_mesh_max_faces``) by re-tessellating a part
coarser when needed. Collision geometry is a set of convex pieces per part, from the MuJoCo mesh:
the convex hull of each connected component, or, when ``coacd`` is installed and a component is
clearly non-convex, a capped CoACD decomposition (see :data:`COACD_MAX_HULLS`).
"""

from __future__ import annotations

import logging

import numpy as np

from ..config import TOL
from ..errors import KernelError
from ..kernel import Mesh, placed_mesh
from ..program.model import CompiledPart

log = logging.getLogger(__name__)

#: At most this many convex pieces per component from CoACD (caps its cost).
COACD_MAX_HULLS = 8
#: CoACD concavity threshold (its ``threshold`` argument); larger is faster and coarser.
COACD_THRESHOLD = 0.08
#: Components with fewer triangles than this are skipped in collision (slivers).
MIN_COMPONENT_FACES = 4

#: At most this many coarsening steps (each ``TOL.sim_mesh_coarsen`` x the deflection) for MuJoCo.
SIM_MAX_COARSEN_STEPS = 12
#: Largest angular deflection a coarsened MuJoCo mesh uses, rad.
SIM_MAX_ANGULAR_RAD = 1.5

_COLLISION: dict[str, list[Mesh]] = {}
_SIM: dict[str, Mesh] = {}


def part_mesh(part: CompiledPart) -> Mesh:
    """The part's exact visual mesh in WORLD coordinates, mm (cached by digest)."""
    return part.mesh()


def sim_mesh(part: CompiledPart) -> Mesh:
    """The part's mesh for MuJoCo (world mm, cached by digest): the exact mesh when it has at
    most ``TOL.sim_mesh_max_faces`` triangles, else the part re-tessellated with its linear
    deflection multiplied by ``TOL.sim_mesh_coarsen`` (angular by its square root) until it
    fits.

    Raises:
        KernelError: the part still has too many triangles after
            :data:`SIM_MAX_COARSEN_STEPS` steps (many flat features: coarser meshing cannot
            help); the message names the part and the figure.
    """
    key = part.digest
    hit = _SIM.get(key)
    if hit is not None:
        return hit
    mesh = part_mesh(part)
    cap = TOL.sim_mesh_max_faces
    if len(mesh.faces) > cap:
        from .. import kernel
        exact = len(mesh.faces)
        shape = part.shape()
        linear, angular = kernel.mesh_deflection(shape), TOL.mesh_angular_rad
        for _ in range(SIM_MAX_COARSEN_STEPS):
            linear *= TOL.sim_mesh_coarsen
            angular = min(angular * TOL.sim_mesh_coarsen ** 0.5, SIM_MAX_ANGULAR_RAD)
            mesh = kernel.tessellate(shape, linear=linear, angular=angular, name=part.name)
            if len(mesh.faces) <= cap:
                break
        else:
            raise KernelError(
                f"part {part.name}: its MuJoCo mesh still has {len(mesh.faces):,} triangles at "
                f"{linear:.3g} mm deflection, over MuJoCo's limit of {cap:,} "
                f"(TOL.sim_mesh_max_faces); simplify the part")
        log.info("part %s: %d triangles for MuJoCo (exact mesh %d) at %.3g mm deflection",
                 part.name, len(mesh.faces), exact, linear)
    _SIM[key] = mesh
    return mesh


def transform(mesh: Mesh, matrix: np.ndarray, *, scale: float = 1.0) -> Mesh:
    """``mesh`` moved by the 4x4 ``matrix`` then scaled (e.g. 1e-3 for mm -> m)."""
    return placed_mesh(mesh, matrix, scale=scale)


def to_local_m(mesh: Mesh, frame: np.ndarray) -> Mesh:
    """A world-mm mesh expressed in ``frame`` (4x4 world, mm), in metres."""
    inv = np.linalg.inv(frame)
    return transform(mesh, inv, scale=1e-3)


def _components(mesh: Mesh) -> list[Mesh]:
    """The pieces of ``mesh`` with at least :data:`MIN_COMPONENT_FACES` triangles, or
    ``[mesh]`` when none has: triangles join where they share an edge that exactly two
    triangles use (a touch at a vertex, or along an edge of three or more, does not join).
    Pieces come in the order of their first triangle; each keeps its triangles' order and
    the vertices they use, in their order."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = mesh.faces
    m = len(f)
    if m == 0:
        return [mesh]
    order, starts, counts = _edge_groups(f)
    pair = starts[counts == 2]
    a, b = order[pair] // 3, order[pair + 1] // 3
    _, labels = connected_components(coo_matrix((np.ones(len(a)), (a, b)), shape=(m, m)),
                                     directed=False)
    # pieces ordered by their first triangle, whatever order the labels came in
    _, firsts, dense = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(len(firsts), dtype=np.int64)
    rank[np.argsort(firsts)] = np.arange(len(firsts))
    key = rank[dense.reshape(-1)]
    by_piece = np.argsort(key, kind="stable")
    bounds = np.searchsorted(key[by_piece], np.arange(len(firsts) + 1))
    out = []
    for i in range(len(firsts)):
        idx = by_piece[bounds[i]:bounds[i + 1]]
        if len(idx) < MIN_COMPONENT_FACES:
            continue
        used, local = np.unique(f[idx], return_inverse=True)
        out.append(Mesh(mesh.vertices[used], local.reshape(-1, 3).astype(np.int64)))
    return out or [mesh]


def _hull(mesh: Mesh) -> Mesh | None:
    """The convex hull of ``mesh``'s vertices as a closed triangle mesh, every triangle wound
    outward (by qhull's own facet normal), triangles of zero area left out; its vertices are
    the hull's, in their order in ``mesh``. ``None`` when qhull cannot make one, even joggled,
    or what it makes has no area (fewer than four points, or all of them on a line)."""
    from scipy.spatial import ConvexHull, QhullError
    points = np.asarray(mesh.vertices, dtype=np.float64)
    try:
        try:
            hull = ConvexHull(points, qhull_options="QbB Pp Qt")
        except QhullError:  # flat or nearly so: joggled, a hull of (nearly) zero thickness
            hull = ConvexHull(points, qhull_options="QJ")
    except (QhullError, ValueError) as exc:
        log.debug("convex hull failed: %s", exc)
        return None
    used = np.sort(hull.vertices)
    remap = np.zeros(len(points), dtype=np.int64)
    remap[used] = np.arange(len(used))
    faces = remap[hull.simplices]
    vertices = points[used]
    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]],
                     vertices[faces[:, 2]] - vertices[faces[:, 0]])
    keep = np.linalg.norm(cross, axis=1) > 0
    inward = np.einsum("ij,ij->i", cross, hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    if keep.sum() < 4:  # nothing closed is left (a line, joggled)
        return None
    return Mesh(vertices, faces[keep])


def _edge_groups(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles' edges (three per triangle; edge ``3 * t + k`` runs from its corner ``k``)
    grouped by their two vertices: ``(order, starts, counts)``, where ``order`` lists the
    edges sorted by vertex pair, and each group of equal edges starts at ``starts[g]`` in it
    and holds ``counts[g]`` of them."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    order = np.lexsort((edges[:, 1], edges[:, 0]))
    e = edges[order]
    starts = np.flatnonzero(np.r_[True, np.any(e[1:] != e[:-1], axis=1)])
    return order, starts, np.diff(np.r_[starts, len(e)])


def _closed(faces: np.ndarray) -> bool:
    """Whether every edge of the triangles is used by exactly two of them."""
    return len(faces) > 0 and bool((_edge_groups(faces)[2] == 2).all())


def _volume(mesh: Mesh) -> float:
    """The volume the triangles enclose (:func:`procedura_brep.gates.geometry.signed_volume`),
    unsigned."""
    from ..gates.geometry import signed_volume
    return abs(signed_volume(mesh.vertices, mesh.faces))


def _coacd(mesh: Mesh) -> list[Mesh] | None:
    try:
        import coacd  # optional dependency
    except ImportError:
        return None
    try:
        coacd.set_log_level("error")
        parts = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces),
                                threshold=COACD_THRESHOLD, max_convex_hull=COACD_MAX_HULLS)
    except Exception as exc:
        log.warning("coacd failed (%s); using the convex hull", exc)
        return None
    return [Mesh(np.asarray(v), np.asarray(f, dtype=np.int64)) for v, f in parts]


def collision_pieces(part: CompiledPart) -> list[Mesh]:
    """Convex pieces (world, mm) that approximate the part for collision (cached by digest)."""
    key = part.digest
    if key in _COLLISION:
        return _COLLISION[key]
    pieces: list[Mesh] = []
    for comp in _components(sim_mesh(part)):
        hull = _hull(comp)
        if hull is None:
            continue
        vol = _volume(comp) if _closed(comp.faces) else 0.0
        hvol = _volume(hull)
        if vol > 0 and hvol > TOL.nonconvex_ratio * vol:
            dec = _coacd(comp)
            if dec:
                pieces.extend(dec)
                continue
        pieces.append(hull)
    _COLLISION[key] = pieces
    return pieces


def smooth_normals(mesh: Mesh, *, crease_deg: float = TOL.normal_crease_deg) -> tuple[Mesh, np.ndarray]:
    """``(mesh with split vertices, unit vertex normals)`` for smooth shading with crisp edges.

    Each triangle corner starts as its own vertex; two corners at the same vertex are merged
    when their triangles share an edge through it whose dihedral (angle between the face
    normals) is below ``crease_deg`` (so a curved surface shades smooth and a box edge, a
    chamfer or a non-manifold edge splits). A merged vertex's normal is the area-weighted sum
    of its triangles' normals, made unit. Positions and triangles are unchanged; vertex order
    is deterministic (first corner order).
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    v, f = mesh.vertices, mesh.faces
    m = len(f)
    if m == 0:
        return mesh, np.zeros((len(v), 3))
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    norm = np.linalg.norm(cross, axis=1)
    unit = cross / np.where(norm > 0, norm, 1.0)[:, None]
    # half-edge h = 3*i + k runs from corner h (vertex f[i, k]) to corner nxt[h]
    start = f.reshape(-1)
    nxt = (np.arange(m)[:, None] * 3 + np.array([1, 2, 0])).reshape(-1)
    end = start[nxt]
    order, starts, counts = _edge_groups(f)  # the half-edges h, grouped by their two vertices
    pos = starts[counts == 2]  # manifold edges: exactly two half-edges
    h1, h2 = order[pos], order[pos + 1]
    smooth = np.einsum("ij,ij->i", unit[h1 // 3], unit[h2 // 3]) > np.cos(np.radians(crease_deg))
    h1, h2 = h1[smooth], h2[smooth]
    same_dir = start[h1] == start[h2]  # flipped neighbour: twin runs the same way
    a1, b1 = h1, nxt[h1]
    a2 = np.where(same_dir, h2, nxt[h2])
    b2 = np.where(same_dir, nxt[h2], h2)
    rows = np.r_[a1, b1]
    cols = np.r_[a2, b2]
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * m, 3 * m))
    n, labels = connected_components(graph, directed=False)
    # Max's weights (J. Graphics Tools 4(2), 1999): each corner adds its face's cross product
    # divided by the squared lengths of its two edges, exact for vertices on a sphere
    corners = np.arange(3 * m)
    prev = (np.arange(m)[:, None] * 3 + np.array([2, 0, 1])).reshape(-1)
    e1 = v[end] - v[start]
    e2 = v[start[prev]] - v[start]
    w = 1.0 / np.maximum(np.einsum("ij,ij->i", e1, e1) * np.einsum("ij,ij->i", e2, e2),
                         np.finfo(float).tiny)
    normals = np.zeros((n, 3))
    np.add.at(normals, labels, cross[corners // 3] * w[:, None])
    length = np.linalg.norm(normals, axis=1)
    corner_of = np.zeros(n, dtype=np.int64)
    corner_of[labels[::-1]] = corners[::-1]  # first corner of each new vertex
    fallback = unit[corner_of // 3]
    normals = np.where(length[:, None] > 0, normals / np.where(length > 0, length, 1.0)[:, None],
                       fallback)
    return Mesh(v[start[corner_of]], labels.reshape(m, 3).astype(np.int64)), normals


#: A binary STL triangle: unit normal, three corners (little-endian float32), attribute word.
STL_TRIANGLE = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])


def stl_bytes(mesh: Mesh) -> bytes:
    """Binary STL of ``mesh`` (units as given): an 80-byte header of zeros, the triangle
    count, then each triangle with its unit normal (zero for a triangle of no area)."""
    v, f = np.asarray(mesh.vertices, dtype=np.float64), mesh.faces
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(cross, axis=1)
    packed = np.zeros(len(f), dtype=STL_TRIANGLE)
    packed["normal"] = cross / np.where(norm > 0, norm, 1.0)[:, None]
    packed["corners"] = tri
    return bytes(80) + np.uint32(len(f)).astype("<u4").tobytes() + packed.tobytes()


def clear_cache() -> None:
    """Forget every cached mesh (tests)."""
    from ..program.model import clear_mesh_cache
    clear_mesh_cache()
    _COLLISION.clear()
    _SIM.clear()
