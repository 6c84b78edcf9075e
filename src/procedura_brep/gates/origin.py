"""The origin gate: a part is modelled around its own origin, not at its assembly position.

A program never places a part: it draws each part in the part's own coordinates, publishes its
frames there, and the mates place it (``T_child = T_parent * F_parent * Delta * F_child^-1``).
A part drawn where it sits in the assembly, with its mounting frame out there at its body,
compiles and gates alike (the solved placement is the identity: the frames already agree), but
the model placed the part, not the solver, and a param change propagates only where the model
happened to chain its expressions.

The rule, per part, in the part's own coordinates (its local solid, mate features included;
read from the world mesh the other gates share, moved back by the inverse placement):

* ``s`` = the largest side of the part's bounding box, ``limit = max(TOL.origin_offset_factor
  * s, TOL.origin_offset_min_mm)``;
* ``d`` = the distance from the origin to that box (0 when the origin lies in or on it);
* a non-root part is drawn at its assembly position when ``d > limit`` **and** its mounting
  frame (the child frame of the mate that places it, :attr:`CompiledMate.primary`) lies at the
  body: within ``limit`` of the box. A part whose body merely extends from its origin (a long
  arm with its pivot frame at one end) has ``d = 0`` and never trips; a part whose mounting
  frame is at its origin and whose body is away from it is not this mistake (the connectivity
  gate judges whether it floats);
* the root (placed at the identity by definition, no mounting frame) is judged on its body
  only: ``d > limit``.

Colour blocks (``@paint``) ride with their part and are not judged. The finding is a warning
(``part-origin``): the program is valid, only badly structured; the staged agent blocks an
attempt on it (:data:`procedura_brep.agent.tools.AGENT_BLOCKING`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledMate, CompiledModel, CompiledPart, Finding
from .policy import GateResult, result

#: The finding's code.
CODE: str = "part-origin"
#: What the finding tells the model to do.
FIX: str = "model the part around its own origin with its mounting frame there, and let the mate place it"


@dataclass(frozen=True)
class OriginMeasure:
    """Where one part's body and mounting frame lie in the part's own coordinates (mm).

    Attributes:
        part: the part's name.
        lo: the local bounding box's low corner.
        hi: the local bounding box's high corner.
        distance_mm: distance from the part's origin to the box (0 inside or on it).
        limit_mm: the most ``distance_mm`` may be.
        frame: the mounting frame's name (``""`` for the root).
        frame_origin: the mounting frame's origin (None for the root).
        frame_distance_mm: distance from the mounting frame's origin to the box (None for the
            root).
    """

    part: str
    lo: np.ndarray
    hi: np.ndarray
    distance_mm: float
    limit_mm: float
    frame: str = ""
    frame_origin: np.ndarray | None = None
    frame_distance_mm: float | None = None

    @property
    def size_mm(self) -> float:
        """The part's own size: the largest side of its local box."""
        return float(np.max(self.hi - self.lo))

    @property
    def centre(self) -> np.ndarray:
        """The centre of the local box."""
        return (self.lo + self.hi) / 2.0

    @property
    def drawn_away(self) -> bool:
        """The rule: the body lies beyond the limit from the origin and (a non-root part) the
        mounting frame lies at the body."""
        if self.distance_mm <= self.limit_mm:
            return False
        return self.frame_distance_mm is None or self.frame_distance_mm <= self.limit_mm

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "distance_mm": round(self.distance_mm, 4), "limit_mm": round(self.limit_mm, 4),
            "size_mm": round(self.size_mm, 4), "centre_mm": _r(self.centre),
            "bbox_local": [_r(self.lo), _r(self.hi)]}
        if self.frame_origin is not None and self.frame_distance_mm is not None:
            out.update({"frame": self.frame, "frame_origin_mm": _r(self.frame_origin),
                        "frame_distance_mm": round(self.frame_distance_mm, 4)})
        return out


def _r(v: np.ndarray) -> list[float]:
    return [round(float(x), 4) + 0.0 for x in v]


