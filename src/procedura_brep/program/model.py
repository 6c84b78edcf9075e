"""The compiled assembly as plain data: what the sandbox returns and every later layer reads.

No kernel objects live here, only BRep bytes and 4x4 matrices (mm), so a model is JSON-safe
(see :func:`to_json`, and :func:`procedura_brep.program.trust.model_from_json`, which
validates it back) and independent of the process that compiled it.
Shapes are materialised lazily through :mod:`procedura_brep.kernel`. :class:`Finding` lives in
:mod:`procedura_brep.findings` (base layer) and is re-exported here.
"""

from __future__ import annotations

import base64
import hashlib
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..findings import Finding as Finding  # re-exported: the model's findings
from ..findings import cap_text as cap_text  # re-exported
from ..findings import failed
from ..materials import MATERIALS, Material, default_library, get, library_to_json
from ..mates.kinds import Motion
from ..mates.vocabulary import TYPES

if TYPE_CHECKING:
    from ..kernel import Mesh, Shape

_MESHES: dict[str, Any] = {}
_MESH_CACHE_SIZE = 512
#: Part-local meshes by the sha256 of the BRep bytes: parts of the same local geometry (twins,
#: :func:`procedura_brep.program.runtime._twins`: six identical wheels) are tessellated once,
#: each world mesh is the local one moved by its placement.
_LOCAL_MESHES: dict[str, Any] = {}
#: Local shapes read back from BRep bytes, by part name and the bytes' sha256: a part that
#: comes back unchanged from the next compile (a cache hit) is not read again. Two parts of
#: one model never share a shape (the STEP writer would make identical parts one shape).
#: Shapes are only read from (meshing cleans and rebuilds the triangulation every time).
_SHAPES: dict[str, Any] = {}
#: Exact extents of part-local shapes along local unit directions, by the BRep bytes' sha256
#: and the direction (:meth:`CompiledPart.extent`), and their exact boxes (``box`` for the
#: direction): an optimal box costs milliseconds a part (the battery asks for about a hundred
#: on the rover), and twins placed alike share theirs.
_EXTENTS: dict[str, Any] = {}


def clear_mesh_cache() -> None:
    """Forget every cached part mesh, shape and exact extent (tests, memory)."""
    _MESHES.clear()
    _LOCAL_MESHES.clear()
    _SHAPES.clear()
    _EXTENTS.clear()


def _keep(cache: dict[str, Any], key: str, value: Any) -> Any:
    """Store ``value`` under ``key`` in one of this module's caches, the oldest entry dropped
    when it holds :data:`_MESH_CACHE_SIZE`; returns ``value``."""
    if key not in cache and len(cache) >= _MESH_CACHE_SIZE:
        cache.pop(next(iter(cache)))
    cache[key] = value
    return value


def adopt_mesh(digest: str, mesh: Any) -> None:
    """Cache ``mesh`` as the mesh of the part geometry ``digest``: one tessellated by another
    process of ours from the same geometry (:mod:`procedura_brep.run.overlap`)."""
    _keep(_MESHES, digest, mesh)


