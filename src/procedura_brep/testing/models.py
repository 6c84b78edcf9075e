"""Compiled-model helpers for tests and benchmarks.

* :func:`cpart` and :func:`peg_model` build :class:`~procedura_brep.program.model.CompiledModel`
  parts by hand, without the sandbox (gate tests measure them directly);
* :func:`compiled` compiles a program in a sandbox worker and fails with the findings when it
  does not compile cleanly;
* :func:`rebuilt` names the parts a compile ran (not loaded from the part cache).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from procedura_brep.program.model import CompiledModel, CompiledPart
    from procedura_brep.program.sandbox import Worker


def cpart(name: str, shape: Any, placement: Any = None, **frames: Any) -> CompiledPart:
    """A CompiledPart from a build123d shape (local coords) and a world placement."""
    from procedura_brep import kernel
    from procedura_brep.program.model import CompiledPart
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
    from build123d import Align, Box, Cylinder

    from procedura_brep.mates.fits import iso286
    from procedura_brep.mates.placement import trans
    from procedura_brep.program.model import CompiledMate, CompiledModel

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


def compiled(source: str, *, worker: Worker | None = None, name: str = "model",
             cache: bool = True) -> CompiledModel:
    """Compile ``source`` in ``worker`` (default: the shared warm worker).

    Raises:
        AssertionError: the program did not compile cleanly; the message lists the error
            findings (code, part or mate, line, message).
    """
    from procedura_brep.findings import blocking
    from procedura_brep.program.sandbox import CompileOptions, default_worker
    model = (worker or default_worker()).compile(source, CompileOptions(name=name, cache=cache))
    errors = blocking(model.findings)
    if errors or not model.parts:
        rows = "\n".join(f"  {f.code} {f.part or f.mate or ''} line {f.line}: {f.message}"
                         for f in errors) or "  (no parts)"
        raise AssertionError(f"the program did not compile cleanly:\n{rows}")
    return model


def rebuilt(model: CompiledModel) -> set[str]:
    """The parts a compile ran (each has a ``part:<name>`` timing); the others came from the
    part cache (or failed before they ran)."""
    return {k.split(":", 1)[1] for k in model.timings if k.startswith("part:")}
