"""URDF export in two profiles, as ``{relative path: bytes}`` (robot file plus ``meshes/``).

* ``strict``: plain URDF that yourdfpy and ``check_urdf`` accept. A spherical joint becomes three
  revolutes (X, Y, Z, each limited to the cone angle) through two tiny-mass links
  (:data:`TINY_MASS_KG`). Every ``<limit>`` carries effort and velocity.
* ``mujoco``: the same tree with spherical joints kept (``type="spherical"``) and a
  ``<mujoco><compiler .../></mujoco>`` element so MuJoCo keeps static bodies and visuals.

Link frames follow :mod:`procedura_brep.articulation.tree` (a child link's origin is its joint
anchor, its +Z the joint axis), so every joint axis is ``0 0 1``. Units: metres, kg, radians.
Mesh paths are relative (``meshes/<part>.stl``); stems are unique (part names are unique, and
collision pieces are ``<part>__c<k>``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import Literal

import numpy as np

from .. import materials
from ..articulation.mass import MassProps, link_masses
from ..articulation.tree import Articulation, Joint, articulate
from ..program.model import CompiledModel
from .meshes import collision_pieces, part_mesh, stl_bytes, to_local_m

Profile = Literal["strict", "mujoco"]

#: Mass of the helper links that carry a spherical joint's three revolutes (strict profile).
TINY_MASS_KG = 1e-6
#: Principal inertia of those helper links.
TINY_INERTIA = 1e-9

#: File name of each profile's robot description inside ``urdf/``.
ROBOT_FILES: dict[str, str] = {"strict": "robot.urdf", "mujoco": "robot.mujoco.urdf"}


def fmt(x: float) -> str:
    """A float written with 12 significant digits (sub-nanometre for our sizes)."""
    v = float(x)
    return "0" if abs(v) < 1e-15 else f"{v:.12g}"


def vec(v: np.ndarray) -> str:
    return " ".join(fmt(x) for x in v)


def rpy(r: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r))."""
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(r).as_euler("xyz")


def origin(parent: ET.Element, m: np.ndarray) -> None:
    """An ``<origin>`` for the 4x4 ``m`` whose translation is already in metres."""
    ET.SubElement(parent, "origin", xyz=vec(m[:3, 3]), rpy=vec(rpy(m[:3, :3])))


def relative_m(parent_mm: np.ndarray, child_mm: np.ndarray) -> np.ndarray:
    """inv(parent) @ child with the translation in metres."""
    rel = np.linalg.inv(parent_mm) @ child_mm
    rel[:3, 3] /= 1000.0
    return rel


def _inertial(link: ET.Element, mp: MassProps) -> None:
    ine = ET.SubElement(link, "inertial")
    ET.SubElement(ine, "origin", xyz=vec(mp.com), rpy="0 0 0")
    ET.SubElement(ine, "mass", value=fmt(mp.mass))
    i = mp.inertia
    ET.SubElement(ine, "inertia", ixx=fmt(i[0, 0]), ixy=fmt(i[0, 1]), ixz=fmt(i[0, 2]),
                  iyy=fmt(i[1, 1]), iyz=fmt(i[1, 2]), izz=fmt(i[2, 2]))


def _tiny_link(robot: ET.Element, name: str) -> None:
    link = ET.SubElement(robot, "link", name=name)
    _inertial(link, MassProps(TINY_MASS_KG, np.zeros(3), np.eye(3) * TINY_INERTIA))


def _joint(robot: ET.Element, name: str, jtype: str, parent: str, child: str, org: np.ndarray,
           axis: str, j: Joint, lo: float | None, hi: float | None) -> None:
    el = ET.SubElement(robot, "joint", name=name, type=jtype)
    origin(el, org)
    ET.SubElement(el, "parent", link=parent)
    ET.SubElement(el, "child", link=child)
    if jtype != "spherical":
        ET.SubElement(el, "axis", xyz=axis)
    attrs = {"effort": fmt(j.effort), "velocity": fmt(j.velocity)}
    if lo is not None and hi is not None:
        attrs = {"lower": fmt(lo), "upper": fmt(hi), **attrs}
    ET.SubElement(el, "limit", **attrs)


