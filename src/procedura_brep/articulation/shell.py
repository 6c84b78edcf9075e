"""Mass integrals of a part weighed as a shell (``@part(hollow=wall)``): exact where OCCT can.

The exact shell is the solid minus its inward offset by the wall
(``BRepOffsetAPI_MakeOffsetShape``, join by arcs): its volume, centre and inertia are the
solid's volume integrals minus the offset's. OCCT's offset can fail, return a wrong or invalid
shape, run long, or crash the process (it segfaults on some grousered wheels), so it runs in a
forked child (:func:`procedura_brep.limited.run_limited`) under a wall-clock limit
(:data:`EXACT_WALL_S`), and its result is kept only when it is valid and plausible (the inner
volume strictly inside the solid's, the shell within :data:`PLAUSIBLE_RATIO` of the
thin-shell estimate). Otherwise the thin-shell approximation is used: the mass sits on the
surface, volume = area x wall, centre and inertia from ``BRepGProp.SurfaceProperties`` times
the wall. The method and, for the approximation, why the exact path was not taken are
recorded.

A wall that is not less than the part's mean half-thickness (volume / area, exact for a
plate) leaves no hollow: the part is weighed solid, and the note says so.

All integrals here are per unit density, in the part's LOCAL coordinates and millimetres
(mm^3, mm, mm^5); :mod:`.mass` scales them by the density and places them in the world.
Results are cached by (the part's BRep sha256, the wall), and the cache is inherited by
processes forked afterwards (the overlapped export), so every file of one build carries the
same numbers.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

Method = Literal["solid", "declared", "shell-exact", "shell-approx"]

#: Wall-clock seconds the exact offset of one part may take (in its forked child).
EXACT_WALL_S = 20.0
#: Wall-clock seconds the exact offsets of one process may take together (a build's limited
#: child computes them all once); past it every further hollow part is approximated, so a
#: model of many slow parts stays bounded.
EXACT_BUDGET_S = 60.0
#: Seconds this process has spent on exact offsets.
_SPENT = [0.0]
#: The exact shell volume must lie within (lo, hi) x the thin-shell estimate (area x wall);
#: outside, OCCT's offset is taken as wrong (a box of side s and wall t gives
#: 1 - 2t/s + 4t^2/(3 s^2), 0.90 at t = s/20; a wall near the half-thickness gives ~0.5).
PLAUSIBLE_RATIO = (0.5, 1.5)
#: Tolerance (mm) of the offset construction.
OFFSET_TOL_MM = 1e-4

_CACHE: dict[tuple[str, float], Integrals] = {}
_CACHE_SIZE = 512


@dataclass(frozen=True)
class Integrals:
    """Mass integrals per unit density, local coordinates, mm.

    Attributes:
        volume: mm^3 of material.
        com: (3,) centre, mm.
        inertia: (3, 3) about ``com``, mm^5 (times a density in kg/mm^3: kg mm^2).
        method: ``solid`` | ``shell-exact`` | ``shell-approx``.
        note: why the method is not the one asked for ("" when it is).
    """

    volume: float
    com: np.ndarray
    inertia: np.ndarray
    method: Method
    note: str = ""

    def as_json(self) -> dict[str, Any]:
        return {"volume": self.volume, "com": self.com.tolist(), "inertia": self.inertia.tolist(),
                "method": self.method, "note": self.note}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> Integrals:
        return cls(float(d["volume"]), np.array(d["com"], dtype=float),
                   np.array(d["inertia"], dtype=float), d["method"], str(d.get("note", "")))


def volume_integrals(shape: Any) -> Integrals:
    """The solid's volume integrals (OCCT's exact ``VolumeProperties``)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return _integrals(props, "solid")


