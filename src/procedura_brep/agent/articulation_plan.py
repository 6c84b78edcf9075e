"""The articulation planning call's reply, its evidence, and the rules its edits must meet.

The model sees the geometric evidence (:func:`evidence_text`: each part's surface-covariance
symmetry axis, the contact areas between parts, the mates with their world axes, the links and
joints they make now) and answers one JSON object (:func:`parse_articulation`)::

    {"links": [["base", "post"], ["arm"]],
     "joints": [{"mate": "arm_pivot", "limits": [-40, 40], "home": 0, "effort": 8,
                 "velocity": 2, "drive": "position"}],
     "promote": [{"mate": "cap_seat", "type": "revolute", "limits": null, "drive": "velocity"}],
     "base": "welded",
     "wheels": []}

``joints`` retunes kinematic mates (limits in deg for rotations, mm for slides; ``home``; ``effort``;
``velocity``; ``cone`` for spherical); ``promote`` turns a static mate into a revolute or
prismatic one, which :func:`promotion_refusal` allows only where the evidence supports it;
``drive`` must agree with the limits (``velocity`` exactly for a continuous turn). ``links``,
``base`` and ``wheels`` are optional: the mates and the evidence decide them (the request shows
them), so the model states them only where it reads the assembly differently, and a
disagreement is recorded as a finding, never applied. Parsing collects every problem at once.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..articulation import Articulation
from ..articulation.wheels import is_round_about
from ..config import TOL
from ..errors import ProceduraError
from ..mates.kinds import Motion
from ..mates.vocabulary import TYPES
from ..program.model import CompiledMate, CompiledModel
from ..text import did_you_mean

_FENCE_RE = re.compile(r"```(?:json)?\s*\n(.*?)```", re.S)
#: Options a joint or promotion entry may set (besides ``mate``, ``type`` and ``drive``).
JOINT_OPTIONS = ("limits", "home", "effort", "velocity", "cone")
#: The kinematic types a static mate may be promoted to.
PROMOTABLE = tuple(n for n, t in TYPES.items() if t.motion in (Motion.TURN, Motion.SLIDE))
PLAN_KEYS = ("links", "joints", "promote", "base", "wheels")
DRIVES = ("position", "velocity")
BASES = ("free", "welded")


class ArticulationPlanError(ProceduraError):
    """The reply is not a usable articulation plan; ``problems`` lists every reason."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("; ".join(problems))
        self.problems = problems


@dataclass(frozen=True)
class JointEdit:
    """One planned change of a mate: options to set, and a new type for a promotion."""

    mate: str
    options: dict[str, Any]
    drive: str | None = None
    promote_to: str | None = None


@dataclass
class ArticulationPlan:
    """A parsed articulation reply."""

    edits: list[JointEdit]
    base: str | None = None  # None: the reply leaves it to the tool
    links: list[list[str]] | None = None
    wheels: list[str] | None = None
    raw: dict[str, Any] = field(default_factory=dict)


def _json_object(text: str) -> Any:
    blocks = [m.group(1) for m in _FENCE_RE.finditer(text)]
    lo, hi = text.find("{"), text.rfind("}")
    for c in blocks + ([text[lo:hi + 1]] if 0 <= lo < hi else []):
        try:
            return json.loads(c)
        except json.JSONDecodeError:
            continue
    return None


