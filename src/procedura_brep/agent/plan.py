"""The assembly plan: the ordered part list the staged build works through.

The plan call returns one JSON object (in a fenced block or bare)::

    {"parts": [
      {"name": "chassis", "detail": "silhouette",
       "description": "600 x 400 x 120 mm box frame, the root; wheels hang below its sides",
       "mates": []},
      {"name": "wheel_fl", "detail": "major",
       "description": "160 mm wheel, 60 mm wide, front left, axle along Y",
       "mates": [{"partner": "chassis", "type": "revolute", "nominal": "axle_d"}]}
    ]}

It is parsed strictly (:func:`parse_plan`): every problem is collected and reported at once, so
a retry can fix them all. Part names are snake_case and unique, details are the three levels,
each mate names an earlier part, a mate type of the vocabulary and a snake_case param name for
its nominal; the first part is the root and has no mates, every other part has at least one.
Parts whose mates point forward are moved after their partners (a stable topological order);
a mate cycle is an error. Mirror pairs stay separate parts (``wheel_l``, ``wheel_r``): an entry
whose name says it stands for several (``wheel_pair``, ``both_arms``) is an error.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any, Literal

from ..errors import ProceduraError

Detail = Literal["silhouette", "major", "sub"]
DETAILS: tuple[str, ...] = ("silhouette", "major", "sub")
NAME_RE = re.compile(r"[a-z][a-z0-9_]{0,62}")
_JSON_FENCE_RE = re.compile(r"```(?:json|JSON)?[ \t]*\n(.*?)```", re.S)
# A name that stands for several physical parts: "wheel_pair", "both_wheels", "bolt_set".
_MANY_RE = re.compile(r"(^|_)(pair|pairs|both|set|all)(_|$)")
MAX_PARTS = 200


class PlanError(ProceduraError):
    """A plan reply that cannot be used; ``problems`` lists every issue found (for the retry)."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        head = problems[0] if len(problems) == 1 else f"{len(problems)} problems: " + "; ".join(problems)
        super().__init__(f"plan: {head}")


@dataclass(frozen=True)
class PlannedMate:
    """A mate of a planned part to an earlier one: the partner part, the type, the nominal, and
    whether the compiler builds its features (``features=False``: frames and placement only,
    the parts model their contact themselves, as a long slide's rail and blocks do)."""

    partner: str
    type: str
    nominal: str
    features: bool = True

    def as_dict(self) -> dict[str, Any]:
        row: dict[str, Any] = {"partner": self.partner, "type": self.type, "nominal": self.nominal}
        if not self.features:
            row["features"] = False
        return row

    def text(self) -> str:
        """``revolute, nominal pin_d`` (``, features=False`` when the compiler builds none)."""
        return f"{self.type}, nominal {self.nominal}" + ("" if self.features else ", features=False")


@dataclass(frozen=True)
class PlannedCoupling:
    """The driven part's joint (its first mate) follows the driver part's (the driver's first
    mate) through a transmission of ``type`` (``program.couplings.SPECS``)."""

    driver: str
    type: str

    def as_dict(self) -> dict[str, Any]:
        return {"driver": self.driver, "type": self.type}


@dataclass(frozen=True)
class PlannedPart:
    """One part of the plan."""

    name: str
    detail: Detail
    description: str
    mates: tuple[PlannedMate, ...] = ()
    couple: PlannedCoupling | None = None

    @property
    def partners(self) -> tuple[str, ...]:
        return tuple(m.partner for m in self.mates)

    def as_dict(self) -> dict[str, Any]:
        row: dict[str, Any] = {"name": self.name, "detail": self.detail,
                               "description": self.description, "mates": [m.as_dict() for m in self.mates]}
        if self.couple is not None:
            row["couple"] = self.couple.as_dict()
        return row


@dataclass(frozen=True)
class Plan:
    """The ordered part list (a topological order of the mate graph; the root first)."""

    parts: tuple[PlannedPart, ...]
    notes: tuple[str, ...] = field(default=(), compare=False)  # what parsing repaired (reorders)

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parts]

    def part(self, name: str) -> PlannedPart:
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(name)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def children(self, name: str) -> list[str]:
        """Parts that mate to ``name``."""
        return [p.name for p in self.parts if name in p.partners]

    def as_dict(self) -> dict[str, Any]:
        return {"parts": [p.as_dict() for p in self.parts]}

    def to_json(self) -> str:
        return json.dumps(self.as_dict(), indent=2, ensure_ascii=False) + "\n"


