"""MJCF export built with :class:`mujoco.MjSpec`: the scene the MuJoCo battery runs.

One body per link, nested as the kinematic tree; body frames are the link frames of
:mod:`procedura_brep.articulation.tree` (so every joint sits at the body origin with axis
``0 0 1``). SI units, radians, the ``implicitfast`` integrator, a floor plane at the assembly's
lowest point, explicit inertials from :mod:`procedura_brep.articulation.mass`.

Geoms: the exact visual mesh of every part (group 1, no collisions) and its convex collision
pieces (group 3). Pairs of links whose collision pieces already overlap in the compiled pose are
excluded from collisions (MuJoCo collides convex hulls, which fill holes and bores; the exact
rest-contact check is battery B3).

Actuators follow each joint's ``drive`` in the :class:`~procedura_brep.articulation.Articulation`:
a position servo per ``position``-driven DOF, a velocity servo per ``velocity``-driven one (the
articulation gives continuous joints velocity drives). A cylindrical joint is two joints on one
body, both at its origin about/along
``0 0 1``: ``<mate>__slide`` (slide) then ``<mate>__turn`` (hinge), each with its own servo.
Position gains are scaled from the joint-space inertia so every servo has the
same natural frequency (:data:`SERVO_HZ`); a velocity servo's gain is at least effort / velocity
(full effort at stall), since a wheel carries the vehicle's load, not just its own inertia.
Every actuator's force is limited by the mate's effort. A spherical joint (MuJoCo ``ball``,
``range="0 cone"``: only the upper value, the cone half-angle, counts) is held by three position
servos ``<joint>__x|y|z`` whose transmission is the ball's rotation vector projected on the joint
frame's x, y and z (``gear``), each within +-cone: like a swivel's lock, they hold the compiled
pose against gravity up to the mate's effort. The root is free or welded to the world as the
articulation's ``base`` says (nothing here re-derives it).

Couplings (``couple(...)``, :class:`~procedura_brep.articulation.tree.Coupling`): a driven joint
gets no actuator (a servo of its own would fight the coupling); an ``<equality><joint>`` named
after the coupling ties it to its driver (``q_driven = offset + ratio q_driver``, SI, from the
compiled pose; a chain of couplings is a chain of equalities). It is written
``joint1="<driven>" joint2="<driver>" polycoef="offset ratio 0 0 0"`` when ``|ratio| >= 1`` and
the other way round, ``joint1="<driver>" joint2="<driven>" polycoef="-offset/ratio 1/ratio 0 0
0"``, when ``|ratio| < 1`` (:func:`equality_form`): MuJoCo regularises a joint equality by the
sum of the two joints' inverse inertias, ignoring the coefficient, which overstates the
constraint's true inverse inertia ``w1 + k^2 w2`` whenever ``|k| < 1``; a lead screw's nut
(0.64 mm per rad) then drifted 27 mm off its screw. With ``|k| >= 1`` the estimate is never
above the truth, and with :data:`COUPLING_SOLREF` and the near-hard :data:`COUPLING_SOLIMP`
every coupling of ``tests/program/transmission.py`` holds within 0.05 % of its ratio. A
linkage's cut joint (:class:`~procedura_brep.articulation.tree.Cut`) is no joint of the tree but
an ``<equality><connect name="<cut mate>" body1="<its parent link>" body2="<its child link>"
anchor=...>`` at its anchor (body1's frame), :data:`LOOP_SOLREF` and the same impedance; the loop's other
joints have no servo (the driver turns the loop). A chain
head's servo is tuned for its own inertia plus what its couplings reflect onto it
(``ratio^2 M_jj`` of each joint it drives), and a speed-driven head that is not a wheel gets the
inertia-scaled gain ``2 zeta M omega`` instead of the stall gain: MuJoCo's ``implicitfast``
integrates actuator damping implicitly but solves constraints against the bare inertia, so a
stall gain thousands of times a lead screw's inertia let its nut leave the screw by 10 mm in one
step.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..articulation.mass import MassProps, link_masses
from ..articulation.tree import Articulation, ArticulationError, Coupling, articulate
from ..mates.kinds import JointKind
from ..program.model import CompiledModel
from .meshes import collision_pieces, part_mesh, sim_mesh, stl_bytes, to_local_m

log = logging.getLogger(__name__)

#: Simulation timestep, s.
TIMESTEP = 0.002
#: Natural frequency of every position servo, Hz (gain = M_jj * (2 pi f)^2).
SERVO_HZ = 8.0
#: Angular natural frequency of every servo, rad/s (2 pi SERVO_HZ).
SERVO_OMEGA = 2 * np.pi * SERVO_HZ
#: Smallest mate velocity (rad/s or m/s) a velocity servo's stall gain divides by (a zero
#: velocity would make the gain infinite).
MIN_VELOCITY = 1e-9
#: Damping ratio of every servo.
SERVO_ZETA = 1.0
#: Time constant and damping ratio of a coupling's equality (>= 2 timesteps: stable).
COUPLING_SOLREF = (0.01, 1.0)
#: Time constant of a linkage's connect (2.5 timesteps): the loop's gap under the battery's ramp
#: scales with its square (0.088 mm at 0.01 s, 0.026 mm at 0.005 s on tests/program/fourbar.py).
LOOP_SOLREF = (0.005, 1.0)
#: Impedance of a coupling's equality: near hard at every violation (see the module docstring).
COUPLING_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
#: Mesh directory of ``model.xml`` relative to the bundle root (shared with the URDF).
MESHDIR = "urdf/meshes"


@dataclass
class MjcfBuild:
    """A built scene: the spec, its mesh assets and facts the battery needs.

    Attributes:
        spec: the MjSpec (compile with ``spec.compile()``; assets already attached).
        assets: ``{mesh file name: STL bytes}``.
        free_root: whether the root link has a free joint.
        wheels: names of the wheel joints.
        floor_z: floor height, m (world).
        excluded: link pairs excluded from collision because their hulls overlap at rest.
    """

    spec: object
    assets: dict[str, bytes]
    free_root: bool
    wheels: list[str]
    floor_z: float
    excluded: list[tuple[str, str]] = field(default_factory=list)


def quat(r: np.ndarray) -> list[float]:
    """MuJoCo quaternion (w, x, y, z) of a rotation matrix."""
    from scipy.spatial.transform import Rotation
    x, y, z, w = Rotation.from_matrix(r).as_quat()
    return [float(w), float(x), float(y), float(z)]


def lowest_z(model: CompiledModel, parts: list[str]) -> float:
    """Lowest world z of the given parts' meshes, mm."""
    return float(min(part_mesh(model.part(n)).vertices[:, 2].min() for n in parts))


