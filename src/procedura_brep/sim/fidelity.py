"""Static checks: B0 model fidelity (MJCF), B5 URDF re-import, B6 USD validation.

Every check compares against the articulation derived from the mate graph (``mates.json``'s
world frames): joint anchors in metres and axes as unit vectors in the world.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np

from ..articulation.mass import MassProps
from ..articulation.tree import Articulation
from ..config import TOL
from ..mates.kinds import JOINT_KINDS, REVOLUTE
from .report import CheckResult

#: ``{joint type: MuJoCo joint type}`` of every kind exported as one MuJoCo joint.
MJ_TYPES = {k.name: k.mjcf for k in JOINT_KINDS.values() if k.mjcf is not None}


def angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two vectors, rad (robust near 0)."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def expected_frames(art: Articulation, world: np.ndarray | None = None
                    ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{joint: (anchor m, axis)}`` from the mate graph, optionally re-expressed in ``world``
    (a 4x4 mm frame, e.g. the URDF root); a cylindrical joint's ``__slide`` and ``__turn``
    share its anchor and axis."""
    inv = np.eye(4) if world is None else np.linalg.inv(world)
    out = {}
    for j in art.joints:
        f = inv @ j.frame
        out[j.name] = (f[:3, 3] / 1000.0, f[:3, 2] / np.linalg.norm(f[:3, 2]))
        if j.kind.compound:
            for d in j.dofs():
                out[d.name] = out[j.name]
    return out


def mj_joint_types(art: Articulation) -> dict[str, str]:
    """``{exported joint name: MuJoCo type}`` the mate graph asks for."""
    out = {}
    for j in art.joints:
        if j.kind.ball:
            out[j.name] = str(j.kind.mjcf)
        for d in j.dofs():
            out[d.name] = MJ_TYPES[d.type]
    return out


def compare_frames(art: Articulation, got: dict[str, tuple[np.ndarray, np.ndarray]],
                   expected: dict[str, tuple[np.ndarray, np.ndarray]]
                   ) -> tuple[float, float, str | None, str | None]:
    """(max anchor error m, max axis error rad, worst-anchor joint, worst-axis joint)."""
    da = dr = 0.0
    wa = wr = None
    spherical = {j.name for j in art.joints if j.kind.ball}
    for name, (anchor, axis) in expected.items():
        if name not in got:
            continue
        e = float(np.linalg.norm(got[name][0] - anchor))
        if e > da:
            da, wa = e, name
        if name not in spherical:
            r = angle(got[name][1], axis)
            if r > dr:
                dr, wr = r, name
    return da, dr, wa, wr


