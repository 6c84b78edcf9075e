"""Hand-built compiled models for the gate tests (no sandbox needed)."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep import kernel
from procedura_brep.mates.fits import iso286
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledMate, CompiledModel, CompiledPart


def cpart(name: str, shape, placement=None, **frames) -> CompiledPart:
    """A CompiledPart from a build123d shape (local coords) and a world placement."""
    return CompiledPart(name=name, brep=kernel.write_brep(shape.wrapped),
                        placement=np.eye(4) if placement is None else np.asarray(placement, float),
                        frames={k: np.asarray(v, float) for k, v in frames.items()} or {"origin": np.eye(4)},
                        material="steel")


def peg_model(d: float = 10.0, fit: str = "clearance", *, lift: float = 0.0,
              interference_scale: float | None = None, depth: float | None = None) -> CompiledModel:
    """A post with a peg seated in a socket in a base block; the mate plane is world z = 0.

    ``lift`` moves the post along the mate axis (+ hovers, - gouges); ``interference_scale``
    makes the peg ``scale`` times the fit's per-side interference oversize.
    """
    from build123d import Align, Box, Cylinder, Pos

    f = iso286(d, fit)
    depth = depth or d
    relief = max(0.2, 0.05 * d)
    shaft = f.shaft
    if interference_scale is not None:
        shaft = f.hole + 2.0 * interference_scale * f.interference
    w = 3 * d
    base = Box(2 * w, 2 * w, depth + 10, align=(Align.CENTER, Align.CENTER, Align.MAX))
    base = base - Cylinder(f.hole / 2, depth + relief, align=(Align.CENTER, Align.CENTER, Align.MAX))
    post = Box(w, w, 2 * d, align=(Align.CENTER, Align.CENTER, Align.MIN))
    post = post + Cylinder(shaft / 2, depth, align=(Align.CENTER, Align.CENTER, Align.MAX))
    parts = [cpart("base", base, top=np.eye(4)), cpart("post", post, trans(0, 0, lift), foot=np.eye(4))]
    mate = CompiledMate(name="post_on_base", type="press_fit" if fit == "press" else "peg_socket",
                        kind="static", child="post", child_frame="foot", parent="base",
                        parent_frame="top", nominal_name="peg_d", nominal=d, fit=f.as_dict(),
                        options={}, dof={}, world_frame=np.eye(4), line=12)
    return CompiledModel(name="peg", params={"peg_d": d}, parts=parts, mates=[mate])


@pytest.fixture
def make_peg():
    return peg_model