def _geoms(spec, body, model: CompiledModel, name: str, frame: np.ndarray,
           assets: dict[str, bytes]) -> None:
    import mujoco
    part = model.part(name)
    mat = model.material_of(part)
    fname = f"{name}.stl"
    assets[fname] = stl_bytes(to_local_m(sim_mesh(part), frame))  # within MuJoCo's face limit
    spec.add_mesh(name=name, file=fname)
    g = body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name,
                      contype=0, conaffinity=0, group=1, rgba=[*mat.rgb, 1.0])
    g.mass = 0
    for k, piece in enumerate(collision_pieces(part)):
        stem = f"{name}__c{k}"
        assets[f"{stem}.stl"] = stl_bytes(to_local_m(piece, frame))
        spec.add_mesh(name=stem, file=f"{stem}.stl")
        c = body.add_geom(name=stem, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=stem, group=3,
                          rgba=[*mat.rgb, 0.0])
        c.mass = 0


def _balanced(xml: str) -> str:
    """``xml`` with ``balanceinertia="true"`` on its compiler element: ``MjSpec.to_xml`` leaves
    the flag out, so a file loaded on its own would refuse a moment its rounding tipped past the
    triangle inequality (the floored moments keep a margin; this is the second guard)."""
    if "balanceinertia" in xml:
        return xml
    return xml.replace("<compiler ", '<compiler balanceinertia="true" ', 1)


def _inertial(body, mp: MassProps) -> None:
    w, v = mp.principal()
    body.explicitinertial = True
    body.mass = float(mp.mass)
    body.ipos = [float(x) for x in mp.com]
    body.iquat = quat(v)
    body.inertia = [float(x) for x in w]


def _mj_joint_type(kind: JointKind):
    """The ``mjtJoint`` of a joint kind's MuJoCo type (``hinge``, ``slide``, ``ball``)."""
    import mujoco
    return getattr(mujoco.mjtJoint, f"mjJNT_{str(kind.mjcf).upper()}")