@dataclass
class CompiledPart:
    """One part: its local solid (features applied) and where it sits in the world."""

    name: str
    brep: bytes
    placement: np.ndarray
    frames: dict[str, np.ndarray] = field(default_factory=dict)
    material: str = "steel"
    detail: str = "major"
    description: str = ""
    lines: tuple[int, int] = (0, 0)
    reads: tuple[str, ...] = ()
    cache_key: str = ""
    pieces: int = 1
    #: Declared mass in kg (``@part(mass=...)``): the part's density is scaled so it weighs
    #: this (centre of mass and inertia shape from the solid); None: volume x density.
    mass: float | None = None
    #: Wall thickness in mm (``@part(hollow=...)``): the part weighs as a shell of this wall;
    #: its geometry stays the solid. None: a solid part.
    hollow: float | None = None
    #: The part this colour block is painted on (``@paint``); "" for a part.
    block_of: str = ""
    #: A painted part's solid before its blocks were cut (what the part cache stores); b"" when
    #: the part is not painted.
    unpainted: bytes = field(default=b"", repr=False)
    #: The compile loaded this part's solid from the part cache (its ``brep`` is the stored one).
    from_cache: bool = field(default=False, compare=False)
    _shape: Any = field(default=None, repr=False, compare=False)
    #: (the ``brep`` object hashed, its sha256): kept with the object so a new ``brep`` is
    #: hashed again
    _brep_sha: Any = field(default=None, repr=False, compare=False)

    def _brep_hash(self) -> Any:
        memo = self._brep_sha
        if memo is None or memo[0] is not self.brep:
            memo = self._brep_sha = (self.brep, hashlib.sha256(self.brep))
        return memo[1].copy()

    @property
    def local_digest(self) -> str:
        """sha256 of the local BRep: the same for parts of the same local geometry (twins)."""
        hexdigest: str = self._brep_hash().hexdigest()
        return hexdigest

    @property
    def digest(self) -> str:
        """sha256 of the local BRep plus placement: changes exactly when the geometry does."""
        h = self._brep_hash()
        h.update(np.round(self.placement, 9).tobytes())
        hexdigest: str = h.hexdigest()
        return hexdigest

    def local_shape(self) -> Shape:
        """The part's TopoDS_Shape in part-local coordinates (cached, also across models)."""
        if self._shape is None:
            key = f"{self.name}:{self.local_digest}"
            shape = _SHAPES.get(key)
            if shape is None:
                from .. import kernel
                shape = _keep(_SHAPES, key, kernel.read_brep(self.brep))
            self._shape = shape
        return self._shape

    def shape(self) -> Shape:
        """The part's TopoDS_Shape placed in the world."""
        from .. import kernel
        return kernel.located(self.local_shape(), self.placement)

    def mesh(self) -> Mesh:
        """The part's world mesh (mm) with the tessellation settings of ``config.TOL`` (linear
        deflection scaled with the part's size, see :func:`procedura_brep.kernel.tessellate`).

        Shared by gates, exports and renders through a digest-keyed cache; the local mesh it
        moves is shared by the parts of the same local geometry (:meth:`local_mesh`), so each
        geometry is tessellated once per process.
        """
        key = self.digest
        hit: Mesh | None = _MESHES.get(key)
        if hit is None:
            from .. import kernel
            hit = _keep(_MESHES, key, kernel.placed_mesh(self.local_mesh(), self.placement))
        return hit

    def local_mesh(self) -> Mesh:
        """The part's mesh in its own frame (mm), cached by its BRep bytes: a twin's is the
        same mesh. Tessellated from the local shape, as OCCT meshes a located shape (on its
        faces' own geometry), so a placement changes no triangle. A twin's own shape is given
        the triangulation too (:func:`procedura_brep.kernel.share_triangulation`): it reads
        as meshed, as every part's shape did when each was meshed on its own."""
        from .. import kernel
        key = self.local_digest
        shape = self.local_shape()
        hit = _LOCAL_MESHES.get(key)
        if hit is None:
            hit = _keep(_LOCAL_MESHES, key, (kernel.tessellate(shape, name=self.name), shape))
        elif hit[1] is not shape:
            kernel.share_triangulation(hit[1], shape)
        mesh: Mesh = hit[0]
        return mesh

    def local_box(self) -> tuple[np.ndarray, np.ndarray]:
        """The exact (optimal) box of the part's local shape, ``(lo, hi)`` in mm, cached by
        its local geometry (twins share it)."""
        key = f"{self.local_digest}:box"
        hit = _EXTENTS.get(key)
        if hit is None:
            from .. import kernel
            lo, hi = kernel.bbox(self.local_shape(), optimal=True)
            hit = _keep(_EXTENTS, key, (np.array(lo), np.array(hi)))
        return hit[0].copy(), hit[1].copy()

    def extent(self, direction: np.ndarray) -> tuple[float, float]:
        """Exact (least, greatest) of the placed part along the world unit ``direction``, mm:
        the local shape's extent along that direction turned into the part's frame (its
        optimal box in a frame whose Z is that direction), plus the placement's offset along
        it. Cached by the local geometry and the local direction: twins turned alike (six
        wheels) pay for one exact box."""
        d = np.asarray(direction, float)
        rot, offset = self.placement[:3, :3], float(self.placement[:3, 3] @ d)
        local = rot.T @ d
        key = f"{self.local_digest}:{np.round(local, 12).tobytes().hex()}"
        hit = _EXTENTS.get(key)
        if hit is None:
            from .. import kernel
            from ..mates.motion import plane_basis
            frame = np.eye(4)
            frame[:3, :3] = np.vstack([plane_basis(local), local])  # rows: local -> Z along it
            lo, hi = kernel.bbox(kernel.located(self.local_shape(), frame), optimal=True)
            hit = _keep(_EXTENTS, key, (lo[2], hi[2]))
        return hit[0] + offset, hit[1] + offset

    def world_frame(self, frame: str) -> np.ndarray:
        world: np.ndarray = self.placement @ self.frames[frame]
        return world

    @property
    def owner(self) -> str:
        """The part whose body this is: the painted part for a colour block, else the part."""
        return self.block_of or self.name


