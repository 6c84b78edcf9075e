"""Geometry metrics on the shipped mesh: pieces, components, N_vis, Shrp60, Dih95, triangles.

The shipped mesh is every part tessellated with the fixed settings ``TOL.mesh_linear_mm`` /
``TOL.mesh_angular_rad``, vertices welded within ``TOL.mesh_weld_mm`` and degenerate triangles
dropped (:func:`procedura_brep.kernel.tessellate`), in world millimetres, one mesh per part.

* ``Shrp60``: total length of the interior mesh edges whose dihedral (angle between the two
  adjacent face normals; 0 on a flat face, 90 on a box edge) exceeds ``TOL.sharp_dihedral_deg``.
  Reported unnormalised in mm (``shrp60_mm``) and normalised by the model span, the largest side
  of the model's axis-aligned bbox (``shrp60_per_span`` = shrp60_mm / span_mm, dimensionless).
* ``Dih95``: the 95th percentile (numpy linear interpolation) of the dihedral over all interior
  edges, unweighted, in degrees.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import TOL
from ..program.model import CompiledModel
from .connectivity import Connectivity, analyse
from .geometry import part_geometry


def sharp_length(angles: np.ndarray, lengths: np.ndarray, *, threshold: float = TOL.sharp_dihedral_deg) -> float:
    """Total length (mm) of edges with dihedral above ``threshold`` degrees."""
    return float(lengths[angles > threshold].sum())


def dihedral_percentile(angles: np.ndarray, q: float = 95.0) -> float:
    """The ``q``-th percentile of edge dihedrals, degrees (0 for an empty mesh)."""
    return float(np.percentile(angles, q)) if len(angles) else 0.0


def mesh_metrics(model: CompiledModel, *, conn: Connectivity | None = None) -> dict[str, Any]:
    """The metric dict of ``model`` (see module docstring and docs/gates.md for the fields)."""
    geos = [part_geometry(p) for p in model.parts]
    conn = conn if conn is not None else analyse(model)
    edges = [g.edge_angles() for g in geos]
    angles = np.concatenate([a for a, _ in edges]) if edges else np.zeros(0)
    lengths = np.concatenate([l for _, l in edges]) if edges else np.zeros(0)
    shrp = sharp_length(angles, lengths)
    return {
        "triangles": int(sum(g.triangles for g in geos)),
        "triangles_per_part": {g.name: g.triangles for g in geos},
        "mesh_pieces": int(sum(len(g.pieces) for g in geos)),
        "components": len(conn.components),
        "n_vis": conn.n_vis,
        "span_mm": round(conn.span, 6),
        "shrp60_mm": round(shrp, 6),
        "shrp60_per_span": round(shrp / conn.span, 6) if conn.span > 0 else 0.0,
        "dih95_deg": round(dihedral_percentile(angles), 6),
        "sharp_dihedral_deg": TOL.sharp_dihedral_deg,
        "tessellation": {"linear_mm": TOL.mesh_linear_mm, "angular_rad": TOL.mesh_angular_rad,
                         "weld_mm": TOL.mesh_weld_mm},
    }
