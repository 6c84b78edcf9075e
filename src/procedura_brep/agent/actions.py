"""The fixer's action protocol and the invariants of the refine loop, enforced in code.

The fixer answers every turn with one JSON object naming one action (provider-neutral: no tool
calling API is needed)::

    {"action": "render", "views": ["iso_ne", "front", "left"]}      1-20 names from the catalog
    {"action": "render", "close_up": "wheel_lr"}                     a part or a mate
    {"action": "diagnose"}                                           the separate critic call
    {"action": "edit_part", "part": "wheel_lr", "reply": "## params ... ## mates ..."}
    {"action": "set_param", "name": "wheel_d", "value": 140}
    {"action": "add_part", "name": "lead_screw", "what": "12 mm lead screw, 600 mm long, along Y",
     "mates_to": "frame", "type": "revolute", "nominal": "screw_d"}
    {"action": "compile"}
    {"action": "check_connectivity"}
    {"action": "finish", "verdict": "ok" | "give_up", "reason": "..."}

:class:`RefineSession` executes them against a :class:`Workbench` (the real one renders, calls
the critic, splices and gates; tests use fakes) and holds the invariants of the paper's refine
loop (section 3.4):

- a successful ``diagnose`` sets a one-shot latch; exactly one applied edit (``edit_part``,
  ``set_param``, ``add_part`` or a rebuild) consumes it; a refused edit leaves it (the
  diagnosis still stands, so the fixer can correct its edit); an edit without it is refused;
- ``diagnose`` is refused while the views are stale (rendered before the last change, or none);
- ``finish(ok)`` is refused while the recompiled program has a visible floater, while the last
  critique has a HIGH issue, or while the last critique predates the last edit, naming them;
  the program is recompiled first when it is stale;
- ``finish(give_up)`` is never gated;
- ``add_part`` asks the workbench to build a new part through the build stage's path (its
  build request, splice, gates, N_vis); it is an edit like the others;
- a part that cannot be fixed in place is routed back to the build stage: after
  :data:`REBUILD_AFTER` refused ``edit_part`` of one part the workbench rebuilds it from its
  build request (once per part, :data:`MAX_REBUILDS` in a session), an edit like the others;
- only successful edits count against the edit budget; when it is spent, edits are refused and
  the session must finish. A bound on all actions ends a fixer that never finishes.

Every refusal is an observation for the fixer (one line saying why and what to do), never an
exception.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

from ..errors import ProceduraError
from .critic import Critique

ACTIONS: tuple[str, ...] = ("render", "diagnose", "edit_part", "set_param", "add_part", "compile",
                            "check_connectivity", "finish")
#: Refused ``edit_part`` calls of one part after which it is rebuilt from its build request.
REBUILD_AFTER = 2
#: Rebuilds in one session (each part at most once).
MAX_REBUILDS = 2
_NAME_RE = re.compile(r"[a-z][a-z0-9_]{0,62}")
MAX_VIEWS = 20
_FENCE_RE = re.compile(r"```(?:json)?[ \t]*\n(.*?)```", re.S)


class ActionError(ProceduraError):
    """A fixer reply that is not one well-formed action (the retry is told why)."""


@dataclass(frozen=True)
class Action:
    """One parsed action: its name and its arguments."""

    name: str
    args: dict[str, Any] = field(default_factory=dict)


def parse_action(text: str, *, view_names: tuple[str, ...]) -> Action:
    """Read one action from a fixer reply (a fenced JSON block or a bare object).

    Raises:
        ActionError: not JSON, not an object, an unknown action, missing or bad arguments.
    """
    blocks = [m.group(1) for m in _FENCE_RE.finditer(text)]
    lo, hi = text.find("{"), text.rfind("}")
    candidates = blocks + ([text[lo:hi + 1]] if 0 <= lo < hi else [])
    data: Any = None
    for c in candidates:
        try:
            data = json.loads(c)
            break
        except json.JSONDecodeError:
            continue
    if not isinstance(data, dict):
        raise ActionError('answer with one JSON object such as {"action": "diagnose"}; actions: '
                          + ", ".join(ACTIONS))
    name = data.get("action")
    if name not in ACTIONS:
        raise ActionError(f"unknown action {name!r}; use one of {', '.join(ACTIONS)}")
    args = {k: v for k, v in data.items() if k != "action"}
    if name == "render":
        views, close = args.get("views"), args.get("close_up")
        if close is not None:
            if not isinstance(close, str) or not close:
                raise ActionError("render close_up takes a part or mate name")
        else:
            if isinstance(views, str):
                views = [views]
            if not isinstance(views, list) or not 1 <= len(views) <= MAX_VIEWS:
                raise ActionError(f"render takes 1-{MAX_VIEWS} view names, e.g. "
                                  f'{{"action": "render", "views": ["{view_names[0]}"]}}')
            unknown = [v for v in views if v not in view_names]
            if unknown:
                raise ActionError(f"unknown view(s) {', '.join(map(str, unknown))}; views: {', '.join(view_names)}")
            args["views"] = list(dict.fromkeys(views))
    elif name == "edit_part":
        if not isinstance(args.get("part"), str) or not isinstance(args.get("reply"), str):
            raise ActionError("edit_part takes \"part\" (a part name) and \"reply\" (the part's five "
                              "blocks: params, helpers, body, frames, mates)")
    elif name == "set_param":
        value = args.get("value")
        if not isinstance(args.get("name"), str) or isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ActionError('set_param takes "name" (a param) and a numeric "value"')
    elif name == "add_part":
        bad = [k for k in ("name", "mates_to", "type", "nominal")
               if not isinstance(args.get(k), str) or not _NAME_RE.fullmatch(args[k])]
        what = args.get("what")
        if bad or not isinstance(what, str) or len(what.strip()) < 8:
            raise ActionError('add_part takes "name" (a new snake_case part), "what" (what it is: '
                              'size, aspect, pose against its neighbours), "mates_to" (an existing '
                              'part), "type" (a mate type) and "nominal" (the param name sizing the '
                              'mate)' + (f"; bad: {', '.join(bad)}" if bad else ""))
        if args.get("detail", "major") not in ("silhouette", "major", "sub"):
            raise ActionError('add_part "detail" is silhouette, major or sub')
    elif name == "finish":
        if args.get("verdict") not in ("ok", "give_up"):
            raise ActionError('finish takes "verdict": "ok" or "give_up"')
    return Action(name, args)


@dataclass(frozen=True)
class CompileOutcome:
    """What compiling the current program found: ok, the findings' lines, the floaters."""

    ok: bool
    findings: tuple[str, ...] = ()
    floaters: tuple[str, ...] = ()  # "part_name (box ...)" for each visible floater (N_vis)