@dataclass
class CompiledMate:
    """One mate as compiled: type, partners, resolved nominal and fit, world frame, residual."""

    name: str
    type: str
    kind: str
    child: str
    child_frame: str
    parent: str
    parent_frame: str
    nominal_name: str
    nominal: float
    fit: dict[str, Any]
    options: dict[str, Any]
    dof: dict[str, Any]
    world_frame: np.ndarray
    primary: bool = True
    residual_mm: float = 0.0
    residual_rad: float = 0.0
    line: int | None = None

    @property
    def limits(self) -> Any:
        if self.type in TYPES and TYPES[self.type].motion is Motion.BALL:
            return {"cone_deg": self.options.get("cone")}
        return self.options.get("limits")


@dataclass(frozen=True)
class CompiledCoupling:
    """One ``couple(...)`` as compiled: two kinematic mates that move together.

    Attributes:
        name: ``f"{driven}__{driver}"``.
        type: ``gear`` | ``rack_pinion`` | ``screw`` | ``belt`` | ``linkage``.
        driven, driver: the mate names (the driven joint follows the driver).
        ratio: d(driven)/d(driver) with angles in rad and lengths in mm (rad/rad, mm/rad or
            rad/mm), signed: the sign comes from the mesh (an external gear pair reverses the
            sense) and from the two joints' world axes. 0 for a linkage (no constant ratio).
        offset: the driven position when the driver is at 0, on the same scale; joint
            positions count from the compiled pose, where every coupled pair meshes, so 0.
        inputs: keyword -> the param name it reads (``{"driver_teeth": "z_pinion"}``), or the
            literal option (``hand``, ``internal``, ``rack``, ``closes``) as text.
        values: keyword -> the param's value at compile.
        closes: a linkage's cut mate ("" otherwise).
        line: the program line of the statement.
        mesh: the two parts whose surfaces engage (gear and gear, rack and pinion, screw and
            nut; ``("", "")`` for a belt): the coupling gate checks them, and the battery's
            exact sweep leaves the pair to it (one part swept past a still partner would
            collide tooth on tooth).
    """

    name: str
    type: str
    driven: str
    driver: str
    ratio: float
    offset: float = 0.0
    inputs: dict[str, str] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)
    closes: str = ""
    line: int | None = None
    mesh: tuple[str, str] = ("", "")

    def as_dict(self) -> dict[str, Any]:
        """JSON-safe (``mates.json``, the compile result)."""
        return {"name": self.name, "type": self.type, "driven": self.driven, "driver": self.driver,
                "ratio": self.ratio, "offset": self.offset, "inputs": dict(self.inputs),
                "values": dict(self.values), "closes": self.closes, "line": self.line,
                "mesh": list(self.mesh)}