def _dof_joint(spec, body, dof, kp: float) -> None:
    """A hinge or slide at the body origin about/along its z, with its servo."""
    import mujoco
    jt = body.add_joint(name=dof.name, type=_mj_joint_type(dof.kind), axis=[0, 0, 1], pos=[0, 0, 0])
    if not dof.kind.limited:
        jt.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    else:
        jt.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        jt.range = [float(dof.lower), float(dof.upper)]
    if dof.driver:  # moved by its coupling's equality: no servo of its own
        return
    act = spec.add_actuator(name=dof.name, target=dof.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
    if dof.drive == "velocity":
        act.set_to_velocity(kv=float(kp))
        act.ctrlrange = [-dof.velocity, dof.velocity]
    else:
        if dof.lower is None or dof.upper is None:
            raise ArticulationError(f"joint {dof.name!r} has a position drive but no limits; "
                                    f"give it limits or a velocity drive")
        m_jj = kp  # gains hold M_jj for position servos
        act.set_to_position(kp=float(m_jj * SERVO_OMEGA**2),
                            kv=float(2 * SERVO_ZETA * m_jj * SERVO_OMEGA))
        act.ctrlrange = [float(dof.lower), float(dof.upper)]
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    act.forcerange = [-dof.effort, dof.effort]


def equality_form(c: Coupling) -> tuple[str, str, float, float]:
    """``(joint1, joint2, a0, a1)`` of a coupling's joint equality ``q1 = a0 + a1 q2``: the
    driven joint first when ``|ratio| >= 1``, else the driver (see the module docstring)."""
    if abs(c.ratio) >= 1.0:
        return c.driven, c.driver, c.offset, c.ratio
    return c.driver, c.driven, -c.offset / c.ratio, 1.0 / c.ratio


def _reflected(art: Articulation, m, mass_matrix: np.ndarray) -> dict[str, float]:
    """Chain head -> the inertia its couplings add to it, ``sum(ratio^2 M_jj)`` over the joints
    it drives (directly or down a chain), so its servo is tuned for the load it moves."""
    import mujoco
    out: dict[str, float] = {}
    for c in art.couplings:
        if c.type == "linkage":
            continue
        head, ratio, _ = art.root_driver(c.driven)
        dof = int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, c.driven)])
        out[head] = out.get(head, 0.0) + ratio**2 * float(mass_matrix[dof, dof])
    return out


def _build(model: CompiledModel, art: Articulation, masses: dict[str, MassProps], floor_z: float,
           gains: dict[str, float] | None, excluded: list[tuple[str, str]]) -> MjcfBuild:
    import mujoco
    spec = mujoco.MjSpec()
    spec.modelname = model.name
    spec.compiler.degree = False
    spec.compiler.autolimits = True
    spec.compiler.balanceinertia = True
    spec.meshdir = MESHDIR
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.timestep = TIMESTEP
    spec.worldbody.add_light(name="sun", pos=[0, 0, 5], dir=[0, 0, -1])
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            pos=[0, 0, floor_z], rgba=[0.8, 0.8, 0.8, 1])
    assets: dict[str, bytes] = {}
    bodies = {}
    for lk in art.links:
        if lk.parent_joint is None:
            parent_body, parent_frame = spec.worldbody, np.eye(4)
        else:
            pj = art.joint(lk.parent_joint)
            parent_body, parent_frame = bodies[pj.parent], art.link(pj.parent).frame
        rel = np.linalg.inv(parent_frame) @ lk.frame
        body = parent_body.add_body(name=lk.name, pos=[float(x) for x in rel[:3, 3] / 1000.0],
                                    quat=quat(rel[:3, :3]))
        bodies[lk.name] = body
        _inertial(body, masses[lk.name])
        if lk.parent_joint is None and art.free:
            body.add_freejoint(name=f"{lk.name}__free")
        for name in lk.parts:
            _geoms(spec, body, model, name, lk.frame, assets)
        if lk.parent_joint is None:
            continue
        j = art.joint(lk.parent_joint)
        kp = (gains or {}).get(j.name, 1.0)
        if j.kind.ball:  # always a position hold (its drive)
            # a ball joint's range is "0 cone": only the upper value (the cone half-angle) counts
            body.add_joint(name=j.name, type=_mj_joint_type(j.kind), pos=[0, 0, 0],
                           range=[0.0, float(j.upper)], limited=mujoco.mjtLimited.mjLIMITED_TRUE)
            for k, ax in enumerate("xyz"):  # hold servos about the joint frame's x, y, z
                act = spec.add_actuator(name=f"{j.name}__{ax}", target=j.name,
                                        trntype=mujoco.mjtTrn.mjTRN_JOINT)
                act.gear = [1.0 if i == k else 0.0 for i in range(6)]
                act.set_to_position(kp=float(kp * SERVO_OMEGA**2),
                                    kv=float(2 * SERVO_ZETA * kp * SERVO_OMEGA))
                act.ctrlrange = [-float(j.upper), float(j.upper)]
                act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
                act.forcerange = [-j.effort, j.effort]
            continue
        for dof in j.dofs():  # one joint; a cylindrical joint's slide then turn, same axis
            _dof_joint(spec, body, dof, (gains or {}).get(dof.name, 1.0))
    for cut in art.cuts:  # a linkage's loop: a point constraint at the cut joint's anchor
        anchor = np.linalg.inv(art.link(cut.parent).frame) @ cut.frame
        spec.add_equality(name=cut.name, type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_BODY,
                          name1=cut.parent, name2=cut.child,
                          data=[float(x) for x in anchor[:3, 3] / 1000.0] + [0.0] * 9,
                          solref=list(LOOP_SOLREF), solimp=list(COUPLING_SOLIMP))
    for c in art.couplings:
        if c.type == "linkage":  # moved by the loop (the connect above), no ratio
            continue
        j1, j2, a0, a1 = equality_form(c)
        spec.add_equality(name=c.name, type=mujoco.mjtEq.mjEQ_JOINT, name1=j1,
                          name2=j2, data=[a0, a1, 0, 0, 0] + [0] * 7,
                          solref=list(COUPLING_SOLREF), solimp=list(COUPLING_SOLIMP))
    for a, b in excluded:
        spec.add_exclude(bodyname1=a, bodyname2=b)
    spec.assets = dict(assets)
    return MjcfBuild(spec, assets, art.free, list(art.wheels), floor_z, list(excluded))


