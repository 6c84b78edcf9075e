"""URDF export in two profiles, as ``{relative path: bytes}`` (robot file plus ``meshes/``).

* ``strict``: plain URDF that yourdfpy and ``check_urdf`` accept. A spherical joint becomes three
  revolutes ``<joint>__x|y|z`` about the joint frame's X, Y, Z axes, all at the anchor, each
  limited to +-cone (a box that contains the cone), through two tiny-mass links
  (:data:`TINY_MASS_KG`). Every ``<limit>`` carries effort and velocity.
* ``mujoco``: the same tree with spherical joints kept (``type="spherical"``) and a
  ``<mujoco><compiler .../></mujoco>`` element so MuJoCo keeps static bodies and visuals.
  MuJoCo's URDF importer turns ``spherical`` into a ``ball`` joint and copies
  ``<limit lower upper>`` into its range; a ball range is ``0 cone`` (only the upper value, the
  cone half-angle, is used), so a spherical joint's limit is ``lower="0" upper="<cone rad>"``
  (``autolimits`` makes it limited). URDF parsers other than MuJoCo's do not know the type:
  use the strict profile for them.

A cylindrical joint (slide along and turn about one axis) is, in both profiles, a prismatic
``<joint>__slide`` from the parent to a tiny-mass carrier link ``<joint>__slide`` and a revolute
(or continuous) ``<joint>__turn`` from the carrier to the child, both at the anchor, axis
``0 0 1``.

A coupled joint (``couple(...)``) carries ``<mimic joint="<driver>" multiplier="<ratio>"
offset="<offset>"/>`` (SI: rad/rad, m/rad, rad/m), in both profiles. A chain of couplings (a gear
train) names the chain's head, the joint nobody drives, with the product of the ratios
(:meth:`~procedura_brep.articulation.tree.Articulation.root_driver`): URDF consumers
resolve one level of mimic only. A linkage (a closed loop) is the tree without its cut joint
(URDF has no loops): the cut is named in an XML comment at the end of the robot, and the loop's
other joints carry no mimic (they follow the loop, not a ratio).

Link frames follow :mod:`procedura_brep.articulation.tree` (a child link's origin is its joint
anchor, its +Z the joint axis), so every joint axis is ``0 0 1``. Units: metres, kg, radians.
Mesh paths are relative (``meshes/<part>.stl``); stems are unique (part names are unique, and
collision pieces are ``<part>__c<k>``).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import Literal

import numpy as np

from ..articulation.mass import MassProps, link_masses
from ..articulation.tree import Articulation, Joint, articulate
from ..materials import get
from ..mates.kinds import REVOLUTE, JointKind
from ..program.model import CompiledModel
from .meshes import collision_pieces, sim_mesh, stl_bytes, to_local_m

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


#: Below this ``hypot(R00, R10)`` (= |cos pitch|) the pitch is +-90 deg to machine precision
#: (gimbal lock): yaw is set to 0 and roll carries the whole rotation about the shared axis.
GIMBAL_EPS = 1e-15


def rpy(r: np.ndarray) -> np.ndarray:
    """URDF roll-pitch-yaw ``(r, p, y)`` with ``R = Rz(y) Ry(p) Rx(r)``, exact at gimbal lock.

    Yaw comes from the first column; roll and pitch from ``Rz(-y) R = Ry(p) Rx(r)``, which is
    well conditioned for any yaw (the residual of a slightly wrong yaw lands in the entry that is
    0 by construction), so ``R`` is reconstructed to machine precision everywhere, including
    pitch = +-90 deg, where yaw is 0 by convention (:data:`GIMBAL_EPS`). No warnings.
    """
    m = np.asarray(r, dtype=float)
    c = float(np.hypot(m[0, 0], m[1, 0]))
    yaw = math.atan2(m[1, 0], m[0, 0]) if c > GIMBAL_EPS else 0.0
    cy, sy = math.cos(yaw), math.sin(yaw)
    # rows of Rz(-yaw) @ m that are needed: row0 = cy*m0 + sy*m1, row1 = -sy*m0 + cy*m1
    row0 = cy * m[0] + sy * m[1]
    row1 = -sy * m[0] + cy * m[1]
    roll = math.atan2(-row1[2], row1[1])
    pitch = math.atan2(-m[2, 0], row0[0])
    return np.array([roll, pitch, yaw])


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The 3x3 rotation ``Rz(yaw) Ry(pitch) Rx(roll)`` (the inverse of :func:`rpy`)."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


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


def _joint(robot: ET.Element, name: str, kind: JointKind, parent: str, child: str, org: np.ndarray,
           axis: str, j: Joint, lo: float | None, hi: float | None,
           limits: tuple[float, float] | None = None) -> None:
    """One ``<joint>`` of ``kind`` (its URDF type; a ball has no axis); ``limits`` = (effort,
    velocity), default the joint's own."""
    el = ET.SubElement(robot, "joint", name=name, type=str(kind.urdf))
    origin(el, org)
    ET.SubElement(el, "parent", link=parent)
    ET.SubElement(el, "child", link=child)
    if not kind.ball:
        ET.SubElement(el, "axis", xyz=axis)
    effort, velocity = limits or (j.effort, j.velocity)
    attrs = {"effort": fmt(effort), "velocity": fmt(velocity)}
    if lo is not None and hi is not None:
        attrs = {"lower": fmt(lo), "upper": fmt(hi), **attrs}
    ET.SubElement(el, "limit", **attrs)