def mj_joint_frames(m) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{joint: (xanchor, xaxis)}`` of a compiled MjModel at qpos0 (free joints left out)."""
    import mujoco
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    out = {}
    for i in range(m.njnt):
        if m.jnt_type[i] == mujoco.mjtJoint.mjJNT_FREE:
            continue
        out[m.joint(i).name] = (np.array(d.xanchor[i]), np.array(d.xaxis[i]))
    return out


def _mj_type(m, i: int) -> str:
    import mujoco
    return {mujoco.mjtJoint.mjJNT_HINGE: "hinge", mujoco.mjtJoint.mjJNT_SLIDE: "slide",
            mujoco.mjtJoint.mjJNT_BALL: "ball", mujoco.mjtJoint.mjJNT_FREE: "free"}[int(m.jnt_type[i])]


def check_b0(art: Articulation, m) -> CheckResult:
    """B0: bodies = links, joints = kinematic mates (names and types), anchors and axes match."""
    import mujoco
    bodies = sorted(m.body(i).name for i in range(1, m.nbody))
    links = sorted(lk.name for lk in art.links)
    got_types = {m.joint(i).name: _mj_type(m, i) for i in range(m.njnt)
                 if m.jnt_type[i] != mujoco.mjtJoint.mjJNT_FREE}
    want_types = mj_joint_types(art)
    da, dr, wa, wr = compare_frames(art, mj_joint_frames(m), expected_frames(art))
    measured = {"bodies": len(bodies), "joints": len(got_types), "anchor_err_m": da,
                "axis_err_rad": dr}
    limits = {"bodies": len(links), "joints": len(want_types), "anchor_err_m": TOL.sim_anchor_m,
              "axis_err_rad": TOL.sim_axis_rad}
    problems = []
    if bodies != links:
        problems.append(f"bodies {bodies} != links {links}")
    if got_types != want_types:
        bad = sorted(k for k in set(got_types) | set(want_types) if got_types.get(k) != want_types.get(k))
        problems.append(f"joint mismatch at {', '.join(bad)}: MJCF {[got_types.get(k) for k in bad]}"
                        f" vs mates {[want_types.get(k) for k in bad]}")
    if da > TOL.sim_anchor_m:
        problems.append(f"joint {wa!r} anchor off by {da:.3g} m (limit {TOL.sim_anchor_m:g})")
    if dr > TOL.sim_axis_rad:
        problems.append(f"joint {wr!r} axis off by {math.degrees(dr):.3g} deg "
                        f"({dr:.3g} rad, limit {TOL.sim_axis_rad:g})")
    return CheckResult("B0", "model fidelity", not problems, measured, limits,
                       "; ".join(problems) or "MJCF bodies, joints, anchors and axes match the mates")


def _urdf_strict_types(art: Articulation) -> dict[str, str]:
    out = {}
    for j in art.joints:
        if j.kind.ball:  # the strict profile's three revolutes (see ..export.urdf)
            out.update({f"{j.name}__{a}": str(REVOLUTE.urdf) for a in "xyz"})
        else:
            out.update({d.name: str(d.kind.urdf) for d in j.dofs()})
    return out


def check_b5(art: Articulation, masses: dict[str, MassProps], urdf_dir: Path) -> CheckResult:
    """B5: the MuJoCo-profile URDF re-imports with the same joints, axes and masses; the strict
    profile passes yourdfpy validation (and ``check_urdf`` when installed)."""
    import mujoco
    import yourdfpy

    from ..export.urdf import ROBOT_FILES
    problems: list[str] = []
    measured: dict[str, object] = {}
    m = mujoco.MjModel.from_xml_path(str(urdf_dir / ROBOT_FILES["mujoco"]))
    got_types = {m.joint(i).name: _mj_type(m, i) for i in range(m.njnt)}
    want_types = mj_joint_types(art)
    if got_types != want_types:
        bad = sorted(k for k in set(got_types) | set(want_types) if got_types.get(k) != want_types.get(k))
        problems.append(f"mujoco-profile joint mismatch at {', '.join(bad)}: URDF "
                        f"{[got_types.get(k) for k in bad]} vs mates {[want_types.get(k) for k in bad]}")
    da, dr, wa, wr = compare_frames(art, mj_joint_frames(m), expected_frames(art, art.root.frame))
    mass_err, worst = 0.0, None
    for lk in art.links:
        bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, lk.name)
        if bid < 0:
            problems.append(f"link {lk.name!r} missing after URDF import")
            continue
        e = abs(float(m.body_mass[bid]) - masses[lk.name].mass) / masses[lk.name].mass
        if e > mass_err:
            mass_err, worst = e, lk.name
    measured.update(anchor_err_m=da, axis_err_rad=dr, mass_rel_err=mass_err)
    if da > TOL.sim_anchor_m:
        problems.append(f"joint {wa!r} anchor off by {da:.3g} m after URDF import")
    if dr > TOL.sim_axis_rad:
        problems.append(f"joint {wr!r} axis off by {dr:.3g} rad after URDF import")
    if mass_err > TOL.sim_mass_rel:
        problems.append(f"link {worst!r} mass off by {mass_err:.3g} (relative) after URDF import")
    strict = urdf_dir / ROBOT_FILES["strict"]
    u = yourdfpy.URDF.load(str(strict), build_scene_graph=True, load_meshes=False)
    valid = bool(u.validate())
    measured["yourdfpy_valid"] = valid
    if not valid:
        problems.append("strict URDF fails yourdfpy validation")
    problems.extend(_mimic_problems(art, u, m))
    measured["mimics"] = sum(1 for j in u.joint_map.values() if j.mimic is not None)
    st_types = {name: j.type for name, j in u.joint_map.items()}
    want_strict = _urdf_strict_types(art)
    if st_types != want_strict:
        bad = sorted(k for k in set(st_types) | set(want_strict) if st_types.get(k) != want_strict.get(k))
        problems.append(f"strict-profile joint type mismatch at {', '.join(bad)}: URDF "
                        f"{[st_types.get(k) for k in bad]} vs mates {[want_strict.get(k) for k in bad]}")
    tool = shutil.which("check_urdf")
    if tool:
        r = subprocess.run([tool, str(strict)], capture_output=True, text=True, timeout=60)
        measured["check_urdf_rc"] = r.returncode
        if r.returncode != 0:
            problems.append(f"check_urdf failed: {r.stderr.strip()[:200]}")
    else:
        measured["check_urdf_rc"] = None
    limits = {"anchor_err_m": TOL.sim_anchor_m, "axis_err_rad": TOL.sim_axis_rad,
              "mass_rel_err": TOL.sim_mass_rel, "yourdfpy_valid": True, "check_urdf_rc": 0}
    return CheckResult("B5", "URDF re-import", not problems, measured, limits,
                       "; ".join(problems) or "URDF re-imports with the same joints, axes, masses")


def _mimic_problems(art: Articulation, u, m) -> list[str]:
    """Every coupled joint carries its ``<mimic>`` (the chain's head, the ratio product) in the
    strict URDF, and MuJoCo's import of the mujoco profile turned each into an equality."""
    ratios = [c for c in art.couplings if c.type != "linkage"]  # a loop's joints mimic nothing
    want = {c.driven: art.root_driver(c.driven) for c in ratios}
    got = {n: (j.mimic.joint, float(j.mimic.multiplier), float(j.mimic.offset or 0.0))
           for n, j in u.joint_map.items() if j.mimic is not None}
    out = []
    for name in sorted(set(want) | set(got)):
        w, g = want.get(name), got.get(name)
        if w is None or g is None or g[0] != w[0] or not np.isclose(g[1], w[1], rtol=1e-9, atol=0) \
                or not np.isclose(g[2], w[2], rtol=0, atol=1e-12):
            out.append(f"URDF joint {name!r}: mimic {g} where the couplings say {w}")
    if int(m.neq) != len(ratios):
        out.append(f"the mujoco-profile URDF imports with {int(m.neq)} equality constraints; the "
                   f"model has {len(ratios)} ratio couplings")
    return out


#: Validators B6 runs (every registered physics validator plus stage metadata).
def _validator_names() -> list[str]:
    from pxr import UsdValidation
    reg = UsdValidation.ValidationRegistry()
    return [md.name for md in reg.GetAllValidatorMetadata()
            if md.name.startswith(("usdPhysicsValidators:", "usdGeomValidators:StageMetadata"))]


def check_b6(art: Articulation, usda: Path) -> CheckResult:
    """B6: UsdValidation physics validators report 0 errors; joint frames agree; one
    articulation root."""
    from pxr import Usd, UsdPhysics, UsdValidation

    from ..export.usd import serial_usd, usd_joint_frames
    serial_usd()  # before the stage is opened and validated (fork safety: see serial_usd)
    stage = Usd.Stage.Open(str(usda))
    names = _validator_names()
    reg = UsdValidation.ValidationRegistry()
    ctx = UsdValidation.ValidationContext(reg.GetOrLoadValidatorsByName(names))
    errors = [e for e in ctx.Validate(stage)
              if e.GetType() == UsdValidation.ValidationErrorType.Error]
    roots = [p for p in stage.Traverse() if p.HasAPI(UsdPhysics.ArticulationRootAPI)]
    frames = usd_joint_frames(stage)
    da, dr, wa, wr = compare_frames(art, frames, expected_frames(art))
    problems = [f"{e.GetValidator().GetMetadata().name if e.GetValidator() else 'validator'}: "
                f"{e.GetMessage()[:160]}" for e in errors[:5]]
    missing = sorted(set(j.name for j in art.joints) - set(frames))
    if missing:
        problems.append(f"joints missing in USD: {', '.join(missing)}")
    if len(roots) != 1:
        problems.append(f"{len(roots)} ArticulationRootAPI prims (need exactly 1)")
    if da > TOL.sim_anchor_m:
        problems.append(f"joint {wa!r} anchor off by {da:.3g} m in USD")
    if dr > TOL.sim_axis_rad:
        problems.append(f"joint {wr!r} axis off by {dr:.3g} rad in USD")
    measured = {"validation_errors": len(errors), "articulation_roots": len(roots),
                "anchor_err_m": da, "axis_err_rad": dr, "validators": len(names)}
    limits = {"validation_errors": 0, "articulation_roots": 1, "anchor_err_m": TOL.sim_anchor_m,
              "axis_err_rad": TOL.sim_axis_rad}
    return CheckResult("B6", "USD validation", not problems, measured, limits,
                       "; ".join(problems) or "USD physics validators pass; joint frames agree")


def bundle_joint_frames(root: Path, art: Articulation
                        ) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """World joint frames ``{format: {joint: (anchor m, unit axis)}}`` read back from a bundle.

    Formats: ``mjcf`` (``model.xml``), ``urdf-mujoco`` and ``urdf-strict`` (``urdf/``, re-expressed
    in the world through the root link's frame), ``usd`` (``model.usda``). In ``urdf-strict`` a
    spherical joint appears as its three revolutes ``<joint>__x|y|z`` (axes: the joint frame's
    X, Y, Z); every other format uses the mate names. Compare with :func:`expected_frames`.
    """
    import mujoco
    import yourdfpy
    from pxr import Usd

    from ..export.urdf import ROBOT_FILES
    from ..export.usd import serial_usd, usd_joint_frames
    serial_usd()  # before the stage is opened (fork safety: see serial_usd)
    base = np.array(art.root.frame, dtype=float)
    base[:3, 3] /= 1000.0

    def world(frames: dict[str, tuple[np.ndarray, np.ndarray]]):
        return {k: (base[:3, :3] @ a + base[:3, 3], base[:3, :3] @ x) for k, (a, x) in frames.items()}

    out = {"mjcf": mj_joint_frames(mujoco.MjModel.from_xml_path(str(root / "model.xml"))),
           "urdf-mujoco": world(mj_joint_frames(mujoco.MjModel.from_xml_path(
               str(root / "urdf" / ROBOT_FILES["mujoco"])))),
           "usd": usd_joint_frames(Usd.Stage.Open(str(root / "model.usda")))}
    u = yourdfpy.URDF.load(str(root / "urdf" / ROBOT_FILES["strict"]), load_meshes=False)
    strict = {}
    for name, j in u.joint_map.items():
        t = u.get_transform(j.child, u.base_link)
        axis = t[:3, :3] @ np.asarray(j.axis, dtype=float)
        strict[name] = (t[:3, 3], axis / np.linalg.norm(axis))
    out["urdf-strict"] = world(strict)
    return out
