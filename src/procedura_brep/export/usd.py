"""OpenUSD export (``model.usda``): UsdPhysics articulation, Z-up, metres, kilograms.

Layout (flat links, as UsdPhysics expects for articulations)::

    /<model>                      Xform, default prim, PhysicsArticulationRootAPI
                                  (named Tf.MakeValidIdentifier(model.name))
      /Looks/<material>           UsdPreviewSurface per material used
      /<link>                     Xform at the link's world frame, RigidBodyAPI + MassAPI
        /<part>                   Mesh (exact visual, link-local), bound to its material
        /<part>__collision        Xform holding convex pieces (CollisionAPI + MeshCollisionAPI)
      /joints/<mate>              RevoluteJoint / PrismaticJoint / SphericalJoint, or for a
                                  cylindrical mate a generic (D6) Joint free only along and
                                  about X (the other four DOF locked by LimitAPI low > high),
                                  with transX and rotX drives
      /joints/<root link>__world  FixedJoint (body1 = root link, body0 empty = world), only when
                                  the articulation's base is ``welded``: the
                                  same fixed base as ``model.xml``; the ArticulationRootAPI on
                                  its ancestor ``/<model>`` makes it a fixed-base articulation

USD joint axes can only be X, Y or Z, so each joint frame is the mate frame rotated so that its
+X is the mate's +Z (``localRot0/1``, :data:`Z_TO_X`); the axis is ``"X"``. Revolute limits are
in degrees, prismatic in metres; every driven joint has a DriveAPI (angular or linear) of the kind
its ``drive`` says: ``position`` (stiffness, target position 0) or ``velocity`` (damping only,
target velocity 0).

A coupled joint (``couple(...)``) has no DriveAPI (its driver moves it; UsdPhysics has no
schema for a joint-to-joint ratio), and carries custom attributes in our namespace
(:data:`COUPLING_NS`): ``procedura:coupling:driver`` (a relationship to the driver joint's prim),
``:type`` (gear, rack_pinion, screw, belt), ``:ratio`` and ``:offset`` in the joints' USD units
(degrees for a revolute, metres for a prismatic: the units of their limits here), with
``q_driven = offset + ratio * q_driver`` counted from the authored pose. A linkage's cut joint
is written as its joint with ``physics:excludeFromArticulation = true`` (a loop closure), no
drive; the loop's other joints carry ``driver`` and ``type = "linkage"`` only (no ratio).
"""

from __future__ import annotations

import numpy as np

from ..articulation.mass import MassProps, link_masses
from ..articulation.tree import Articulation, articulate
from ..materials import Material, get
from ..program.model import CompiledModel
from .glb import srgb_to_linear
from .meshes import collision_pieces, part_mesh, to_local_m
from .mjcf import quat

#: Rotation taking the joint's X axis onto the mate frame's Z axis (R_y(-90 deg)).
Z_TO_X = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
#: Namespace of our custom attributes (UsdPhysics has no schema for them).
COUPLING_NS = "procedura:coupling"
#: Drive stiffness/damping written for position drives (per unit of effort).
DRIVE_STIFFNESS_PER_EFFORT = 10.0
DRIVE_DAMPING_PER_EFFORT = 1.0


def _quatf(r: np.ndarray):
    """Gf.Quatf of a rotation matrix (via :func:`.mjcf.quat`, (w, x, y, z))."""
    from pxr import Gf
    w, x, y, z = quat(r)
    return Gf.Quatf(w, Gf.Vec3f(x, y, z))


def _matrix(m_mm: np.ndarray):
    from pxr import Gf
    m = np.array(m_mm, dtype=float)
    m[:3, 3] /= 1000.0
    return Gf.Matrix4d(m.T.tolist())  # USD matrices are row-vector (transposed)


def _mesh(stage, path: str, mesh):
    from pxr import UsdGeom, Vt
    prim = UsdGeom.Mesh.Define(stage, path)
    prim.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(mesh.vertices.astype(np.float32)))
    prim.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(mesh.faces), 3, np.int32)))
    prim.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(mesh.faces.reshape(-1).astype(np.int32)))
    prim.CreateSubdivisionSchemeAttr("none")
    return prim