def _json_object(text: str) -> Any:
    """The JSON object of a reply: a fenced block, or the outermost braces of the text."""
    candidates = [m.group(1) for m in _JSON_FENCE_RE.finditer(text)] + [text.strip()]
    for open_, close in ("{}", "[]"):
        lo, hi = text.find(open_), text.rfind(close)
        if lo >= 0 and hi > lo:
            candidates.append(text[lo:hi + 1])
    if not any(c.startswith(("{", "[")) for c in candidates):
        raise PlanError(["the reply holds no JSON object: answer with one ```json block "
                         "{\"parts\": [...]}"])
    last: json.JSONDecodeError | None = None
    for c in candidates:
        try:
            return json.loads(c)
        except json.JSONDecodeError as exc:
            last = exc
    assert last is not None
    raise PlanError([f"the JSON does not parse: {last.msg} at line {last.lineno} column {last.colno}"])


def parse_plan(text: str | dict[str, Any], *, mate_types: tuple[str, ...] | None = None) -> Plan:
    """Parse and check a plan reply.

    Args:
        text: the reply text (or the already-decoded object).
        mate_types: the accepted mate type names (default: the vocabulary's).

    Raises:
        PlanError: with every problem found, each naming the part and the field.
    """
    if mate_types is None:
        from ..mates import TYPES
        mate_types = tuple(TYPES)
    data = _json_object(text) if isinstance(text, str) else text
    if isinstance(data, list):
        data = {"parts": data}
    if not isinstance(data, dict) or not isinstance(data.get("parts"), list):
        raise PlanError(['expected an object {"parts": [...]} with a list of parts'])
    rows = data["parts"]
    problems: list[str] = []
    if not rows:
        raise PlanError(["the plan has no parts"])
    if len(rows) > MAX_PARTS:
        raise PlanError([f"the plan has {len(rows)} parts; at most {MAX_PARTS}"])
    parts: list[PlannedPart] = []
    seen: set[str] = set()
    for i, row in enumerate(rows, start=1):
        where = f"part {i}"
        if not isinstance(row, dict):
            problems.append(f"{where}: expected an object with name, detail, description, mates")
            continue
        name = row.get("name")
        if not isinstance(name, str) or not NAME_RE.fullmatch(name):
            problems.append(f"{where}: name {name!r} must be snake_case ([a-z][a-z0-9_]*, at most 63 chars)")
            continue
        where = f"part {name}"
        if name in seen:
            problems.append(f"{where}: the name is used twice; every part needs its own name "
                            "(mirror pairs are two parts, e.g. {name}_l and {name}_r)".replace("{name}", name))
            continue
        seen.add(name)
        detail = row.get("detail", "major")
        if detail not in DETAILS:
            problems.append(f"{where}: detail {detail!r} must be one of {', '.join(DETAILS)}")
        desc = row.get("description", "")
        if not isinstance(desc, str) or len(desc.strip()) < 8:
            problems.append(f"{where}: give a description that fixes its size, aspect and pose "
                            "against its neighbours")
            desc = str(desc)
        if _MANY_RE.search(name):
            problems.append(f"{where}: one entry stands for several parts; list each physical part "
                            "separately (mirror pairs too: wheel_l and wheel_r)")
        mates: list[PlannedMate] = []
        raw_mates = row.get("mates", [])
        if not isinstance(raw_mates, list):
            problems.append(f"{where}: mates must be a list")
            raw_mates = []
        for k, m in enumerate(raw_mates, start=1):
            if not isinstance(m, dict):
                problems.append(f"{where} mate {k}: expected an object with partner, type, nominal")
                continue
            partner, mtype, nominal = m.get("partner"), m.get("type"), m.get("nominal")
            feats = m.get("features", True)
            bad = False
            if not isinstance(feats, bool):
                problems.append(f"{where} mate {k}: features must be true or false, not {feats!r}")
                bad = True
            if not isinstance(partner, str) or not NAME_RE.fullmatch(partner):
                problems.append(f"{where} mate {k}: partner {partner!r} is not a part name")
                bad = True
            elif partner == name:
                problems.append(f"{where} mate {k}: a part cannot mate to itself")
                bad = True
            if mtype not in mate_types:
                problems.append(f"{where} mate {k}: type {mtype!r} is not a mate type; use one of "
                                f"{', '.join(mate_types)}")
                bad = True
            if not isinstance(nominal, str) or not NAME_RE.fullmatch(nominal):
                problems.append(f"{where} mate {k}: nominal {nominal!r} must be a param name "
                                "(snake_case), never a number")
                bad = True
            if not bad:
                mates.append(PlannedMate(partner, mtype, nominal, feats))
        couple = _couple(row.get("couple"), where, problems)
        parts.append(PlannedPart(name, detail if detail in DETAILS else "major", desc.strip(),
                                 tuple(mates), couple))
    names = {p.name for p in parts}
    for p in parts:
        for m in p.mates:
            if m.partner not in names:
                problems.append(f"part {p.name}: mate partner {m.partner!r} is not in the plan")
    problems += _coupling_problems(parts)
    if problems:
        raise PlanError(problems)
    ordered, notes = topological(parts)
    pos = {p.name: i for i, p in enumerate(ordered)}
    late = [p for p in ordered if p.couple is not None and pos[p.couple.driver] > pos[p.name]]
    if late:
        raise PlanError([f"part {p.name}: its driver {p.couple.driver!r} must come before it "  # type: ignore[union-attr]
                         f"(list the driver first)" for p in late])
    root = ordered[0]
    if root.mates:
        raise PlanError([f"part {root.name}: the root (first part) mates to nothing"])
    unmated = [p.name for p in ordered[1:] if not p.mates]
    if unmated:
        raise PlanError([f"part {n}: every part but the root needs a mate to an earlier part"
                         for n in unmated])
    return Plan(tuple(ordered), tuple(notes))


