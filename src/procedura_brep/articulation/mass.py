"""Mass properties per part and per link, from exact volumes and the model's material densities.

A part's mass is, by its ``@part`` declaration:

* ``solid`` (the default): ``volume * density``, the density from the model's material library
  (``CompiledModel.materials``: the built-in table :data:`procedura_brep.materials.MATERIALS`,
  kg/m^3, e.g. steel 7850, aluminium 2700, ABS 1050, rubber 1200, plus the program's own
  ``material(...)`` declarations);
* ``declared`` (``mass=kg``): the solid's properties with the density scaled so the part (with
  its ``@paint`` blocks, each keeping its share) weighs what it declares; centre of mass and
  the shape of the inertia stay the solid's;
* ``shell-exact`` / ``shell-approx`` (``hollow=wall``): the part as a shell of that wall, of its
  material (:mod:`.shell`: exact where OCCT's offset works, else the thin-shell
  approximation; a wall not under the part's half-thickness is weighed ``solid``, with a note).

Centre of mass and the inertia tensor about it come from OCCT's exact volume (or surface)
integrals; parts combine with the parallel-axis theorem. Results are in SI (kg, m, kg m^2);
:func:`part_mass` is in world coordinates, :func:`link_masses` in each link frame. A link never
has zero mass or a singular inertia: tiny values are floored at :data:`MIN_MASS_KG` /
:data:`MIN_INERTIA_KGM2`. :func:`mass_report` is ``report.json``'s ``masses`` section.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..findings import Finding
from ..program.model import CompiledModel, CompiledPart
from .shell import Integrals, Method, shell, volume_integrals
from .tree import Articulation

#: Smallest mass written for any link (kg).
MIN_MASS_KG = 1e-6
#: Smallest principal inertia written for any link (kg m^2).
MIN_INERTIA_KGM2 = 1e-9
#: Each principal moment is kept at least this fraction of the largest below the sum of the
#: other two (:func:`floored`): 20 times what rounding to 6 significant digits can take.
TRIANGLE_MARGIN = 2e-5


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


@dataclass(frozen=True)
class PartMass:
    """One part's mass properties (world, SI) and how they were had.

    Attributes:
        props: mass (kg), centre of mass (m, world), inertia about it (kg m^2, world).
        method: ``solid`` | ``declared`` | ``shell-exact`` | ``shell-approx``.
        density: the material's density, kg/m^3.
        note: what a figure not had as the part asked rests on (a fallback and why, a shell
            shared with paint blocks); "" otherwise.
    """

    props: MassProps
    method: Method
    density: float
    note: str = ""


def part_mass(model: CompiledModel, name: str) -> MassProps:
    """A part's mass properties in WORLD coordinates (kg, m, kg m^2)."""
    return part_mass_detail(model, name).props


def part_mass_detail(model: CompiledModel, name: str) -> PartMass:
    """A part's mass properties in WORLD coordinates with the method that gave them."""
    part = model.part(name)
    density = model.material_of(part).density
    rho = density * 1e-9  # kg / mm^3
    owner = model.part(part.block_of) if part.block_of else part
    owned = [p for p in model.parts if p.owner == owner.name]  # the part and its paint blocks
    if owner.mass is not None:
        return PartMass(_world(_solid(part), part, _shared(model, owned, owner.mass, rho)),
                        "declared", density)
    if owner.hollow is not None and len(owned) > 1:  # a painted shell: one shell, shared
        got = shell(owner.unpainted or owner.brep, owner.hollow)
        kg = got.volume * model.material_of(owner).density * 1e-9
        note = "; ".join(n for n in (got.note, PAINTED_SHELL) if n)
        return PartMass(_world(_solid(part), part, _shared(model, owned, kg, rho)), got.method,
                        density, note)
    if part.hollow is not None:
        got = shell(part.brep, part.hollow, part.local_shape())
        return PartMass(_world(got, part, rho), got.method, density, got.note)
    return PartMass(_world(_solid(part), part, rho), "solid", density)


#: The note of a hollow part with ``@paint`` blocks.
PAINTED_SHELL = ("the shell of the unpainted part (its material), shared with its paint blocks in "
                 "proportion to their solid masses")


def _shared(model: CompiledModel, pieces: list[CompiledPart], kg: float, rho: float) -> float:
    """The density (kg/mm^3) that makes a piece of density ``rho`` carry its share of ``kg``
    spread over ``pieces`` (a part and its paint blocks) in proportion to their solid masses."""
    total = sum(model.material_of(p).density * 1e-9 * _solid(p).volume for p in pieces)
    return kg / total * rho if total > 0 else 0.0


def _solid(part: CompiledPart) -> Integrals:
    return volume_integrals(part.local_shape())


def _world(i: Integrals, part: CompiledPart, rho: float) -> MassProps:
    """Local integrals (mm) times ``rho`` (kg/mm^3), placed in the world (SI)."""
    r, t = part.placement[:3, :3], part.placement[:3, 3]
    com = (r @ i.com + t) / 1000.0
    return MassProps(i.volume * rho, com, r @ i.inertia @ r.T * rho * 1e-6)


def combine(items: list[MassProps]) -> MassProps:
    """Sum of bodies given in the same frame (parallel-axis theorem)."""
    mass = sum(i.mass for i in items)
    if mass <= 0:
        return MassProps(0.0, np.zeros(3), np.zeros((3, 3)))
    com: np.ndarray = np.sum([i.mass * i.com for i in items], axis=0) / mass
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
    # triangle inequality: each moment <= sum of the other two, with a margin of
    # TRIANGLE_MARGIN of the largest: a flat or slender part sits on the boundary (a lamina's
    # C = A + B), and the 6 significant digits an MJCF file keeps would tip it over (MuJoCo
    # then refuses the file: a recorded lead screw did)
    margin = TRIANGLE_MARGIN * float(w.max())
    for k in range(3):
        others = w.sum() - w[k]
        if w[k] > others - margin:
            w[(k + 1) % 3] += (w[k] - others + margin) / 2 + MIN_INERTIA_KGM2
            w[(k + 2) % 3] += (w[k] - others + margin) / 2 + MIN_INERTIA_KGM2
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


def mass_report(model: CompiledModel) -> tuple[dict[str, Any], list[Finding]]:
    """``report.json``'s ``masses`` section (world frame, SI) and its findings (a ``hollow=``
    weighed otherwise than asked: a warning naming the part)."""
    rows: list[dict[str, Any]] = []
    props: list[MassProps] = []
    findings: list[Finding] = []
    for p in model.parts:
        pm = part_mass_detail(model, p.name)
        props.append(pm.props)
        row: dict[str, Any] = {"name": p.name, "material": p.material, "density_kg_m3": pm.density,
                               "method": pm.method, "mass_kg": pm.props.mass,
                               "com_m": pm.props.com.tolist(), "inertia_kg_m2": pm.props.inertia.tolist()}
        if p.mass is not None:
            row["declared_kg"] = p.mass
        if p.hollow is not None:
            row["hollow_mm"] = p.hollow
        if pm.note:
            row["note"] = pm.note
            if pm.method == "solid" and p.hollow is not None:
                findings.append(Finding("part-hollow", f"part {p.name}: {pm.note}", part=p.name,
                                        value=p.hollow, severity="warning"))
        rows.append(row)
    total = combine(props)
    return ({"frame": "world", "units": {"mass": "kg", "length": "m", "inertia": "kg m^2"},
             "parts": rows, "total": {"mass_kg": total.mass, "com_m": total.com.tolist(),
                                      "inertia_kg_m2": total.inertia.tolist()}}, findings)