class Workbench(Protocol):
    """What the session drives; the real one renders, calls the critic, splices and gates."""

    def render(self, source: str, *, views: list[str] | None, close_up: str | None) -> list[Any]: ...

    def critique(self, source: str, views: list[Any], trail: list[Critique]) -> Critique: ...

    def edit_part(self, source: str, part: str, reply: str) -> str: ...

    def set_param(self, source: str, name: str, value: float) -> str: ...

    # optional: ``add_part(source, args) -> str`` and, with ``can_rebuild`` true,
    # ``rebuild_part(source, part, reasons) -> str`` (both raise EditRefused)

    def compile(self, source: str) -> CompileOutcome: ...

    def connectivity(self, source: str) -> CompileOutcome: ...


class EditRefused(ProceduraError):
    """The workbench refused an edit (it does not splice, compile or pass its gates)."""


Verdict = Literal["ok", "give_up", "budget", "steps"]


@dataclass
class Step:
    """One executed action and what the fixer is told."""

    action: str
    ok: bool
    observation: str


@dataclass
class RefineSession:
    """The refine loop's state and invariants (see the module docstring)."""

    bench: Workbench
    source: str
    max_edits: int = 6
    max_actions: int = 60
    version: int = 0
    views: list[Any] = field(default_factory=list)
    views_version: int = -1
    critique: Critique | None = None
    critique_version: int = -1
    trail: list[Critique] = field(default_factory=list)
    latch: bool = False
    edits: int = 0
    compiled: CompileOutcome | None = None
    compiled_version: int = -1
    steps: list[Step] = field(default_factory=list)
    verdict: Verdict | None = None
    refusals: dict[str, list[str]] = field(default_factory=dict)  # refused edit_part reasons, per part
    rebuilt: list[str] = field(default_factory=list)  # parts routed back to their build request

    @property
    def done(self) -> bool:
        return self.verdict is not None

    def run(self, action: Action) -> Step:
        """Execute one action; return the observation (a refusal is an observation too)."""
        if self.done:
            return self._log(action.name, False, f"the session has ended ({self.verdict})")
        step = getattr(self, f"_do_{action.name}")(action.args)
        if len(self.steps) >= self.max_actions and not self.done:
            self.verdict = "steps"
            self._ensure_compiled()
            step.observation += f"; the action limit ({self.max_actions}) is reached: the session ends"
        return step

    def _log(self, action: str, ok: bool, text: str) -> Step:
        step = Step(action, ok, text)
        self.steps.append(step)
        return step

    def _changed(self, source: str) -> None:
        self.source, self.version = source, self.version + 1

    def _ensure_compiled(self) -> CompileOutcome:
        if self.compiled_version != self.version or self.compiled is None:
            self.compiled, self.compiled_version = self.bench.compile(self.source), self.version
        return self.compiled

    # actions -------------------------------------------------------------------------------

    def _do_render(self, args: dict[str, Any]) -> Step:
        self.views = self.bench.render(self.source, views=args.get("views"), close_up=args.get("close_up"))
        self.views_version = self.version
        what = f"close-up of {args['close_up']}" if args.get("close_up") else ", ".join(args["views"])
        return self._log("render", True, f"rendered {len(self.views)} view(s): {what}")

    def _do_diagnose(self, args: dict[str, Any]) -> Step:
        if not self.views or self.views_version != self.version:
            why = "no views are rendered" if not self.views else "the views predate the last edit"
            return self._log("diagnose", False, f"refused: {why}; render the current program first")
        crit = self.bench.critique(self.source, self.views, list(self.trail))
        self.critique, self.critique_version = crit, self.version
        self.trail.append(crit)
        self.latch = True
        return self._log("diagnose", True, crit.text())

    def _apply(self, name: str, apply: Any) -> tuple[bool | None, str]:
        """Run one gated edit: (True, text) applied; (False, text) refused by the workbench (the
        diagnosis stands); (None, text) refused by the loop (budget, no diagnosis)."""
        if self.edits >= self.max_edits:
            return None, (f"refused: the edit budget ({self.max_edits}) is spent; "
                          "finish with ok or give_up")
        if not self.latch:
            return None, ("refused: an edit needs a fresh diagnosis; diagnose first "
                          "(one diagnosis allows one edit)")
        try:
            new = apply()
        except EditRefused as exc:  # nothing changed: the diagnosis still stands
            return False, f"edit refused: {exc}; the diagnosis still allows one edit"
        self.latch = False  # consumed by the edit that landed
        self._changed(new)
        self.edits += 1
        renames = getattr(self.bench, "last_renames", {}) if name in ("edit_part", "add_part",
                                                                       "rebuild_part") else {}
        renamed = ("; helper(s) renamed because the program already has a different helper of "
                   "that name: " + ", ".join(f"{a} -> {b}" for a, b in renames.items()) +
                   " (the part now calls the new name)") if renames else ""
        note = getattr(self.bench, "last_note", "") if name in ("add_part", "rebuild_part") else ""
        return True, (f"edit applied ({self.edits}/{self.max_edits} edits){renamed}"
                      + (f"; {note}" if note else "") + "; compile, render and diagnose to check it")

    def _edit(self, name: str, apply: Any) -> Step:
        ok, text = self._apply(name, apply)
        return self._log(name, bool(ok), text)

    def _do_edit_part(self, args: dict[str, Any]) -> Step:
        part = args["part"]
        ok, text = self._apply("edit_part", lambda: self.bench.edit_part(self.source, part, args["reply"]))
        if ok is not False:
            if ok:
                self.refusals.pop(part, None)
            return self._log("edit_part", bool(ok), text)
        reasons = self.refusals.setdefault(part, [])
        reasons.append(text.removeprefix("edit refused: ")
                       .removesuffix("; the diagnosis still allows one edit"))
        if (len(reasons) < REBUILD_AFTER or part in self.rebuilt or len(self.rebuilt) >= MAX_REBUILDS
                or not getattr(self.bench, "can_rebuild", False)):
            return self._log("edit_part", False, text)
        # routed back to the stage that made it: the part is rebuilt from its build request
        self.rebuilt.append(part)
        done, rebuilt = self._apply("rebuild_part",
                                    lambda: self.bench.rebuild_part(self.source, part, list(reasons)))
        text += (f"; {part} could not be fixed in place ({len(reasons)} refused edits), so it goes "
                 f"back to its build request and is rebuilt: " + rebuilt)
        return self._log("rebuild_part" if done else "edit_part", bool(done), text)

    def _do_set_param(self, args: dict[str, Any]) -> Step:
        return self._edit("set_param", lambda: self.bench.set_param(self.source, args["name"], float(args["value"])))

    def _do_add_part(self, args: dict[str, Any]) -> Step:
        add = getattr(self.bench, "add_part", None)
        if add is None:
            return self._log("add_part", False, "refused: this session cannot add parts")
        return self._edit("add_part", lambda: add(self.source, dict(args)))

    def _do_compile(self, args: dict[str, Any]) -> Step:
        out = self._ensure_compiled()
        text = "compiled: all gates pass" if out.ok else "compiled with findings:\n" + "\n".join(out.findings)
        if out.floaters:
            text += f"\n{len(out.floaters)} visible floater(s): " + "; ".join(out.floaters) + \
                    " (run check_connectivity for details)"
        return self._log("compile", out.ok, text)

    def _do_check_connectivity(self, args: dict[str, Any]) -> Step:
        out = self.bench.connectivity(self.source)
        if not out.floaters:
            return self._log("check_connectivity", True, "connected: N_vis = 0")
        return self._log("check_connectivity", False, f"N_vis = {len(out.floaters)}: " + "; ".join(out.floaters))

    def _do_finish(self, args: dict[str, Any]) -> Step:
        if args["verdict"] == "give_up":
            self.verdict = "give_up"
            self._ensure_compiled()
            return self._log("finish", True, f"gave up: {args.get('reason', 'no reason given')}")
        out = self._ensure_compiled()
        problems: list[str] = []
        if out.floaters:
            problems.append(f"{len(out.floaters)} visible floater(s): " + "; ".join(out.floaters))
        if self.critique is None or self.critique_version != self.version:
            problems.append("the last diagnosis predates the last edit: render and diagnose the "
                            "current program")
        elif self.critique.high:
            problems.append("HIGH issue(s) open: " + "; ".join(i.line() for i in self.critique.high))
        if problems:
            return self._log("finish", False, "finish(ok) refused: " + " | ".join(problems))
        self.verdict = "ok"
        return self._log("finish", True, "finished: ok")

    def end(self, verdict: Verdict) -> None:
        """End the session from outside (edit budget or action limit spent, a stopped run)."""
        if not self.done:
            self.verdict = verdict
            self._ensure_compiled()