def mesh_files(model: CompiledModel, art: Articulation) -> dict[str, bytes]:
    """``meshes/<part>.stl`` (visual) and ``meshes/<part>__c<k>.stl`` (collision), link-local, m."""
    out: dict[str, bytes] = {}
    for lk in art.links:
        for name in lk.parts:
            part = model.part(name)
            out[f"meshes/{name}.stl"] = stl_bytes(to_local_m(part_mesh(part), lk.frame))
            for k, piece in enumerate(collision_pieces(part)):
                out[f"meshes/{name}__c{k}.stl"] = stl_bytes(to_local_m(piece, lk.frame))
    return out


def urdf_text(model: CompiledModel, *, profile: Profile = "strict",
              art: Articulation | None = None,
              masses: dict[str, MassProps] | None = None) -> str:
    """The robot description of ``model`` in ``profile`` (meshes referenced, not included)."""
    art = art or articulate(model)
    masses = masses or link_masses(model, art)
    robot = ET.Element("robot", name=model.name)
    if profile == "mujoco":
        mj = ET.SubElement(robot, "mujoco")
        ET.SubElement(mj, "compiler", angle="radian", fusestatic="false", discardvisual="false",
                      strippath="false", balanceinertia="true", autolimits="true")
    for mat in sorted({model.part(n).material for lk in art.links for n in lk.parts}):
        m = materials.get(mat)
        el = ET.SubElement(robot, "material", name=mat)
        ET.SubElement(el, "color", rgba=f"{vec(m.rgb)} 1")
    for lk in art.links:
        link = ET.SubElement(robot, "link", name=lk.name)
        _inertial(link, masses[lk.name])
        for name in lk.parts:
            part = model.part(name)
            vis = ET.SubElement(link, "visual", name=name)
            ET.SubElement(vis, "origin", xyz="0 0 0", rpy="0 0 0")
            geo = ET.SubElement(vis, "geometry")
            ET.SubElement(geo, "mesh", filename=f"meshes/{name}.stl")
            ET.SubElement(vis, "material", name=part.material)
            for k in range(len(collision_pieces(part))):
                col = ET.SubElement(link, "collision", name=f"{name}__c{k}")
                ET.SubElement(col, "origin", xyz="0 0 0", rpy="0 0 0")
                geo = ET.SubElement(col, "geometry")
                ET.SubElement(geo, "mesh", filename=f"meshes/{name}__c{k}.stl")
    for j in art.joints:
        org = relative_m(art.link(j.parent).frame, art.link(j.child).frame)
        if j.type == "spherical" and profile == "strict":
            ident = np.eye(4)
            _tiny_link(robot, f"{j.name}__x")
            _tiny_link(robot, f"{j.name}__y")
            cone = j.upper
            _joint(robot, f"{j.name}__x", "revolute", j.parent, f"{j.name}__x", org, "1 0 0",
                   j, -cone, cone)
            _joint(robot, f"{j.name}__y", "revolute", f"{j.name}__x", f"{j.name}__y", ident,
                   "0 1 0", j, -cone, cone)
            _joint(robot, f"{j.name}__z", "revolute", f"{j.name}__y", j.child, ident, "0 0 1",
                   j, -cone, cone)
        elif j.type == "spherical":
            _joint(robot, j.name, "spherical", j.parent, j.child, org, "0 0 1", j, None, None)
        else:
            _joint(robot, j.name, j.type, j.parent, j.child, org, "0 0 1", j, j.lower, j.upper)
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def urdf_files(model: CompiledModel, *, art: Articulation | None = None,
               masses: dict[str, MassProps] | None = None) -> dict[str, bytes]:
    """Both profiles and the shared meshes, as ``{path relative to urdf/: bytes}``."""
    art = art or articulate(model)
    masses = masses or link_masses(model, art)
    out = mesh_files(model, art)
    for prof, fname in ROBOT_FILES.items():
        out[fname] = urdf_text(model, profile=prof, art=art, masses=masses).encode()  # type: ignore[arg-type]
    return out