def box_distance(point: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Distance from ``point`` to the axis-aligned box ``lo..hi`` (0 inside or on it)."""
    gap = np.maximum(np.maximum(lo - point, point - hi), 0.0)
    return float(np.linalg.norm(gap))


def local_box(part: CompiledPart) -> tuple[np.ndarray, np.ndarray] | None:
    """The part's bounding box in its own coordinates, from its shared world mesh (None for an
    empty mesh)."""
    v = np.asarray(part.mesh().vertices, float)
    if not len(v):
        return None
    m = np.asarray(part.placement, float)
    local = (v - m[:3, 3]) @ m[:3, :3]  # R^T (v - t) for each row: placements are rigid
    return local.min(axis=0), local.max(axis=0)


def mounting_mates(model: CompiledModel) -> dict[str, CompiledMate]:
    """Each placed child's mounting mate: the primary mate that names it as the child."""
    out: dict[str, CompiledMate] = {}
    for m in model.mates:
        if m.primary and m.child not in out:
            out[m.child] = m
    return out


def measure(part: CompiledPart, mount: CompiledMate | None) -> OriginMeasure | None:
    """The part's :class:`OriginMeasure` (``mount``: its mounting mate; None for the root);
    None when the part has no geometry."""
    box = local_box(part)
    if box is None:
        return None
    lo, hi = box
    size = float(np.max(hi - lo))
    limit = max(TOL.origin_offset_factor * size, TOL.origin_offset_min_mm)
    dist = box_distance(np.zeros(3), lo, hi)
    if mount is None or mount.child_frame not in part.frames:
        return OriginMeasure(part.name, lo, hi, dist, limit)
    origin = np.asarray(part.frames[mount.child_frame], float)[:3, 3]
    return OriginMeasure(part.name, lo, hi, dist, limit, mount.child_frame, origin,
                         box_distance(origin, lo, hi))


def _vec(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{round(float(x), 1) + 0.0:.1f}" for x in v) + ")"


def message(m: OriginMeasure, *, root: bool) -> str:
    """The finding's text: the part, the offset (mm, vector) and the fix."""
    head = (f"{m.part} is drawn {m.distance_mm:.1f} mm away from its own origin (more than its "
            f"own size, {m.size_mm:.1f} mm): its body's box is centred at {_vec(m.centre)} mm in "
            f"its own coordinates")
    if root:
        return (f"{head}; the root is placed at the origin, so the whole assembly is drawn off "
                f"it: {FIX} (move the body by {_vec(-m.centre)} mm)")
    if m.frame_origin is None:
        return f"{head}: {FIX} (move the body by {_vec(-m.centre)} mm)"
    return (f"{head}, and its mounting frame {m.part}.{m.frame} is out there at the body, at "
            f"{_vec(m.frame_origin)} mm: the part is drawn at its assembly position, so the "
            f"solver only agrees with where it was drawn. {FIX[0].upper() + FIX[1:]} (move the "
            f"body and every frame of {m.part} by {_vec(-m.frame_origin)} mm)")


def origin_gate(model: CompiledModel) -> tuple[list[Finding], GateResult]:
    """One ``part-origin`` warning per part drawn at its assembly position (module docstring);
    ``measured`` maps each such part to :meth:`OriginMeasure.as_dict` and gives the rule's
    ``factor`` and ``min_mm``."""
    findings: list[Finding] = []
    flagged: dict[str, Any] = {}
    mounts = mounting_mates(model)
    root = next((p.name for p in model.parts if not p.block_of), None)
    for part in model.parts:
        if part.block_of:
            continue
        is_root = part.name == root
        mount = None if is_root else mounts.get(part.name)
        if mount is None and not is_root:
            continue  # unplaced (a compile error says so)
        m = measure(part, mount)
        if m is None or not m.drawn_away:
            continue
        flagged[part.name] = m.as_dict()
        findings.append(Finding(CODE, message(m, root=is_root), part=part.name,
                                mate=None if mount is None else mount.name,
                                line=part.lines[0] or None, value=round(m.distance_mm, 4),
                                limit=round(m.limit_mm, 4), severity="warning"))
    return findings, result("origin", findings, {"parts": flagged,
                                                 "factor": TOL.origin_offset_factor,
                                                 "min_mm": TOL.origin_offset_min_mm})


__all__ = ["CODE", "FIX", "OriginMeasure", "box_distance", "local_box", "measure", "message",
           "mounting_mates", "origin_gate"]