def mesh_files(model: CompiledModel, art: Articulation) -> dict[str, bytes]:
    """``meshes/<part>.stl`` (visual) and ``meshes/<part>__c<k>.stl`` (collision), link-local, m;
    within MuJoCo's face limit (:func:`.meshes.sim_mesh`)."""
    out: dict[str, bytes] = {}
    for lk in art.links:
        for name in lk.parts:
            part = model.part(name)
            out[f"meshes/{name}.stl"] = stl_bytes(to_local_m(sim_mesh(part), lk.frame))
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
        m = get(mat, model.materials)
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
        kind = j.kind
        if kind.ball and profile == "strict":
            ident = np.eye(4)
            _tiny_link(robot, f"{j.name}__x")
            _tiny_link(robot, f"{j.name}__y")
            cone = j.upper
            _joint(robot, f"{j.name}__x", REVOLUTE, j.parent, f"{j.name}__x", org, "1 0 0",
                   j, -cone, cone)
            _joint(robot, f"{j.name}__y", REVOLUTE, f"{j.name}__x", f"{j.name}__y", ident,
                   "0 1 0", j, -cone, cone)
            _joint(robot, f"{j.name}__z", REVOLUTE, f"{j.name}__y", j.child, ident, "0 0 1",
                   j, -cone, cone)
        elif kind.ball:
            # MuJoCo's URDF importer maps "spherical" to a ball joint and reads <limit lower upper>
            # into its range, whose ball convention is "0 cone" (autolimits makes it limited)
            _joint(robot, j.name, kind, j.parent, j.child, org, "0 0 1", j, 0.0, j.upper)
        elif kind.compound:
            # both profiles: slide then turn on one axis, through a tiny-mass carrier link
            # (a URDF joint has one DOF, and MuJoCo's importer keeps one joint per link)
            slide, turn = j.dofs()
            _tiny_link(robot, slide.name)
            _joint(robot, slide.name, slide.kind, j.parent, slide.name, org, "0 0 1", j,
                   slide.lower, slide.upper, (slide.effort, slide.velocity))
            _joint(robot, turn.name, turn.kind, slide.name, j.child, np.eye(4), "0 0 1", j,
                   turn.lower, turn.upper, (turn.effort, turn.velocity))
        else:
            _joint(robot, j.name, kind, j.parent, j.child, org, "0 0 1", j, j.lower, j.upper)
            if j.coupling is not None and j.coupling.type != "linkage":
                head, ratio, offset = art.root_driver(j.name)
                el = robot.findall("joint")[-1]
                ET.SubElement(el, "mimic", joint=head, multiplier=fmt(ratio), offset=fmt(offset))
    for cut in art.cuts:  # URDF is a tree: a loop's cut joint is named, not written
        robot.append(ET.Comment(
            f" loop closure: mate {cut.name} ({cut.type}) joins link {cut.child} to link {cut.parent} "
            f"at {vec(cut.anchor_m)} m (world); URDF has no loops, so it is left out: model.xml "
            f"closes it with an equality connect, model.usda with a joint excluded from the "
            f"articulation "))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def urdf_files(model: CompiledModel, *, art: Articulation | None = None,
               masses: dict[str, MassProps] | None = None) -> dict[str, bytes]:
    """Both profiles and the shared meshes, as ``{path relative to urdf/: bytes}``."""
    art = art or articulate(model)
    masses = masses or link_masses(model, art)
    out = mesh_files(model, art)
    for prof, fname in ROBOT_FILES.items():
        out[fname] = urdf_text(model, profile=prof, art=art, masses=masses).encode()  # type: ignore[arg-type]  # ROBOT_FILES keys are the profiles
    return out
