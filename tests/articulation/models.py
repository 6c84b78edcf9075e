"""Small hand-built models for articulation, export and battery tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

LAMP = Path(__file__).resolve().parents[1] / "program" / "lamp.py"


def lamp_source(limits: tuple[float, float] | None = (-45, 45)) -> str:
    """The test lamp with its arm limits replaced (at +-60 deg the arm would dip into the base)."""
    src = LAMP.read_text()
    return src.replace("limits=(-45, 45)", f"limits={limits!r}")


def compile_lamp(worker, limits: tuple[float, float] | None = (-45, 45)):
    from procedura_brep.program import compile_source
    return compile_source(lamp_source(limits), name="lamp", worker=worker)


def part(name: str, shape, placement=None, material: str = "steel", frames=None):
    from procedura_brep import kernel
    from procedura_brep.program.model import CompiledPart
    return CompiledPart(name=name, brep=kernel.write_brep(shape.wrapped),
                        placement=np.eye(4) if placement is None else placement,
                        frames=frames or {}, material=material)


def mate(name: str, child: str, parent: str, kind: str = "static", mtype: str = "peg_socket",
         frame=None, options=None):
    from procedura_brep.program.model import CompiledMate
    return CompiledMate(name=name, type=mtype, kind=kind, child=child, child_frame="f",
                        parent=parent, parent_frame="f", nominal_name="d", nominal=10.0,
                        fit={}, options=options or {}, dof={},
                        world_frame=np.eye(4) if frame is None else frame)
