"""The refine loop over a real program: the fixer's turns, a workbench of real renders, critic
calls and gated edits (:class:`RefineBench`), and the invariants of :mod:`.actions`.

Used by the staged run (after the build) and by ``revise`` (a person's change request, with the
edits restricted to the parts it names or the critic localises).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from ..errors import ProceduraError
from ..findings import blocking
from ..llm import Image, Message
from ..paths import write_atomic
from ..program.model import CompiledModel, Finding
from ..program.splice import SpliceError, replace_part
from .actions import (
    ActionError,
    CompileOutcome,
    EditRefused,
    RefineSession,
    Step,
    parse_action,
)
from .context import captions
from .critic import Critique, CritiqueError, parse_critique
from .prompts import template
from .runstate import history_path
from .stages import StageHost

log = logging.getLogger(__name__)
#: The views of the close-up a pair finding comes with (the build retries' too).
PAIR_VIEWS: tuple[str, ...] = ("iso_se", "iso_nw")


def pair_finding(findings: list[Finding]) -> Finding | None:
    """The first finding between two parts (an interference, a gouge): the one whose close-up
    (``render --close-up part+other``) a retry, the fixer and the critic are shown."""
    return next((f for f in findings if f.part and f.other), None)


def findings_text(findings: list[Finding], limit: int = 12,
                  where: Callable[[int], str] | None = None) -> str:
    """Findings as model feedback: one ``- message (line N)`` row each, capped; ``where``
    words a program line (e.g. as a line of the reply's own block)."""
    rows = [f"- {f.message}" + (f" ({where(f.line) if where else f'line {f.line}'})" if f.line else "")
            for f in findings[:limit]]
    if len(findings) > limit:
        rows.append(f"- ... and {len(findings) - limit} more")
    return "\n".join(rows) or "- (no details)"


def refine(host: StageHost, source: str, *, intro: str, max_edits: int, max_actions: int,
           critic_system: str | None = None, task: str | None = None,
           allowed: set[str] | None = None, stage: str = "refine",
           roles: tuple[str, str] = ("fixer", "critic"),
           bench_type: type[RefineBench] | None = None) -> tuple[str, dict[str, Any]]:
    """Run the fixer until it finishes (or its budgets end); return the program and a report.

    Args:
        host: the run (model calls, tools, progress).
        source: the program to refine.
        intro: the fixer's first message.
        critic_system: the critic's system prompt (default ``critic_system.md``).
        task: shown to the critic as what the build must satisfy (default: the prompt).
        allowed: edits touch only these parts (None: any); a critique may widen the set to the
            parts it names when ``allowed`` is empty.
        roles: the (fixer, critic) roles of the calls.
        bench_type: a :class:`RefineBench` subclass with stricter edit rules (revise).
    """
    from ..render.views import VIEWS
    bench = (bench_type or RefineBench)(host, critic_system=critic_system, task=task, allowed=allowed,
                                        critic_role=roles[1])
    session = RefineSession(bench, source, max_edits=max_edits, max_actions=max_actions)
    system = (template("fixer_system").replace("{views}", ", ".join(VIEWS)).replace("{edits}", str(max_edits)))
    msgs: list[Message] = [Message.user(intro, *host.refs())]
    shown: list[int] = []  # the messages that carry rendered views (only the newest keeps them)
    while not session.done:
        text = host.call(roles[0], system, msgs, max_tokens=8000)
        msgs.append(Message.assistant(text))
        try:
            action = parse_action(text, view_names=tuple(VIEWS))
        except ActionError as exc:
            session.steps.append(Step("invalid", False, str(exc)))
            if len(session.steps) >= session.max_actions:
                session.end("steps")
            msgs.append(Message.user(f"invalid action: {exc}"))
            continue
        version = session.version
        step = session.run(action)
        if session.version != version:  # an applied edit (edit_part, set_param, add_part, rebuild)
            write_atomic(history_path(host.out_dir, f"{stage}-{step.action}"), session.source)
        images = bench.last_images if action.name == "render" and step.ok else []
        seen = (f"\nViews{_named(images)}. Colour legend: {bench.last_legend}"
                if images else "")  # the fixer's images named and keyed, as the critic's
        if action.name == "compile" and not step.ok:  # a pair finding comes with its close-up
            note, images = bench.pair_close_up(session.source)
            seen = f"\n{note}" if images else ""
        if images:
            shown = _omit_views(msgs, shown)
            shown.append(len(msgs))
        msgs.append(Message.user(step.observation + seen, *images))
        host.progress(stage, f"{action.name}: {step.observation.splitlines()[0][:120]}")
    report = {
        "verdict": session.verdict, "edits": session.edits, "actions": len(session.steps),
        "diagnoses": [c.text() for c in session.trail],
        "refused": [f"{s.action}: {s.observation}" for s in session.steps if not s.ok],
    }
    if bench.routed:
        report["routed"] = bench.routed
    if allowed is not None:
        report["allowed_parts"] = sorted(bench.allowed or ())
    return session.source, report


def _omit_views(msgs: list[Message], shown: list[int]) -> list[int]:
    """Drop the images of the earlier render observations ``shown`` (indices into ``msgs``):
    each keeps its text and a note of how many views it had, so a conversation sends only the
    newest render's images (issue 23.6: every call resent every earlier render)."""
    for i in shown:
        m = msgs[i]
        if m.images:
            msgs[i] = Message.user(f"{m.text}\n({len(m.images)} earlier view(s) omitted: a newer "
                                   "render follows)")
    return []


def _named(views: list[Any]) -> str:
    """``", in order: front (from -Y, ortho), ..."`` for named images ("" when any is unnamed)."""
    names = [getattr(v, "name", "") for v in views]
    return f", in order: {captions(names)}" if names and all(names) else ""


class RefineBench:
    """The refine session's workbench over a host run: real renders, critic calls, gated edits."""

    def __init__(self, host: StageHost, *, critic_system: str | None = None, task: str | None = None,
                 allowed: set[str] | None = None, critic_role: str = "critic") -> None:
        self.host = host
        self.critic_system = critic_system or template("critic_system")
        self.task = task
        self.allowed = set(allowed) if allowed is not None else None
        self.localise = allowed is not None and not allowed
        self.critic_role = critic_role
        self.last_images: list[Image] = []
        self.last_legend = ""
        #: Helper renames the last applied edit_part made (old -> new), for its message.
        self.last_renames: dict[str, str] = {}
        #: What the last applied add_part or rebuild adds to its message.
        self.last_note = ""
        #: One row per add_part or rebuild (routed back to the build stage), for the report.
        self.routed: list[dict[str, Any]] = []
        self._refused: dict[str, list[Finding]] = {}  # the refused edits' findings, per part
        self._models: dict[str, CompiledModel] = {}
        self._outcomes: dict[str, CompileOutcome] = {}
        #: The first blocking finding between two parts of a compiled program: (a+b, its message).
        self._pairs: dict[str, tuple[str, str] | None] = {}

    def _model(self, source: str) -> CompiledModel:
        if source not in self._models:
            self._models = {source: self.host.tools.compile_model(source, self.host.name)}
        return self._models[source]

    def render(self, source: str, *, views: list[str] | None, close_up: str | None) -> list[Any]:
        try:
            imgs, legend = self.host.tools.render(self._model(source), views, close_up=close_up)
        except (ProceduraError, ValueError) as exc:  # an unknown close-up target, no parts
            log.info("render refused: %s", exc)
            imgs, legend = [], self.last_legend
        self.last_images, self.last_legend = imgs, legend
        return imgs

    def pair_close_up(self, source: str) -> tuple[str, list[Image]]:
        """The close-up (the other parts ghosted) of the first blocking finding between two
        parts of ``source`` as compiled, with a line saying what it shows; ("", []) when the
        program was not compiled here or has no such finding."""
        pair = self._pairs.get(source)
        if not pair:
            return "", []
        try:
            imgs, _ = self.host.tools.render(self._model(source), list(PAIR_VIEWS), close_up=pair[0])
        except (ProceduraError, ValueError) as exc:
            log.info("pair close-up refused: %s", exc)
            return "", []
        return (f"Close-up of {pair[0].replace('+', ' and ')} where the gates find: {pair[1]} "
                f"(the two in colour, the other parts ghosted grey){_named(imgs)}."), imgs

    def critique(self, source: str, views: list[Any], trail: list[Critique]) -> Critique:
        model = self._model(source)
        parts = {p.name for p in model.parts}
        earlier = "\n\n".join(f"Review {i + 1}:\n{c.text()}" for i, c in enumerate(trail)) or "none"
        task = self.task or f"Object: {self.host.prompt}"
        note, close = self.pair_close_up(source)
        msgs = [Message.user(f"{task}\nColour legend: {self.last_legend}\n\n"
                             f"The program:\n```python\n{source}```\n\nEarlier reviews:\n{earlier}\n\n"
                             "The views of the current build follow" + _named(views) + "."
                             + (f"\n{note} Its views follow the others." if close else ""),
                             *self.host.refs(), *views, *close)]
        crit = None
        for _ in range(2):
            text = self.host.call(self.critic_role, self.critic_system, msgs, max_tokens=2000)
            try:
                crit = parse_critique(text, parts=parts)
                break
            except CritiqueError as exc:
                msgs += [Message.assistant(text), Message.user(f"{exc}. Reply again in the format asked.")]
        if crit is None:
            return Critique("the critic's reply was unreadable twice", ())
        if self.localise and self.allowed is not None:
            self.allowed |= {n for i in crit.issues for n in i.parts}
        return crit

    def _n_vis(self, source: str) -> int:
        return len(self.compile(source).floaters)

    def edit_part(self, source: str, part: str, reply: str) -> str:
        if self.allowed is not None and part not in self.allowed:
            scope = ", ".join(sorted(self.allowed)) or "the parts the review names"
            raise EditRefused(f"this change may touch only {scope}, not {part}")
        try:
            result = replace_part(source, reply)
        except SpliceError as exc:
            raise EditRefused(str(exc)) from None
        if result.part != part:
            raise EditRefused(f"the reply defines part {result.part!r}, not {part!r}")
        verdict = self.host.tools.gate_part(result.source, part, baseline=self._n_vis(source),
                                            name=self.host.name)
        if not verdict.ok:
            self._refused.setdefault(part, []).extend(verdict.errors)  # every refusal's findings
            raise EditRefused(findings_text(verdict.errors, 6).replace("\n", " "))
        if verdict.model is not None:
            self._models = {result.source: verdict.model}
        self.last_renames = dict(result.renames)
        return result.source

    # routed back to the build stage (issue 23.6) -----------------------------------------------

    @property
    def can_rebuild(self) -> bool:
        """Whether a part that cannot be fixed in place may be rebuilt from its build request
        (a staged run; never a revise, which touches only what the person asked for)."""
        return self.allowed is None and hasattr(self.host, "rebuild_part")

    def add_part(self, source: str, args: dict[str, Any]) -> str:
        """Build a new part through the host's build path (its build request, splice, gates,
        N_vis) and return the program with it; EditRefused when it cannot be added."""
        from ..mates import TYPES
        from ..program.splice import program_parts
        name, partner, mtype = args["name"], args["mates_to"], args["type"]
        hook = getattr(self.host, "add_part", None)
        if self.allowed is not None or hook is None:
            raise EditRefused("this session cannot add parts (a revise changes existing parts only)")
        try:
            parts = program_parts(source)
        except ProceduraError as exc:
            raise EditRefused(f"the program does not parse: {exc}") from None
        if name in parts:
            raise EditRefused(f"part {name} already exists; change it with edit_part")
        if partner not in parts:
            raise EditRefused(f"mates_to {partner!r} is not a part; parts: {', '.join(parts)}")
        if mtype not in TYPES:
            raise EditRefused(f"type {mtype!r} is not a mate type; use one of {', '.join(TYPES)}")
        row: dict[str, Any] = {"kind": "add_part", "part": name, "mates_to": partner, "type": mtype,
                               "what": args["what"]}
        self.routed.append(row)
        try:
            new, note = hook(source, name=name, what=args["what"], partner=partner, mate_type=mtype,
                             nominal=args["nominal"], detail=args.get("detail", "major"),
                             baseline=self._n_vis(source))
        except EditRefused as exc:
            row.update(accepted=False, reason=str(exc))
            raise
        row["accepted"] = True
        self.last_note, self.last_renames = note, {}
        return new

    def rebuild_part(self, source: str, part: str, reasons: list[str]) -> str:
        """Rebuild ``part`` from its build request (its edits in place were refused); a mate
        that could not be satisfied goes back to the plan's mate: the request says so and the
        plan takes the mates the rebuilt part declares. EditRefused when the rebuild fails."""
        hook = getattr(self.host, "rebuild_part", None)
        if not self.can_rebuild or hook is None:
            raise EditRefused("this session cannot rebuild parts")
        mates = sorted({f.mate for f in self._refused.get(part, []) if f.mate})
        row: dict[str, Any] = {"kind": "rebuild", "part": part, "refused_edits": len(reasons),
                               "mates": mates}
        self.routed.append(row)
        try:
            new, note = hook(source, part, reasons=reasons, mates=mates, baseline=self._n_vis(source))
        except EditRefused as exc:
            row.update(accepted=False, reason=str(exc))
            raise
        row.update(accepted=True, note=note)
        self.last_note, self.last_renames = note, {}
        return new

    def set_param(self, source: str, name: str, value: float) -> str:
        from ..errors import EditError
        from ..program.edit import set_params
        try:
            new = set_params(source, {name: value})
        except EditError as exc:
            raise EditRefused(str(exc)) from None
        before, after = self.compile(source), self.compile(new)
        if len(after.findings) > len(before.findings):
            raise EditRefused("it breaks the program: " + "; ".join(after.findings[:6]))
        return new

    def compile(self, source: str) -> CompileOutcome:
        """Every gate on ``source`` (one check per program text; the floaters are its N_vis)."""
        if source in self._outcomes:
            return self._outcomes[source]
        from ..gates import check_model
        try:
            model = self._model(source)
        except ProceduraError as exc:
            return CompileOutcome(False, (str(exc),))
        report = check_model(model, source)
        errs = tuple(f.message for f in blocking(report.findings))
        floaters = tuple(f.message for f in report.gate("connectivity").findings if f.code == "floater")
        pair = pair_finding(blocking(report.findings))
        self._pairs = {source: (f"{pair.part}+{pair.other}", pair.message) if pair else None}
        self._outcomes = {source: CompileOutcome(not errs, errs, floaters)}
        return self._outcomes[source]

    def connectivity(self, source: str) -> CompileOutcome:
        return self.compile(source)