def _material(stage, root: str, m: Material):
    from pxr import Gf, Sdf, UsdShade
    name = m.name
    mat = UsdShade.Material.Define(stage, f"{root}/Looks/{name}")
    sh = UsdShade.Shader.Define(stage, f"{root}/Looks/{name}/PreviewSurface")
    sh.CreateIdAttr("UsdPreviewSurface")
    # UsdPreviewSurface colours are linear; the library's rgb is sRGB (as STEP and MTL take it)
    linear = srgb_to_linear(m.rgb)
    sh.CreateInput("diffuseColor", Sdf.ValueTypeNames.Color3f).Set(Gf.Vec3f(*map(float, linear)))
    sh.CreateInput("metallic", Sdf.ValueTypeNames.Float).Set(float(m.metalness))
    sh.CreateInput("roughness", Sdf.ValueTypeNames.Float).Set(float(m.roughness))
    mat.CreateSurfaceOutput().ConnectToSource(sh.ConnectableAPI(), "surface")
    return mat


def serial_usd() -> None:
    """Keep OpenUSD's work on the calling thread (``Work.SetConcurrencyLimit(1)``) in this
    process; call it before any stage is made, opened or validated.

    By default USD starts a pool of worker threads (TBB) the first time a stage is made (two
    here). This tool forks: the build's limited children, the overlapped export, a warm
    server's commands. A child forked after that pool started inherits its state without its
    threads, and the next stage it makes can wait on them for ever: in CI an export child spun
    in ``Usd.Stage.CreateInMemory()`` for eleven minutes, until killed, under a Ray bench worker
    whose earlier tasks had made and validated stages. A model's stage is a few hundred prims,
    so one thread costs nothing measurable. Setting it through the API prints nothing, unlike
    ``PXR_WORK_THREAD_LIMIT``, which prints a banner on every import."""
    from pxr import Work
    if Work.GetConcurrencyLimit() != 1:
        Work.SetConcurrencyLimit(1)