def _number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _entry(item: Any, where: str, mates: dict[str, CompiledMate], promote: bool,
           problems: list[str], driven: dict[str, str] | None = None) -> JointEdit | None:
    if not isinstance(item, dict) or not isinstance(item.get("mate"), str):
        problems.append(f"{where}: each entry is an object with a \"mate\" name")
        return None
    name = item["mate"]
    allowed = {"mate", "drive", *JOINT_OPTIONS} | ({"type"} if promote else set())
    extra = sorted(set(item) - allowed)
    if extra:
        problems.append(f"{where} {name}: unknown key(s) {', '.join(extra)}; allowed: "
                        f"{', '.join(sorted(allowed))}")
    m = mates.get(name)
    if m is None:
        problems.append(f"{where}: no mate named {name!r}{did_you_mean(name, mates)}; mates: {', '.join(mates)}")
        return None
    if promote and m.kind != "static":
        problems.append(f"promote {name}: it is already kinematic ({m.type}); list it under joints")
    if not promote and m.kind != "kinematic":
        problems.append(f"joints {name}: it is a static {m.type} mate; list it under promote "
                        f"to make it move")
    new_type = item.get("type") if promote else None
    if promote and new_type not in PROMOTABLE:
        problems.append(f"promote {name}: type must be one of {', '.join(PROMOTABLE)}, got {new_type!r}")
    opts: dict[str, Any] = {}
    for key in JOINT_OPTIONS:
        if key not in item:
            continue
        v = item[key]
        if key == "limits":
            if v is not None and not (isinstance(v, list) and len(v) == 2 and all(map(_number, v))):
                problems.append(f"{where} {name}: limits is [lo, hi] (numbers) or null, got {v!r}")
                continue
            opts[key] = None if v is None else (float(v[0]), float(v[1]))
        elif not _number(v):
            problems.append(f"{where} {name}: {key} must be a number, got {v!r}")
        else:
            opts[key] = float(v)
    drive = item.get("drive")
    if drive is not None and driven and name in driven:
        problems.append(f"{where} {name}: it follows {driven[name]} through a coupling, so it gets "
                        f"no drive of its own (drive {driven[name]}); leave drive out")
    if drive is not None and drive not in DRIVES:
        problems.append(f"{where} {name}: drive must be one of {', '.join(DRIVES)}, got {drive!r}")
    jtype = new_type or m.type
    limits = opts["limits"] if "limits" in opts else m.options.get("limits")
    mtype = TYPES.get(jtype)
    kind = None if mtype is None else mtype.joint_kind({"limits": limits})
    if mtype is not None and mtype.needs_limits and limits is None:
        problems.append(f"{where} {name}: a {jtype} joint needs limits [lo, hi] in mm")
    if drive == "velocity" and not (kind is not None and kind.endless):
        problems.append(f"{where} {name}: a velocity drive is for a continuous turn (a revolute "
                        f"with limits null)")
    if drive == "position" and kind is not None and kind.endless:
        problems.append(f"{where} {name}: a position drive needs limits; give limits or drive "
                        f"\"velocity\"")
    return JointEdit(name, opts, drive, new_type)


def parse_articulation(text: str, model: CompiledModel) -> ArticulationPlan:
    """Read the articulation reply for ``model`` (a fenced JSON block or a bare object).

    Raises:
        ArticulationPlanError: with every problem found (for the retry message).
    """
    data = _json_object(text)
    if not isinstance(data, dict):
        raise ArticulationPlanError(['answer with one JSON object {"joints": [...], "promote": '
                                     '[...], "base": "free"|"welded", "links": [...], "wheels": [...]}'])
    problems: list[str] = []
    extra = sorted(set(data) - set(PLAN_KEYS))
    if extra:
        problems.append(f"unknown key(s) {', '.join(extra)}; keys: {', '.join(PLAN_KEYS)}")
    mates = {m.name: m for m in model.mates}
    driven = {c.driven: c.driver for c in model.couplings}
    edits: list[JointEdit] = []
    for key, promote in (("joints", False), ("promote", True)):
        items = data.get(key, [])
        if not isinstance(items, list):
            problems.append(f"{key} must be a list")
            continue
        for item in items:
            e = _entry(item, key, mates, promote, problems, driven)
            if e is not None:
                edits.append(e)
    seen: set[str] = set()
    for e in edits:
        if e.mate in seen:
            problems.append(f"mate {e.mate} is listed twice")
        seen.add(e.mate)
    base = data.get("base")
    if base is not None and base not in BASES:
        problems.append(f"base must be \"free\" or \"welded\", got {base!r}")
    parts = {p.name for p in model.parts}
    links = data.get("links")
    if links is not None and not (isinstance(links, list) and all(
            isinstance(lk, list) and all(isinstance(p, str) for p in lk) for lk in links)):
        problems.append("links is a list of part-name lists")
        links = None
    for p in sorted({p for lk in links or [] for p in lk} - parts):
        problems.append(f"links: no part named {p!r}")
    wheels = data.get("wheels")
    if wheels is not None and not (isinstance(wheels, list) and all(isinstance(w, str) for w in wheels)):
        problems.append("wheels is a list of mate names")
        wheels = None
    if problems:
        raise ArticulationPlanError(problems)
    return ArticulationPlan(edits, base, links, wheels, data)


