"""Mass properties per link from exact part volumes and the model's material densities.

Each part's mass is ``volume * density`` with the density from
the model's material library (``CompiledModel.materials``: the built-in table
:data:`procedura_brep.materials.MATERIALS`, kg/m^3, e.g. steel 7850, aluminium 2700, ABS 1050,
rubber 1200, plus the program's own ``material(...)`` declarations). Centre of mass and the inertia
tensor about it come from OCCT's exact volume
integrals; parts combine with the parallel-axis theorem. Results are in SI (kg, m, kg m^2) and
expressed in the link frame. A link never has zero mass or a singular inertia: tiny values are
floored at :data:`MIN_MASS_KG` / :data:`MIN_INERTIA_KGM2`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..program.model import CompiledModel
from .tree import Articulation

#: Smallest mass written for any link (kg).
MIN_MASS_KG = 1e-6
#: Smallest principal inertia written for any link (kg m^2).
MIN_INERTIA_KGM2 = 1e-9


@dataclass(frozen=True)
class MassProps:
    """Mass properties in SI units.

    Attributes:
        mass: kg.
        com: centre of mass (3,), m, in the frame stated by the producer.
        inertia: 3x3 inertia tensor about the centre of mass, kg m^2, same frame.
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def principal(self) -> tuple[np.ndarray, np.ndarray]:
        """(principal moments (3,), rotation (3,3) whose columns are the principal axes)."""
        w, v = np.linalg.eigh(self.inertia)
        if np.linalg.det(v) < 0:
            v[:, 2] *= -1
        return w, v


def part_mass(model: CompiledModel, name: str) -> MassProps:
    """A part's mass properties in WORLD coordinates (kg, m, kg m^2)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    part = model.part(name)
    rho = model.material_of(part).density * 1e-9  # kg / mm^3
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(part.shape(), props)
    vol = abs(float(props.Mass()))
    c = props.CentreOfMass()
    m = props.MatrixOfInertia()
    inertia = np.array([[m.Value(i, j) for j in (1, 2, 3)] for i in (1, 2, 3)])
    if props.Mass() < 0:
        inertia = -inertia
    return MassProps(vol * rho, np.array([c.X(), c.Y(), c.Z()]) / 1000.0,
                     inertia * rho * 1e-6)


def combine(items: list[MassProps]) -> MassProps:
    """Sum of bodies given in the same frame (parallel-axis theorem)."""
    mass = sum(i.mass for i in items)
    if mass <= 0:
        return MassProps(0.0, np.zeros(3), np.zeros((3, 3)))
    com = sum(i.mass * i.com for i in items) / mass
    inertia = np.zeros((3, 3))
    for i in items:
        d = i.com - com
        inertia += i.inertia + i.mass * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return MassProps(mass, com, inertia)


def floored(p: MassProps) -> MassProps:
    """``p`` with mass and principal inertias raised to the minimums (triangle inequality kept)."""
    mass = max(p.mass, MIN_MASS_KG)
    w, v = np.linalg.eigh((p.inertia + p.inertia.T) / 2)
    w = np.maximum(w, MIN_INERTIA_KGM2)
    # triangle inequality: each moment <= sum of the other two
    for k in range(3):
        others = w.sum() - w[k]
        if w[k] > others:
            w[(k + 1) % 3] += (w[k] - others) / 2 + MIN_INERTIA_KGM2
            w[(k + 2) % 3] += (w[k] - others) / 2 + MIN_INERTIA_KGM2
    return MassProps(mass, p.com, v @ np.diag(w) @ v.T)


def to_frame(p: MassProps, frame_mm: np.ndarray) -> MassProps:
    """World mass properties expressed in a 4x4 world frame given in mm."""
    r = frame_mm[:3, :3]
    t = frame_mm[:3, 3] / 1000.0
    return MassProps(p.mass, r.T @ (p.com - t), r.T @ p.inertia @ r)


def link_masses(model: CompiledModel, art: Articulation) -> dict[str, MassProps]:
    """Mass properties of every link, in its link frame, never zero."""
    out: dict[str, MassProps] = {}
    for lk in art.links:
        world = combine([part_mass(model, n) for n in lk.parts])
        out[lk.name] = floored(to_frame(world, lk.frame))
    return out