def usd_stage(model: CompiledModel, *, art: Articulation | None = None,
              masses: dict[str, MassProps] | None = None):
    """An in-memory Usd.Stage of the articulated model."""
    from pxr import Gf, Tf, Usd, UsdGeom, UsdPhysics, UsdShade
    serial_usd()
    art = art or articulate(model)
    masses = masses or link_masses(model, art)
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    root = f"/{Tf.MakeValidIdentifier(model.name)}"
    top = UsdGeom.Xform.Define(stage, root)
    stage.SetDefaultPrim(top.GetPrim())
    UsdPhysics.Scene.Define(stage, f"{root}/physicsScene")
    UsdPhysics.ArticulationRootAPI.Apply(top.GetPrim())
    mats = {n: _material(stage, root, get(n, model.materials)) for n in sorted({p.material for p in model.parts})}
    for lk in art.links:
        path = f"{root}/{lk.name}"
        x = UsdGeom.Xform.Define(stage, path)
        x.AddTransformOp().Set(_matrix(lk.frame))
        UsdPhysics.RigidBodyAPI.Apply(x.GetPrim())
        mp = masses[lk.name]
        mapi = UsdPhysics.MassAPI.Apply(x.GetPrim())
        w, v = mp.principal()
        mapi.CreateMassAttr(float(mp.mass))
        mapi.CreateCenterOfMassAttr(Gf.Vec3f(*[float(c) for c in mp.com]))
        mapi.CreateDiagonalInertiaAttr(Gf.Vec3f(*[float(c) for c in w]))
        mapi.CreatePrincipalAxesAttr(_quatf(v))
        for name in lk.parts:
            part = model.part(name)
            vis = _mesh(stage, f"{path}/{name}", to_local_m(part_mesh(part), lk.frame))
            UsdShade.MaterialBindingAPI.Apply(vis.GetPrim()).Bind(mats[part.material])
            col_root = UsdGeom.Xform.Define(stage, f"{path}/{name}__collision")
            for k, piece in enumerate(collision_pieces(part)):
                c = _mesh(stage, f"{col_root.GetPath()}/c{k}", to_local_m(piece, lk.frame))
                c.CreatePurposeAttr(UsdGeom.Tokens.guide)
                UsdPhysics.CollisionAPI.Apply(c.GetPrim())
                UsdPhysics.MeshCollisionAPI.Apply(c.GetPrim()).CreateApproximationAttr("convexHull")
    UsdGeom.Scope.Define(stage, f"{root}/joints")
    if not art.free:  # a welded base, as model.xml welds the root
        fixed = UsdPhysics.FixedJoint.Define(stage, f"{root}/joints/{art.root.name}__world")
        fixed.CreateBody1Rel().SetTargets([f"{root}/{art.root.name}"])
        # body0 empty = the world; the joint sits at the root link's origin, whose world pose
        # is the link frame
        pos0 = art.root.frame[:3, 3] / 1000.0
        fixed.CreateLocalPos0Attr(Gf.Vec3f(*[float(c) for c in pos0]))
        fixed.CreateLocalRot0Attr(_quatf(art.root.frame[:3, :3]))
        fixed.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
        fixed.CreateLocalRot1Attr(Gf.Quatf(1.0, Gf.Vec3f(0.0, 0.0, 0.0)))
    for j in art.joints:
        jpath = f"{root}/joints/{j.name}"
        kind = j.kind  # its schema: kind.usd (a cylindrical joint: a D6 joint, _cylindrical)
        if kind.compound:
            jp = _cylindrical(stage, jpath, j)
        else:
            jp = getattr(UsdPhysics, kind.usd).Define(stage, jpath)
            jp.CreateAxisAttr("X")
            if kind.ball:
                cone = float(np.degrees(j.upper))
                jp.CreateConeAngle0LimitAttr(cone)
                jp.CreateConeAngle1LimitAttr(cone)
            elif kind.slides:  # metres
                jp.CreateLowerLimitAttr(float(j.lower))
                jp.CreateUpperLimitAttr(float(j.upper))
            elif kind.limited:  # degrees
                jp.CreateLowerLimitAttr(float(np.degrees(j.lower)))
                jp.CreateUpperLimitAttr(float(np.degrees(j.upper)))
        _bodies(jp, art, root, j.parent, j.child, j.frame)
        if j.coupling is not None:  # moved by its driver: no drive of its own
            _coupling_attrs(jp.GetPrim(), j, art, f"{root}/joints")
        elif kind.compound:
            for dof, instance in zip(j.dofs(), ("transX", "rotX")):
                drive = UsdPhysics.DriveAPI.Apply(jp.GetPrim(), instance)
                drive.CreateTypeAttr("force")
                drive.CreateMaxForceAttr(float(dof.effort))
                drive.CreateDampingAttr(float(dof.effort * DRIVE_DAMPING_PER_EFFORT))
                if dof.drive == "velocity":
                    drive.CreateTargetVelocityAttr(0.0)
                else:
                    drive.CreateStiffnessAttr(float(dof.effort * DRIVE_STIFFNESS_PER_EFFORT))
                    drive.CreateTargetPositionAttr(0.0)
        elif kind.usd_drive is not None:
            drive = UsdPhysics.DriveAPI.Apply(jp.GetPrim(), kind.usd_drive)
            drive.CreateTypeAttr("force")
            drive.CreateMaxForceAttr(float(j.effort))
            if j.drive == "velocity":
                drive.CreateDampingAttr(float(j.effort * DRIVE_DAMPING_PER_EFFORT))
                drive.CreateTargetVelocityAttr(0.0)
            else:
                drive.CreateStiffnessAttr(float(j.effort * DRIVE_STIFFNESS_PER_EFFORT))
                drive.CreateDampingAttr(float(j.effort * DRIVE_DAMPING_PER_EFFORT))
                drive.CreateTargetPositionAttr(0.0)
    for cut in art.cuts:
        _cut_joint(stage, f"{root}/joints/{cut.name}", cut, art, root)
    return stage


def _cut_joint(stage, path: str, cut, art: Articulation, root: str) -> None:
    """A linkage's cut joint: its UsdPhysics joint, excluded from the articulation (a loop
    closure), undriven."""
    from pxr import UsdPhysics

    from ..mates.vocabulary import TYPES
    kind = TYPES[cut.type].joint_kind(cut.mate.options)
    jp = getattr(UsdPhysics, kind.usd).Define(stage, path)
    jp.CreateAxisAttr("X")
    jp.CreateExcludeFromArticulationAttr(True)
    _bodies(jp, art, root, cut.parent, cut.child, cut.frame)


def _bodies(jp, art: Articulation, root: str, parent: str, child: str, frame: np.ndarray) -> None:
    """A joint prim's two bodies (links ``parent`` and ``child`` under ``root``) and its frame
    ``frame`` (world, mm) in each link's frame (m; the joint's X along the frame's Z)."""
    from pxr import Gf
    jp.CreateBody0Rel().SetTargets([f"{root}/{parent}"])
    jp.CreateBody1Rel().SetTargets([f"{root}/{child}"])
    for body, setpos, setrot in ((parent, jp.CreateLocalPos0Attr, jp.CreateLocalRot0Attr),
                                 (child, jp.CreateLocalPos1Attr, jp.CreateLocalRot1Attr)):
        local = np.linalg.inv(art.link(body).frame) @ frame
        setpos(Gf.Vec3f(*[float(c) for c in local[:3, 3] / 1000.0]))
        setrot(_quatf(local[:3, :3] @ Z_TO_X))


