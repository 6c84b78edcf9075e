"""The run directory's JSON records of a model, next to its exporters: ``mates.json`` (the mate
graph with world frames) and the per-part rows of ``report.json``.

Pure functions of a :class:`~procedura_brep.program.model.CompiledModel`; reading volumes and
boxes goes through the kernel boundary but never tessellates, so the parent may call them
outside the limited child.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..program.model import CompiledModel


def frame_dict(m: np.ndarray) -> dict[str, Any]:
    """A 4x4 frame (mm) as origin, x and z axes and the full matrix."""
    return {"origin_mm": m[:3, 3].tolist(), "x_axis": m[:3, 0].tolist(), "z_axis": m[:3, 2].tolist(),
            "matrix": np.asarray(m).tolist()}


def mates_json(model: CompiledModel, evidence: dict[str, Any] | None = None) -> dict[str, Any]:
    """The mate graph: every mate with its world frame, nominal, fit, offset, DOF and limits."""
    mates = []
    for m in model.mates:
        mates.append({
            "name": m.name, "type": m.type, "kind": m.kind,
            "parent": {"part": m.parent, "frame": m.parent_frame},
            "child": {"part": m.child, "frame": m.child_frame},
            "world_frame": frame_dict(m.world_frame),
            "nominal": {"name": m.nominal_name, "value_mm": m.nominal},
            "fit": m.fit, "resolved_offset_mm": m.fit.get("offset"),
            "dof": m.dof, "limits": m.limits,
            "options": {k: v for k, v in m.options.items() if k != "limits"},
            "primary": m.primary, "residual": {"mm": m.residual_mm, "rad": m.residual_rad},
        })
    out: dict[str, Any] = {"program": model.name, "units": {"length": "mm", "angle": "deg"},
                           "root": model.parts[0].name if model.parts else None, "mates": mates}
    if model.couplings:  # couple(...): joints that move together (ratio in rad and mm)
        out["couplings"] = [c.as_dict() for c in model.couplings]
    blocks = {p.name: p.block_of for p in model.parts if p.block_of}
    if blocks:  # colour blocks: rigid with their painted part, joined by no mate
        out["blocks"] = blocks
    if evidence is not None:
        out["evidence"] = evidence
    return out


def part_rows(model: CompiledModel) -> list[dict[str, Any]]:
    """One row per part for ``report.json``: material, detail, volume, world box, the solved
    placement (``placement``: the 4x4 part-to-world matrix, mm, row-major list of lists), lines,
    compile time.

    Raises:
        KernelError: a part's BRep cannot be read.
    """
    from .. import kernel
    rows = []
    for p in model.parts:
        lo, hi = kernel.bbox(p.shape())
        rows.append({"name": p.name, "material": p.material, "detail": p.detail,
                     **({"block_of": p.block_of} if p.block_of else {}),
                     "volume_mm3": kernel.volume(p.local_shape()), "bbox_mm": [list(lo), list(hi)],
                     "placement": np.asarray(p.placement, dtype=float).tolist(),
                     "lines": list(p.lines), "compile_s": model.timings.get(f"part:{p.name}")})
    return rows


def mate_rows(model: CompiledModel) -> list[dict[str, Any]]:
    """One short row per mate for ``report.json`` (the full graph is ``mates.json``)."""
    return [{"name": m.name, "type": m.type, "child": m.child, "parent": m.parent,
             "primary": m.primary, "residual_mm": m.residual_mm, "residual_rad": m.residual_rad}
            for m in model.mates]


__all__ = ["frame_dict", "mate_rows", "mates_json", "part_rows"]