def surface_integrals(shape: Any) -> Integrals:
    """The surface's area integrals (mm^2, mm, mm^4): a shell of unit wall."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(shape, props)
    return _integrals(props, "shell-approx")


def _integrals(props: Any, method: Method) -> Integrals:
    c, m = props.CentreOfMass(), props.MatrixOfInertia()
    inertia = np.array([[m.Value(i, j) for j in (1, 2, 3)] for i in (1, 2, 3)])
    sign = -1.0 if props.Mass() < 0 else 1.0  # a reversed solid integrates negative
    return Integrals(abs(float(props.Mass())), np.array([c.X(), c.Y(), c.Z()]), sign * inertia, method)


def subtract(outer: Integrals, inner: Integrals, method: Method) -> Integrals:
    """``outer`` minus ``inner`` (a body with a cavity): volumes, first and second moments."""
    vol = outer.volume - inner.volume
    com = (outer.volume * outer.com - inner.volume * inner.com) / vol

    def about(i: Integrals, p: np.ndarray) -> np.ndarray:  # parallel axes: to the point p
        d = i.com - p
        moved: np.ndarray = i.inertia + i.volume * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
        return moved

    return Integrals(vol, com, about(outer, com) - about(inner, com), method)


def thin_shell(shape: Any, wall: float, note: str) -> Integrals:
    """The thin-shell approximation: the surface times the wall."""
    s = surface_integrals(shape)
    return Integrals(s.volume * wall, s.com, s.inertia * wall, "shell-approx", note)


def exact_shell(shape: Any, wall: float) -> Integrals | str:
    """The exact shell (solid minus its inward offset), or why it could not be had. Runs OCCT's
    offset in THIS process: call it only in a child that may crash (see :func:`shell`)."""
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.BRepOffset import BRepOffset_Mode
    from OCP.BRepOffsetAPI import BRepOffsetAPI_MakeOffsetShape
    from OCP.GeomAbs import GeomAbs_JoinType
    outer = volume_integrals(shape)
    estimate = surface_integrals(shape).volume * wall
    try:
        off = BRepOffsetAPI_MakeOffsetShape()
        off.PerformByJoin(shape, -wall, OFFSET_TOL_MM, BRepOffset_Mode.BRepOffset_Skin, False,
                          False, GeomAbs_JoinType.GeomAbs_Arc)
        if not off.IsDone():
            return "OCCT's inward offset did not finish"
        inner_shape = off.Shape()
        if inner_shape.IsNull() or not BRepCheck_Analyzer(inner_shape).IsValid():
            return "OCCT's inward offset is not a valid shape"
        inner = volume_integrals(inner_shape)
    except Exception as exc:  # noqa: BLE001 - OCCT's Standard_Failure and its kin: a note
        return f"OCCT's inward offset failed: {type(exc).__name__}"
    if not 0.0 < inner.volume < outer.volume:
        return f"OCCT's inward offset has volume {inner.volume:.6g} mm^3 outside (0, {outer.volume:.6g})"
    shell_vol = outer.volume - inner.volume
    lo, hi = PLAUSIBLE_RATIO
    if not lo * estimate < shell_vol < hi * estimate:
        return (f"OCCT's shell volume {shell_vol:.6g} mm^3 is not within {lo:g}-{hi:g} x the "
                f"thin-shell estimate {estimate:.6g} mm^3")
    return subtract(outer, inner, "shell-exact")


def shell(brep: bytes, wall: float, shape: Any = None) -> Integrals:
    """The part's integrals as a shell of ``wall`` mm (cached by BRep and wall).

    Args:
        brep: the part's local BRep bytes (the cache key; sent to the child).
        wall: the wall thickness, mm.
        shape: the same shape, already read (default: read from ``brep`` when not cached).
    """
    key = (hashlib.sha256(brep).hexdigest(), float(wall))
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    if shape is None:
        from .. import kernel
        shape = kernel.read_brep(brep)
    solid = volume_integrals(shape)
    area = surface_integrals(shape).volume
    half = solid.volume / area if area > 0 else 0.0
    if wall >= half:
        out = Integrals(solid.volume, solid.com, solid.inertia, "solid",
                        f"hollow={wall:g} mm is not less than the part's mean half-thickness "
                        f"(volume / area = {half:.3g} mm): weighed solid")
    else:
        left = EXACT_BUDGET_S - _SPENT[0]
        t = time.monotonic()
        got = (_exact_in_child(brep, wall, min(EXACT_WALL_S, left)) if left > 0 else
               f"this process spent its {EXACT_BUDGET_S:g} s for exact shells (EXACT_BUDGET_S)")
        _SPENT[0] += time.monotonic() - t
        out = got if isinstance(got, Integrals) else thin_shell(shape, wall, got)
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = out
    return out


def _exact_in_child(brep: bytes, wall: float, wall_s: float) -> Integrals | str:
    """:func:`exact_shell` in a forked child given ``wall_s`` seconds (a crash, a hang or
    running out of memory there is a note, not a dead process)."""
    import dataclasses

    from ..config import PARENT
    from ..limited import ChildFailure, run_limited

    def work(send: Any) -> dict[str, Any]:
        from .. import kernel
        got = exact_shell(kernel.read_brep(brep), wall)
        return {"error": got} if isinstance(got, str) else {"ok": got.as_json()}

    limits = dataclasses.replace(PARENT, wall_s=wall_s)
    try:
        out = run_limited(work, stage="mass", limits=limits)
    except ChildFailure as exc:
        why = {"timeout": f"OCCT's inward offset took over {wall_s:g} s",
               "killed": "OCCT's inward offset crashed", "crash": "OCCT's inward offset crashed",
               "memory": "OCCT's inward offset ran out of memory"}.get(exc.kind, f"the exact shell failed: {exc}")
        return why
    if "ok" in out:
        return Integrals.from_json(out["ok"])
    return str(out.get("error", "the exact shell failed"))
