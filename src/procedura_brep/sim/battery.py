"""The MuJoCo battery B0-B8 (docs/battery.md) over one exported bundle.

``run_battery(source)`` takes a :class:`CompiledModel` (the bundle is written first, to
``out_dir`` or a temporary directory; with ``exported=True`` the model's bundle already in
``out_dir`` is checked as it is, and program.py is never read) or a bundle directory holding
``program.py`` (compiled again, so the mate graph is the reference) and the exported files, which
are what gets checked. :func:`failures` turns a report into findings, one per failed check.

B0 model fidelity (``model.xml``) · B1 settle (``model.xml``) · B2 joint sweeps (root welded,
gravity off; exact-solid penetration sampled along every range, spherical cones included) · B3
rest-contact scan on exact solids · B4 wheeled mobility · B5 URDF re-import · B6 USD validation ·
B7 random-control smoke run · B8 transmission (each coupling's measured ratio, :mod:`.transmission`).
A failed check saves up to 8 frames of its phase under ``renders/sim/``.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..articulation import Articulation, articulate, link_masses
from ..config import TOL
from ..findings import Finding
from ..paths import program_name
from ..program.model import CompiledModel
from . import contact
from .dynamics import check_b1, check_b4, check_b7, sweep_joints
from .fidelity import check_b0, check_b5, check_b6
from .frames import render_frames
from .report import BatteryReport, CheckResult
from .transmission import check_b8

if TYPE_CHECKING:
    from .sweep import SweepHit

log = logging.getLogger(__name__)

ALL_CHECKS: tuple[str, ...] = ("B0", "B1", "B2", "B3", "B4", "B5", "B6", "B7", "B8")
#: The checks that read none of the bundle's files (the model and its articulation only): they
#: run while a forked child writes the bundle (:class:`_Export`; B3 in that child, after it).
FILELESS: tuple[str, ...] = ("B2", "B3")
#: Prefix of the temporary bundle directory used when no ``out_dir`` is given (removed after).
TEMP_PREFIX = "procedura-battery-"
#: The export formats the battery reads, and the file (relative) that shows each is there.
NEEDS: dict[str, str] = {"urdf": "urdf", "usd": "model.usda", "mjcf": "model.xml"}


class _Export:
    """The bundle's files being written in a forked child (:class:`procedura_brep.limited.
    Limited`) while this process runs B2, which reads no file: on two cores the export costs
    no wall time. With ``b3`` the child then runs B3 (the rest scan, which reads no file
    either) and sends its result back, so it too runs beside B2. :meth:`wait` returns once the
    files are there, with B3's result or None; a child that failed is not trusted with the
    error: the bundle is written again here (so a failure is raised exactly as the serial
    write raises it) and B3 is left to the caller."""

    def __init__(self, model: CompiledModel, root: Path, formats: tuple[str, ...],
                 art: Articulation, b3: bool = False) -> None:
        from ..limited import Limited
        self.model, self.root, self.formats, self.art, self.b3 = model, root, formats, art, b3
        self.wait_s = 0.0

        def write(send) -> dict[str, Any]:
            from ..export.bundle import write_bundle
            out: dict[str, Any] = {"files": sorted(write_bundle(model, root, formats=formats, art=art))}
            if b3:
                res, _ = _checked("B3", lambda: check_b3(model, art))
                out["B3"] = dataclasses.asdict(res)
            return out
        self._child: Any = Limited(write, stage="battery export")

    def wait(self) -> CheckResult | None:
        """Wait for the files; B3's result when the child ran it, else None."""
        from ..limited import ChildFailure
        t = time.perf_counter()
        child, self._child = self._child, None
        b3 = None
        if child is not None:
            try:
                got = child.collect()
                b3 = CheckResult(**got["B3"]) if "B3" in got else None
            except ChildFailure as exc:
                log.warning("the overlapped export failed (%s); writing the bundle here", exc)
                from ..export.bundle import write_bundle
                write_bundle(self.model, self.root, formats=self.formats, art=self.art)
        self.wait_s = time.perf_counter() - t
        return b3

    def close(self) -> None:
        """End the child if it still runs (an error or an interrupt in the checks)."""
        child, self._child = self._child, None
        if child is not None:
            child.close()


def _checked(cid: str, fn: Callable[[], CheckResult | tuple[CheckResult, list]]
             ) -> tuple[CheckResult, list]:
    """``(result, trajectory)`` of one check, timed; a check that raises is a failed check (a
    broken export), not a crash."""
    t = time.perf_counter()
    try:
        out = fn()
    except Exception as exc:
        log.exception("battery check %s crashed", cid)
        out = CheckResult(cid, cid, False, message=f"{type(exc).__name__}: {exc}")
    res, traj = (out if isinstance(out, tuple) else (out, []))
    res.seconds = time.perf_counter() - t
    return res, traj


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _load(source: CompiledModel | str | Path, out_dir: Path | None, exported: bool = False,
          art: Articulation | None = None, overlap: bool = False, b3: bool = False
          ) -> tuple[CompiledModel, Path, bool, Articulation | None, _Export | None]:
    """``(model, bundle root, whether the root is a temp dir this call created, the
    articulation, the export still being written or None)``. With ``overlap`` (and a second
    core), a bundle that must be written is written by a forked child (:class:`_Export`),
    which with ``b3`` runs B3 after it."""
    if isinstance(source, CompiledModel):
        from ..export.bundle import write_bundle
        temp = out_dir is None
        root = out_dir or Path(tempfile.mkdtemp(prefix=TEMP_PREFIX))
        missing = tuple(f for f, rel in NEEDS.items()
                        if not (exported and not temp and (root / rel).exists()))
        pending = None
        try:
            if missing and overlap and _cores() > 1:
                art = art or articulate(source)
                for part in source.parts:  # meshed once, before the fork: both sides need them
                    part.mesh()
                pending = _Export(source, root, missing, art, b3=b3)
            elif missing:
                write_bundle(source, root, formats=missing, art=art)
        except BaseException:
            if temp:
                shutil.rmtree(root, ignore_errors=True)
            raise
        return source, root, temp, art, pending
    path = Path(source)
    if path.is_file():  # a program file: compile, export next to out_dir
        from ..program import compile_source
        model = compile_source(path.read_text(), name=program_name(path))
        return _load(model, out_dir, art=art, overlap=overlap, b3=b3)
    program = path / "program.py"
    if not program.exists():
        raise FileNotFoundError(f"{path} has no program.py; pass a bundle directory written by "
                                f"`procedura-brep build` or a program file")
    from ..program import compile_source
    model = compile_source(program.read_text(), name=program_name(program))
    if not (path / "model.xml").exists():
        from ..export.bundle import write_bundle
        write_bundle(model, path, formats=("urdf", "usd", "mjcf"), art=art)
    return model, path, False, art, None


def _ball_traj(m, joint: str, direction_deg: float, tilt_rad: float) -> list[np.ndarray]:
    """qpos states tilting one ball joint from rest to the given tilt (for frames)."""
    import mujoco

    from .sweep import tilt_quat
    qadr = int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)])
    out = []
    for k in range(1, 9):
        q = m.qpos0.copy()
        q[qadr:qadr + 4] = tilt_quat(direction_deg, tilt_rad * k / 8)
        out.append(q)
    return out


def check_b2(model: CompiledModel, art, m) -> tuple[CheckResult, list[np.ndarray]]:
    """B2: every driven joint reaches >= 97% of its range, its child never leaves its parent by
    more than ``TOL.sweep_separation_m`` (MuJoCo sweep), and moving it adds no exact-solid
    interference thicker than ``TOL.sim_penetration_mm`` anywhere along its range (closed-form
    samples, :mod:`.sweep`; spherical joints tilted to half and full cone in 8 directions).
    The MuJoCo sweeps run first (:func:`.dynamics.sweep_joints`: independent joints together),
    then the exact ones (:func:`.sweep.sweep_all`: shared with a second process on a second
    core), each given the values its joint reached. A joint that a coupling drives is swept
    with the head of its chain (its row's ``swept_with``; a collision it causes is that head's
    finding); a joint a linkage moves is swept on its own range."""
    import mujoco

    from .sweep import sweep_all
    m.opt.gravity[:] = 0.0  # the sweep tests range and collisions; gravity is B1's business
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    m.geom_contype[floor] = m.geom_conaffinity[floor] = 0  # the root is welded: no floor
    # a coupled joint has no servo: it moves with its driver (the coupling's equality), and
    # battery B8 measures how; the exact sweep below moves it with the head of its chain
    swept = sweep_joints(m, art, [d.name for j in art.joints if not j.kind.ball for d in j.dofs()
                                  if not d.driver])
    # each joint's exact sweep, with the values MuJoCo reached (an overshoot is swept too)
    hits, booleans = sweep_all(model, art, list(art.joints),
                               {j.name: (swept[j.name]["qmin"], swept[j.name]["qmax"])
                                for j in art.joints if j.name in swept})
    rows, problems, worst_traj, unverified = {}, [], [], []
    worst_reach, worst_pen, worst_sep = 1.0, 0.0, 0.0
    for j in art.joints:
        if j.kind.ball:
            hit = hits[j.name]
            rows[j.name] = {"cone_deg": float(np.degrees(j.upper)),
                            "worst_direction_deg": hit.value[0] if hit.value else None,
                            "worst_tilt_deg": float(np.degrees(hit.value[1])) if hit.value else None,
                            **hit.as_dict()}
            worst_pen = max(worst_pen, hit.depth)
            if hit.stopped:
                unverified.append(_stopped(j.name, hit))
            if hit.depth > TOL.sim_penetration_mm:
                problems.append(f"spherical joint {j.name!r} {_driven(hit)}")
                if not worst_traj:
                    worst_traj = _ball_traj(m, j.name, *hit.value)
            continue
        reached = {d.name: swept[d.name] for d in j.dofs() if d.name in swept}
        r = reached[j.name] if j.name in reached else None
        hit = hits[j.name]
        pen = hit.depth
        if j.coupling is not None:
            rows[j.name] = {"driven_by": j.coupling.driver, **hit.as_dict()}
            if hit.swept_with:
                rows[j.name]["exact_sweep"] = (f"swept with its driver {hit.swept_with!r}: see that "
                                               f"joint's row")
        elif r:
            rows[j.name] = {**_reach_row(r), **hit.as_dict()}
        else:  # a cylindrical joint: one row per DOF for the drive, one for the exact sweep
            rows[j.name] = hit.as_dict()
            rows.update({n: _reach_row(x) for n, x in reached.items()})
        if not hit.swept_with:
            _why_no_samples(rows[j.name], hit)
        bad = False
        if hit.stopped:
            unverified.append(_stopped(j.name, hit))
        if pen > TOL.sim_penetration_mm:
            problems.append(f"joint {j.name!r} {_driven(hit)}")
            bad = True
        for name, x in reached.items():
            if x["reach"] < TOL.sweep_reach:
                problems.append(f"joint {name!r} reached {100 * x['reach']:.1f}% of its range "
                                f"(needs {100 * TOL.sweep_reach:.0f}%): {x['why']}")
                bad = True
            if x["separation_m"] > TOL.sweep_separation_m:
                problems.append(f"joint {name!r}: child separates {x['separation_m']:.3g} m from parent")
                bad = True
            if x["warnings"]:
                problems.append(f"joint {name!r}: MuJoCo warnings {x['warnings']}")
                bad = True
            if bad and not worst_traj:
                worst_traj = x["traj"]
            worst_reach = min(worst_reach, x["reach"])
            worst_sep = max(worst_sep, x["separation_m"])
        worst_pen = max(worst_pen, pen)
    measured = {"min_reach": worst_reach, "max_new_penetration_mm": worst_pen,
                "max_separation_m": worst_sep, "booleans": booleans, "joints": rows}
    limits = {"min_reach": TOL.sweep_reach, "max_new_penetration_mm": TOL.sim_penetration_mm,
              "max_separation_m": TOL.sweep_separation_m}
    message = "; ".join(problems) or f"{len(rows)} joints swept"
    if unverified:
        message += "; not verified: " + "; ".join(unverified)
    return CheckResult("B2", "joint sweeps", not problems, measured, limits, message,
                       unverified="; ".join(unverified)), worst_traj


def _reach_row(x: dict[str, Any]) -> dict[str, Any]:
    """The B2 row of one MuJoCo-driven DOF: its reach, where it got, and why it fell short
    (``why``/``cause`` are None when it reached ``TOL.sweep_reach``; ``ramp_s`` and
    ``ramp_needed_s``: the time the ramp gave its range and the time its velocity limit needs)."""
    return {k: x[k] for k in ("reach", "qmin", "qmax", "separation_m", "why", "cause", "ramp_s",
                              "ramp_needed_s")}


def _why_no_samples(row: dict[str, Any], hit: SweepHit) -> None:
    """Say in ``row`` (``samples_why``) why the exact sweep ``hit`` ran no pose: nothing of the
    moved subtree can come within reach of a fixed part along the range."""
    if hit.samples == 0 and not hit.stopped:
        row["samples_why"] = ("no pose needed an exact check: the envelope, extent, radial and surface-"
                              "cell prefilters ruled out every (moved, fixed) part pair, so no "
                              "moved part comes within reach of a fixed one along the range")


def _stopped(joint: str, hit: SweepHit) -> str:
    """What a sweep stopped at its boolean budget or its time bound leaves not verified (never
    a failure: the parts may merely touch)."""
    if hit.stopped_by == "time":
        return (f"joint {joint!r}: the exact sweep ran past its bound of {TOL.sweep_time_s:g} s "
                f"and stopped ({hit.stopped}): the rest of its range is not verified (config "
                f"TOL.sweep_time_s)")
    return (f"joint {joint!r}: the exact sweep spent its budget of {TOL.sweep_max_booleans} "
            f"booleans and stopped ({hit.stopped}): the rest of its range is not verified "
            f"(config TOL.sweep_max_booleans)")


def _driven(hit) -> str:
    """The B2 problem of a sweep that found a new interference: the pair, where they first
    meet, the deepest pose found, its volume and a point of it."""
    meet = f"; they meet at {hit.first_at}" if hit.first_at and hit.first_at != hit.at else ""
    where = (" (at (" + ", ".join(f"{x:.1f}" for x in hit.point) + ") mm)") if hit.point else ""
    return (f"drives {hit.pair[0]!r} {hit.depth:.3g} mm into {hit.pair[1]!r} at {hit.at}{where}, "
            f"{hit.volume:.3g} mm^3{meet} (limit {TOL.sim_penetration_mm} mm)")


def check_b3(model: CompiledModel, art) -> CheckResult:
    """B3: no two parts interpenetrate at rest beyond what a declared fit allows (exact solids).

    The scan is the interference gate's (:func:`procedura_brep.gates.interference.scan`): every
    pair of parts, in any links, with the same allowance (a mate's fit, between its own partners,
    within its feature region) and the same depth measure, so B3 fails exactly where the gate's
    ``interference`` or the mate gate's ``mate-penetration`` does.
    """
    rows = contact.rest_scan(model)
    bad = [r for r in rows if not r.allowed]
    worst = max(bad, key=lambda r: r.depth, default=None)
    measured = {"max_depth_mm": worst.depth if worst else 0.0,
                "pairs": [{**r.as_dict(), "link_a": art.part_link.get(r.a),
                           "link_b": art.part_link.get(r.b)} for r in rows]}
    msg = "; ".join(f"parts {r.a!r} (link {art.part_link.get(r.a)!r}) and {r.b!r} (link "
                    f"{art.part_link.get(r.b)!r}) interpenetrate {r.depth:.3g} mm (allowed "
                    f"{r.limit:.3g} mm)" for r in bad)
    unverified = "; ".join(f"parts {r.a!r} and {r.b!r}: {r.reason}" for r in rows if not r.exact)
    msg = msg or "no two parts interpenetrate at rest beyond their fits"
    if unverified:
        msg += f"; not verified: {unverified}"
    return CheckResult("B3", "rest-contact scan", not bad, measured,
                       {"max_depth_mm": worst.limit if worst else TOL.penetration_slack_mm},
                       msg, unverified=unverified)


def run_battery(source: CompiledModel | str | Path, *, out_dir: str | Path | None = None,
                checks: Iterable[str] | None = None, frames: bool = True,
                exported: bool = False, art: Articulation | None = None) -> BatteryReport:
    """Run the battery; never raises for a failing model (each check reports instead).

    Args:
        source: a CompiledModel, a bundle directory with ``program.py``, or a program file.
        out_dir: where a CompiledModel's bundle and failure frames go (default: the bundle
            directory itself; for a CompiledModel or program file, a temporary directory that is
            removed afterwards, so no frames are saved: the report's notes say so).
        checks: the ids to run (default all).
        frames: save up to 8 frames of a failing phase.
        exported: ``source`` is a CompiledModel whose bundle this process just wrote to
            ``out_dir``: check those files (only a format the battery needs and that is not
            there is written).
        art: the articulation the bundle was exported with (default: :func:`articulate` of
            the model); every check reads links, joints, wheels and the base from it.
    """
    wanted = tuple(c for c in ALL_CHECKS if checks is None or c in set(checks))
    model, root, temp, art, pending = _load(source, Path(out_dir) if out_dir else None, exported,
                                            art, overlap=bool(set(wanted) & set(FILELESS)),
                                            b3="B3" in wanted)
    try:
        return _run(model, root, wanted, frames and not temp, temp, art, pending)
    finally:
        if pending is not None:
            pending.close()
        if temp:
            shutil.rmtree(root, ignore_errors=True)


def failures(report: BatteryReport | dict) -> list[Finding]:
    """One error finding per failed check (code ``battery-B2`` ...), naming the check; a
    skipped check passes. Takes the report or its :meth:`~BatteryReport.as_dict`."""
    checks = report.get("checks", []) if isinstance(report, dict) else [c.as_dict() for c in report.checks]
    out = []
    for c in checks:
        if c.get("unverified") and not c.get("skipped"):
            out.append(Finding("not-verified", f"battery {c.get('id')} not verified: "
                                               f"{c['unverified']}", severity="warning"))
        if c.get("passed") or c.get("skipped"):
            continue
        label = f"{c.get('id')} ({c['name']})" if c.get("name") else str(c.get("id"))
        out.append(Finding(f"battery-{c.get('id')}", f"battery {label} failed: "
                                                     f"{c.get('message') or 'no message'}"))
    return out


def run_bundle(model: CompiledModel, root: str | Path, *, checks: Iterable[str] | None = None,
               frames: bool = True) -> BatteryReport:
    """:func:`run_battery` of an already compiled ``model`` over the bundle directory ``root``
    (written first when it has no ``model.xml``), as for a run directory."""
    root = Path(root)
    if not (root / "model.xml").exists():
        from ..export.bundle import write_bundle
        write_bundle(model, root, formats=("urdf", "usd", "mjcf"))
    return _run(model, root, tuple(c for c in ALL_CHECKS if checks is None or c in set(checks)),
                frames, False)


def _run(model: CompiledModel, root: Path, wanted: tuple[str, ...], frames: bool,
         temp: bool, art: Articulation | None = None, pending: _Export | None = None
         ) -> BatteryReport:
    """The checks of :func:`run_battery` over the bundle at ``root``; with ``pending`` (the
    bundle still being written) the checks that read no file (:data:`FILELESS`) run first, and
    the report lists every check in :data:`ALL_CHECKS` order all the same."""
    import mujoco

    from ..export.mjcf import build_mjcf
    art = art or articulate(model)
    masses = link_masses(model, art)
    report = BatteryReport([])
    if temp:
        report.notes.append("the bundle went to a temporary directory (removed), so no failure "
                            "frames were saved; give an output directory (simulate -o DIR) to keep them")

    def run(cid: str, fn: Callable[[], CheckResult | tuple[CheckResult, list]], mj=None,
            done: CheckResult | None = None) -> None:
        if cid not in wanted:
            return
        res, traj = (done, []) if done is not None else _checked(cid, fn)
        if not res.passed and frames and traj and mj is not None:
            res.frames = render_frames(mj, traj, root, f"{cid}")
            if not res.frames:
                report.notes.append(f"{cid}: frames could not be rendered (no GL context)")
        report.checks.append(res)
        report.timings[cid] = res.seconds

    def fileless(b3: bool = True) -> None:
        welded = None
        if "B2" in wanted:
            welded = build_mjcf(model, art=art.welded(), masses=masses).spec.compile()
        run("B2", lambda: check_b2(model, art, welded), welded)
        if b3:
            run("B3", lambda: check_b3(model, art))

    if pending is not None:
        fileless(b3=not pending.b3)
        done = pending.wait()
        report.timings["export_wait"] = pending.wait_s  # the export (and B3) outlasting B2
        if pending.b3:  # B3 ran in the export's child, or runs here if that child failed
            run("B3", lambda: check_b3(model, art), done=done)
    m_file = mujoco.MjModel.from_xml_path(str(root / "model.xml"))
    run("B0", lambda: check_b0(art, m_file))
    run("B1", lambda: check_b1(m_file, art), m_file)
    if pending is None:
        fileless()
    wheels = list(art.wheels)
    floor_z = float(m_file.geom("floor").pos[2])
    run("B4", lambda: check_b4(m_file, art, wheels, floor_z), m_file)
    run("B5", lambda: check_b5(art, masses, root / "urdf"))
    run("B6", lambda: check_b6(art, root / "model.usda"))
    run("B7", lambda: check_b7(m_file), m_file)
    run("B8", lambda: check_b8(m_file, art), m_file)
    order = {cid: k for k, cid in enumerate(ALL_CHECKS)}
    report.checks.sort(key=lambda c: order.get(c.id, len(order)))
    report.timings = {k: report.timings[k] for k in sorted(report.timings, key=lambda k: order.get(k, len(order)))}
    return report