@dataclass
class CompiledModel:
    """The whole assembly in plan order (the first part is the root).

    ``materials`` is the library the program was compiled with: the built-in table followed by
    the program's own ``material(...)`` declarations. Exports, renders and masses read a part's
    material from it (:meth:`material_of`), never from the global table.
    """

    name: str
    params: dict[str, Any]
    parts: list[CompiledPart]
    mates: list[CompiledMate]
    findings: list[Finding] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    materials: dict[str, Material] = field(default_factory=default_library)
    #: The OS isolation layers the compile child ran under, set by the parent from the child's
    #: log (``applied: netns no_new_privs landlock seccomp; not applied: -``); "" when unknown.
    isolation: str = ""
    #: The ``couple(...)`` statements, checked and resolved (ratio and sign), in program order.
    couplings: list[CompiledCoupling] = field(default_factory=list)
    _index: dict[str, int] | None = field(default=None, init=False, repr=False, compare=False)

    def material_of(self, part: CompiledPart) -> Material:
        """The library entry of ``part``'s material (a MaterialError lists the library)."""
        return get(part.material, self.materials)

    @property
    def declared_materials(self) -> dict[str, Material]:
        """The program's own materials (the library minus the built-ins)."""
        return {k: m for k, m in self.materials.items() if k not in MATERIALS}

    def part(self, name: str) -> CompiledPart:
        """The part named ``name`` (by a name index, remade when ``parts`` changed: a hit is
        checked against the list)."""
        index = self._index
        i = index.get(name) if index is not None else None
        if i is None or i >= len(self.parts) or self.parts[i].name != name:
            index = self._index = {}
            for k, p in enumerate(self.parts):
                index.setdefault(p.name, k)
            i = index.get(name)
        if i is not None:
            return self.parts[i]
        raise KeyError(f"no part named {name!r}; parts: {', '.join(p.name for p in self.parts)}")

    @property
    def ok(self) -> bool:
        return not failed(self.findings)


def _m(a: np.ndarray) -> list[list[float]]:
    rows: list[list[float]] = np.asarray(a, dtype=float).tolist()
    return rows


def to_json(model: CompiledModel, *, by_key: bool = False) -> dict[str, Any]:
    """A JSON-safe dict (BRep as base64) that :func:`.trust.model_from_json` reads back exactly.

    With ``by_key``, a part loaded from the part cache (``from_cache``, not painted) carries
    ``"cached": true`` and no BRep: the reader takes the solid from the cache it shares with
    the writer (the compile child's result: the parent already holds every stored solid).
    """
    def brep(p: CompiledPart) -> dict[str, Any]:
        if by_key and p.from_cache and not p.unpainted and p.cache_key:
            return {"cached": True}
        return {"brep": base64.b64encode(p.brep).decode("ascii")}

    return {
        "name": model.name, "params": model.params, "timings": model.timings,
        "findings": [f.as_dict() for f in model.findings],
        "parts": [{"name": p.name, **brep(p),
                   "placement": _m(p.placement), "frames": {k: _m(v) for k, v in p.frames.items()},
                   "material": p.material, "detail": p.detail, "description": p.description,
                   "lines": list(p.lines), "reads": list(p.reads), "cache_key": p.cache_key,
                   "pieces": p.pieces,
                   **({"mass": p.mass} if p.mass is not None else {}),
                   **({"hollow": p.hollow} if p.hollow is not None else {}),
                   **({"block_of": p.block_of} if p.block_of else {}),
                   **({"unpainted": base64.b64encode(p.unpainted).decode("ascii")}
                      if p.unpainted else {})}
                  for p in model.parts],
        "mates": [{**{k: v for k, v in m.__dict__.items() if k != "world_frame"},
                   "world_frame": _m(m.world_frame)} for m in model.mates],
        "materials": library_to_json(model.declared_materials),
        "couplings": [c.as_dict() for c in model.couplings],
    }