def build_mjcf(model: CompiledModel, *, art: Articulation | None = None,
               masses: dict[str, MassProps] | None = None) -> MjcfBuild:
    """The scene for ``model`` and its articulation ``art`` (default :func:`articulate`): a first
    compile measures joint-space inertia (for servo gains) and hull overlaps at rest (for
    collision excludes); the second is the result. Base, wheels and drives are ``art``'s
    (``art.welded()`` gives the battery's welded sweep scene)."""
    import mujoco
    art = art or articulate(model)
    masses = masses or link_masses(model, art)
    floor_z = lowest_z(model, [p.name for p in model.parts]) / 1000.0
    first = _build(model, art, masses, floor_z, None, [])
    m = first.spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    mass_matrix = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, mass_matrix)
    gains: dict[str, float] = {}
    reflected = _reflected(art, m, mass_matrix)
    for j in art.joints:
        if j.kind.ball:  # the largest of its three diagonal inertias
            jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j.name)
            dof = int(m.jnt_dofadr[jid])
            gains[j.name] = float(np.max(np.diag(mass_matrix)[dof:dof + 3]))
            continue
        for jd in j.dofs():
            dof = int(m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, jd.name)])
            mjj = float(mass_matrix[dof, dof]) + reflected.get(jd.name, 0.0)
            if jd.drive == "velocity" and jd.name in reflected and jd.name not in art.wheels:
                # a coupling's head: a stall gain far above its inertia would be integrated
                # implicitly while the coupling's equality is solved against the bare inertia,
                # and the driven joint would jump off its ratio (see the module docstring)
                gains[jd.name] = 2 * SERVO_ZETA * mjj * SERVO_OMEGA
            elif jd.drive == "velocity":  # velocity servo: stall torque = effort at full speed
                gains[jd.name] = max(2 * SERVO_ZETA * mjj * SERVO_OMEGA,
                                     jd.effort / max(jd.velocity, MIN_VELOCITY))
            else:
                gains[jd.name] = mjj
    excluded: set[tuple[str, str]] = set()
    for c in d.contact[: d.ncon]:
        b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
        if b1 == 0 or b2 == 0 or b1 == b2:
            continue
        n1, n2 = m.body(b1).name, m.body(b2).name
        excluded.add(tuple(sorted((n1, n2))))  # type: ignore[arg-type]  # always a pair of two names
    if excluded:
        log.info("excluding hull contacts at rest: %s", sorted(excluded))
    return _build(model, art, masses, floor_z, gains, sorted(excluded))


def mjcf_files(model: CompiledModel, *, art: Articulation | None = None,
               masses: dict[str, MassProps] | None = None) -> dict[str, bytes]:
    """``{"model.xml": bytes}`` plus the meshes under :data:`MESHDIR` it references."""
    b = build_mjcf(model, art=art, masses=masses)
    b.spec.compile()
    out = {"model.xml": _balanced(b.spec.to_xml()).encode()}
    for name, data in b.assets.items():
        out[f"{MESHDIR}/{name}"] = data
    return out
