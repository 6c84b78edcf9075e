"""The export formats: one row per format, read by the bundle writer and the CLI's ``--formats``.

A row names the format, the files it writes (relative to the run directory), a one-line
description and its writer: a pure function of an :class:`ExportJob` returning
``{relative path: bytes}``. Writers import their module lazily, so this table (and the CLI's
``--help``, which reads it) loads no CAD, numeric or USD module. Adding a format is one row.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from ..articulation import Articulation, MassProps
    from ..program.model import CompiledModel


@dataclass(frozen=True)
class ExportJob:
    """What a writer gets: the model, and (for articulated formats) its articulation and link
    masses, computed once for every format of the bundle."""

    model: CompiledModel
    art: Articulation | None = None
    masses: dict[str, MassProps] | None = None
    step_schema: Literal["AP214", "AP242"] = "AP214"


Writer = Callable[[ExportJob], dict[str, bytes]]


@dataclass(frozen=True)
class Format:
    """One export format.

    Attributes:
        name: the ``--formats`` name.
        files: the files it writes, comma-separated (a name ending in ``/`` is a folder); a test
            checks every row against what its writer returns.
        description: one line.
        write: the writer.
        articulated: whether it needs the articulation (links, joints) and link masses.
    """

    name: str
    files: str
    description: str
    write: Writer
    articulated: bool = False


def _step(job: ExportJob) -> dict[str, bytes]:
    from .step import step_bytes
    return {"model.step": step_bytes(job.model, schema=job.step_schema)}


def _obj(job: ExportJob) -> dict[str, bytes]:
    from .obj import obj_files
    return obj_files(job.model)


def _glb(job: ExportJob) -> dict[str, bytes]:
    from .glb import glb_bytes
    return {"model.glb": glb_bytes(job.model)}


def _usd(job: ExportJob) -> dict[str, bytes]:
    from .usd import usda_text
    return {"model.usda": usda_text(job.model, art=job.art, masses=job.masses).encode()}


def _urdf(job: ExportJob) -> dict[str, bytes]:
    from .urdf import urdf_files
    return {f"urdf/{k}": v for k, v in urdf_files(job.model, art=job.art, masses=job.masses).items()}


def _viewer(job: ExportJob) -> dict[str, bytes]:
    from .viewer import viewer_files
    return viewer_files(job.model, job.art)


def _mjcf(job: ExportJob) -> dict[str, bytes]:
    from .mjcf import mjcf_files
    return mjcf_files(job.model, art=job.art, masses=job.masses)


#: Every format, in writing order.
REGISTRY: dict[str, Format] = {f.name: f for f in (
    Format("step", "model.step", "STEP AP214/AP242: one named, coloured product per part, mm", _step),
    Format("obj", "model.obj, model.mtl", "OBJ + MTL: one group per part, PBR material fields", _obj),
    Format("glb", "model.glb", "binary glTF: per-part nodes and PBR materials", _glb),
    Format("usd", "model.usda", "OpenUSD: UsdPhysics rigid bodies, joints, drives, metres", _usd,
           articulated=True),
    Format("urdf", "urdf/", "URDF, strict and mujoco profiles, with STL meshes", _urdf,
           articulated=True),
    Format("mjcf", "model.xml, urdf/meshes/", "MJCF scene the MuJoCo battery runs (meshes "
           "shared with urdf/)", _mjcf, articulated=True),
    Format("viewer", "viewer.html, viewer/", "offline viewer: part tree, joint sliders, exploded "
           "view, mate frames, findings (three.js, no network)", _viewer),
)}

#: Every format name ``--formats`` accepts, in writing order.
FORMAT_NAMES: tuple[str, ...] = tuple(REGISTRY)

__all__ = ["ExportJob", "FORMAT_NAMES", "Format", "REGISTRY", "Writer"]