def _coupling_attrs(prim, j, art: Articulation, joints: str) -> None:
    """``procedura:coupling:*`` on a driven joint's prim (USD units: deg and m)."""
    from pxr import Sdf
    c = j.coupling
    driver = art.joint(c.driver)
    usd = {True: 1.0, False: float(np.degrees(1.0))}  # SI -> USD unit: m stays, rad -> deg
    ratio = c.ratio * usd[j.kind.slides] / usd[driver.kind.slides]
    prim.CreateRelationship(f"{COUPLING_NS}:driver", custom=True).SetTargets([f"{joints}/{c.driver}"])
    values: tuple[tuple[str, object, object], ...] = (("type", Sdf.ValueTypeNames.Token, c.type),)
    if c.type != "linkage":  # a loop's joint follows the loop, at no constant ratio
        values += (("ratio", Sdf.ValueTypeNames.Double, float(ratio)),
                   ("offset", Sdf.ValueTypeNames.Double, float(c.offset * usd[j.kind.slides])))
    for key, vtype, value in values:
        prim.CreateAttribute(f"{COUPLING_NS}:{key}", vtype, custom=True).Set(value)


#: The four DOF a cylindrical joint locks (a limit with low > high locks a DOF in UsdPhysics).
LOCKED_BY_CYLINDRICAL = ("transY", "transZ", "rotY", "rotZ")


def _cylindrical(stage, path: str, j):
    """A generic (D6) PhysicsJoint free only along and about its X (the mate's Z): transY/Z and
    rotY/Z locked, transX limited in metres, rotX limited in degrees (free when the turn is)."""
    from pxr import UsdPhysics
    jp = getattr(UsdPhysics, j.kind.usd).Define(stage, path)
    prim = jp.GetPrim()
    for dof in LOCKED_BY_CYLINDRICAL:
        lim = UsdPhysics.LimitAPI.Apply(prim, dof)
        lim.CreateLowAttr(1.0)
        lim.CreateHighAttr(-1.0)
    lim = UsdPhysics.LimitAPI.Apply(prim, "transX")
    lim.CreateLowAttr(float(j.lower))
    lim.CreateHighAttr(float(j.upper))
    if j.turn_lower is not None:
        lim = UsdPhysics.LimitAPI.Apply(prim, "rotX")
        lim.CreateLowAttr(float(np.degrees(j.turn_lower)))
        lim.CreateHighAttr(float(np.degrees(j.turn_upper)))
    return jp


def usda_text(model: CompiledModel, *, art: Articulation | None = None,
              masses: dict[str, MassProps] | None = None) -> str:
    """``model.usda`` as text."""
    stage = usd_stage(model, art=art, masses=masses)  # keep alive: the layer is a weak pointer
    return stage.GetRootLayer().ExportToString()


def usd_joint_frames(stage) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{joint name: (world anchor m, world unit axis)}`` read back from a stage (via body0);
    joints anchored to the world (no body0, the fixed base) are left out."""
    from pxr import Usd, UsdGeom, UsdPhysics
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    for prim in stage.Traverse():
        if not prim.IsA(UsdPhysics.Joint):
            continue
        j = UsdPhysics.Joint(prim)
        targets = j.GetBody0Rel().GetTargets()
        if not targets:  # anchored to the world (the fixed base): not a mate
            continue
        body0 = stage.GetPrimAtPath(targets[0])
        world = np.array(cache.GetLocalToWorldTransform(body0)).T  # column-vector convention
        pos = np.array(j.GetLocalPos0Attr().Get(), dtype=float)
        q = j.GetLocalRot0Attr().Get()
        from scipy.spatial.transform import Rotation
        im = q.GetImaginary()
        r = Rotation.from_quat([im[0], im[1], im[2], q.GetReal()]).as_matrix()
        axis_name = prim.GetAttribute("physics:axis").Get() if prim.HasAttribute("physics:axis") else "X"
        local_axis = r[:, "XYZ".index(axis_name)]
        anchor = world[:3, :3] @ pos + world[:3, 3]
        axis = world[:3, :3] @ local_axis
        out[prim.GetName()] = (anchor, axis / np.linalg.norm(axis))
    return out