def _couple(raw: Any, where: str, problems: list[str]) -> PlannedCoupling | None:
    """A part's ``"couple"`` entry (absent: None); problems are appended."""
    if raw is None:
        return None
    from ..program.couplings import SPECS
    if not isinstance(raw, dict):
        problems.append(f'{where}: couple must be an object {{"driver": "<part>", "type": "gear"}}')
        return None
    driver, ctype = raw.get("driver"), raw.get("type")
    ok = True
    if not isinstance(driver, str) or not NAME_RE.fullmatch(driver):
        problems.append(f"{where}: couple driver {driver!r} is not a part name")
        ok = False
    if ctype not in SPECS:
        problems.append(f"{where}: couple type {ctype!r} is not one of {', '.join(SPECS)}")
        ok = False
    return PlannedCoupling(driver, ctype) if ok else None  # type: ignore[arg-type]  # checked above


def _coupling_problems(parts: list[PlannedPart]) -> list[str]:
    """Each coupling's driver is another part of the plan, and both first mates are kinematic."""
    from ..mates import TYPES
    by_name = {p.name: p for p in parts}
    out: list[str] = []

    def moves(p: PlannedPart) -> bool:
        return bool(p.mates) and p.mates[0].type in TYPES and TYPES[p.mates[0].type].kind != "static"
    for p in parts:
        c = p.couple
        if c is None:
            continue
        driver = by_name.get(c.driver)
        if driver is None or driver is p:
            out.append(f"part {p.name}: couple driver {c.driver!r} is not another part of the plan")
            continue
        for q, role in ((p, "driven"), (driver, "driver")):
            if not moves(q):
                out.append(f"part {p.name}: couple {c.type} needs the {role} part {q.name}'s first "
                           f"mate to be a kinematic joint (revolute, prismatic ...)")
    return out


def topological(parts: list[PlannedPart]) -> tuple[list[PlannedPart], list[str]]:
    """A stable topological order: each part after all its partners, otherwise in given order.

    Raises:
        PlanError: the mates form a cycle (naming its parts).
    """
    by_name = {p.name: p for p in parts}
    pos = {p.name: i for i, p in enumerate(parts)}
    placed: list[PlannedPart] = []
    done: set[str] = set()
    waiting = list(parts)
    while waiting:
        ready = next((p for p in waiting if all(q in done for q in p.partners)), None)
        if ready is None:
            raise PlanError([f"the mates form a cycle through {', '.join(p.name for p in waiting)}; "
                             "each part mates only to parts listed before it"])
        waiting.remove(ready)
        placed.append(ready)
        done.add(ready.name)
    notes = [f"moved {p.name} after its partner(s) {', '.join(q for q in p.partners if pos[q] > pos[p.name])}"
             for p in parts if any(pos[q] > pos[p.name] for q in p.partners if q in by_name)]
    return placed, notes