def _round(sym: dict[str, Any], frame: np.ndarray, *, line: bool) -> bool:
    axis = frame[:3, 2] / np.linalg.norm(frame[:3, 2])
    if line:
        return is_round_about(sym, frame[:3, 3], axis)
    if sym.get("kind") != "axis" or sym.get("axis") is None:
        return False
    s = np.asarray(sym["axis"], float)
    return abs(float(s @ axis) / float(np.linalg.norm(s))) >= math.cos(math.radians(TOL.wheel_axis_deg))


def promotion_refusal(mate: CompiledMate, to: str, evidence: dict[str, Any]) -> str | None:
    """Why promoting ``mate`` to ``to`` is refused, or None when the evidence supports it.

    A revolute needs the child or the parent part to be round about the mate's axis line (its
    symmetry axis parallel to the mate frame's +Z within ``TOL.wheel_axis_deg`` and passing
    within ``TOL.wheel_centre_mm`` of the anchor: the wheel test); a prismatic needs a symmetry
    axis of either part parallel to the mate axis (a rod in a bore, a piston).
    """
    frame = np.asarray(mate.world_frame, float)
    syms = {n: evidence["parts"][n]["symmetry"] for n in (mate.child, mate.parent)
            if n in evidence.get("parts", {})}
    turn = TYPES[to].motion is Motion.TURN
    if any(_round(s, frame, line=turn) for s in syms.values()):
        return None
    kinds = ", ".join(f"{n}: {s.get('kind')}" for n, s in syms.items())
    need = ("round about the mate axis (a symmetry axis along it, through the anchor)"
            if turn else "a symmetry axis parallel to the mate axis")
    return (f"promote {mate.name} to {to} refused: neither {mate.child} nor {mate.parent} is "
            f"{need} (evidence {kinds})")


def _vec(v: Any) -> str:
    return "(" + ", ".join(f"{float(x):.3g}" for x in v) + ")"


def evidence_text(model: CompiledModel, evidence: dict[str, Any], art: Articulation | None) -> str:
    """The evidence, the mates and the current links and joints, as the model is shown them."""
    rows = ["## Symmetry (area-weighted surface covariance; an axis is a line through the point)"]
    for name, rec in evidence.get("parts", {}).items():
        s = rec["symmetry"]
        where = (f" axis {_vec(s['axis'])} through {_vec(s['point'])} mm" if s.get("axis") is not None
                 else "")
        rows.append(f"- {name}: {s.get('kind')}{where}")
    rows.append("## Contacts (area where two parts touch: flat faces, or a mate's bearing seat)")
    rows += [f"- {c['a']} / {c['b']}: {c['area_mm2']:.4g} mm^2"
             + (f" (bearing at {', '.join(c['mates'])})"
                if c.get("mates") and c.get("bearing_mm2", 0) >= c.get("face_mm2", 0) else "")
             for c in evidence.get("contacts", [])] or ["- none"]
    rows.append("## Mates (world anchor mm, world axis = the frame's +Z)")
    for m in model.mates:
        f = np.asarray(m.world_frame, float)
        opts = {k: v for k, v in m.options.items() if k in (*JOINT_OPTIONS, "angle_limits")}
        rows.append(f"- {m.name}: {m.type} ({m.kind}) child {m.child} parent {m.parent}, anchor "
                    f"{_vec(f[:3, 3])}, axis {_vec(f[:3, 2])}" + (f", {json.dumps(opts)}" if opts else ""))
    couplings = list(model.couplings)
    if couplings:
        rows.append("## Couplings (a driven joint follows its driver: plan limits for both, a "
                    "drive for the driver only; a revolute's limits lie within [-360, 360] deg, "
                    "so a driver that turns more than a turn over its follower's range, a lead "
                    "screw, turns continuously (limits null, drive velocity) and its follower's "
                    "limits bound it)")
        rows += [f"- {c.driven} follows {c.driver}: {c.type}, ratio {c.ratio:.6g}" for c in couplings]
    if art is not None:
        rows.append("## Links and joints now")
        rows += [f"- link {lk.name}: {', '.join(lk.parts)}" for lk in art.links]
        rows += [f"- joint {j.name}: {j.type}, {j.parent} -> {j.child}, drive {j.drive}" for j in art.joints]
        rows.append(f"- wheels (by evidence): {', '.join(art.wheels) or 'none'}; base: {art.base}")
    return "\n".join(rows)


__all__ = ["ArticulationPlan", "ArticulationPlanError", "JointEdit", "evidence_text",
           "parse_articulation", "promotion_refusal"]
