"""The staged agent (docs/agent.md, the paper's section 3): plan, one-direction review,
mate-driven build one part per call, decoupled-critic refine, materials, then the final build.

One frozen model answers every call through a :class:`~procedura_brep.llm.Client`; each call has
a ``role`` (``plan``, ``review``, ``build``, ``critic``, ``fixer``, ``articulation``,
``battery_fixer``) and a run-wide ``step``
number, so a transcript replays call for call. Everything between the calls is deterministic
(:class:`~procedura_brep.agent.tools.Tools`).

The run directory is written after every commit (:mod:`.runstate`): a killed run resumes from
``state.json`` without losing or redoing a committed part, and the last committed program is
always there. The ablation switches are the paper's Table 3 rows: ``plan=False`` builds without
an assembly plan (the model names each next part itself), ``feedback=False`` sends no renders
to the build calls, ``refine=False`` ships the draft; ``review=False`` skips the review.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .. import interrupt
from ..errors import ProceduraError
from ..findings import blocks
from ..llm import Client, Image, Message, Request, Settings
from ..llm.errors import BudgetExceeded, LLMError
from ..paths import write_atomic
from ..program.model import CompiledModel
from ..program.splice import SpliceError, empty_program, parse_reply, replace_part, splice
from . import reference as reference_image
from .context import CommittedPart, build_request, captions
from .materials import materials_stage
from .plan import Plan, PlanError, PlannedMate, PlannedPart, parse_plan
from .prompts import reference, template
from .reference import Reference
from .refine import PAIR_VIEWS, findings_text, pair_finding, refine
from .review import enforce_review
from .runstate import RunDir, RunState
from .stages import STAGES, next_stage
from .tools import PartVerdict, Tools

log = logging.getLogger(__name__)
Progress = Callable[[str, str], None]
DONE_WORD = "DONE"
#: Views of a failed (but compiled) attempt sent with its retry, the part's origin and frames
#: drawn as axes: two opposite corners, so an axis hidden behind the body in one shows in the other.
RETRY_VIEWS: tuple[str, ...] = ("iso_se", "iso_nw")


class StagedError(ProceduraError):
    """A stage could not go on (no usable plan, no part at all): the run ends with this reason."""


@dataclass(frozen=True)
class StagedOptions:
    """Switches and budgets of a staged run (the ablation rows are plan/review/feedback/refine)."""

    plan: bool = True
    review: bool = True
    feedback: bool = True
    refine: bool = True
    materials: bool = True  # the materials stage (model calls with roles in MATERIAL_ROLES)
    articulation: bool = True  # the articulation planning stage (roles in ARTICULATION_ROLES)
    attempts: int = 3
    plan_attempts: int = 3
    max_edits: int = 6
    max_actions: int = 40
    max_parts: int = 60
    views: tuple[str, ...] | None = None  # build views (None: the 12 defaults)
    simulate: bool = True
    formats: tuple[str, ...] | None = None  # exports of the final build (None: all)


@dataclass
class _Attempts:
    """How the attempts at one part ended: ``ok`` with the passing splice; else the last attempt
    that compiled (``result``/``verdict``, failing) or none, and the last feedback."""

    result: Any
    verdict: PartVerdict | None
    attempt: int
    overhead: float
    feedback: str | None = None

    @property
    def ok(self) -> bool:
        return self.feedback is None and self.verdict is not None and self.verdict.ok


@dataclass
class StagedResult:
    """How a staged run ended."""

    status: str
    out_dir: Path
    state: RunState
    build: Any = None
    refine: dict[str, Any] = field(default_factory=dict)
    message: str = ""


def _mate_table() -> str:
    from ..mates import TYPES
    return "\n".join(f"- {t.name} ({t.kind}, {t.dof.count} DOF): {t.doc}" for t in TYPES.values())


class StagedRun:
    """One staged generation; :meth:`run` drives it to the end."""

    def __init__(self, prompt: str, out_dir: Path, *, client: Client, options: StagedOptions = StagedOptions(),
                 image: bytes | None = None, tools: Tools | None = None, progress: Progress | None = None,
                 state: RunState | None = None) -> None:
        self.client = client
        self.options = options
        self.tools = tools or Tools()
        self.progress = progress or (lambda stage, text: log.info("%s: %s", stage, text))
        self.dir = RunDir(out_dir)
        self.out_dir = out_dir
        self.reference = Image(image, "reference") if image else None
        self.state = state or RunState(prompt)
        self.prompt = self.state.prompt
        self.name = "model"
        self._model: CompiledModel | None = None
        # the stage reports live in the state, so a run resumed after a stage still reports it
        self.refine_report: dict[str, Any] = self.state.refine
        self.reference_info: dict[str, Any] = {"source": "file" if image else "none"}
        self.articulation_report: dict[str, Any] = self.state.articulation
        self._prebuilt: tuple[str | None, Any] = (None, None)
        # refine's view of the plan and the parts it added or rebuilt (applied when it ends)
        self._refine_plan: Plan | None = None
        self._refine_commits: dict[str, CommittedPart] = {}

    # model calls -----------------------------------------------------------------------------

    def call(self, role: str, system: str, messages: list[Message], *, max_tokens: int = 8000) -> str:
        step = self.state.step
        reply = self.client.complete(Request(role, step, system, tuple(messages), Settings(max_tokens=max_tokens)))
        self.state.step = step + 1
        return reply.text

    def _image_note(self) -> str:
        return "The attached image is the reference: match it.\n\n" if self.reference else ""

    def refs(self) -> list[Image]:
        return [self.reference] if self.reference else []

    # stages ----------------------------------------------------------------------------------

    def run(self) -> StagedResult:
        """Run the stages of :data:`.stages.STAGES` from the current one on (all of them for a
        new run); each row's method runs, then the state moves to the next row and is saved."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        st = self.state
        try:
            while st.stage != "done":
                row = next(r for r in STAGES if r.name == st.stage)
                result = getattr(self, row.method)()
                if row.name == "finish":
                    return result
                self._advance(next_stage(row.name))
        except BudgetExceeded as exc:
            return self._finish("budget_exceeded", str(exc))
        except StagedError as exc:
            return self._finish("failed", str(exc))
        return self._finish("ok")

    def _advance(self, stage: str) -> None:
        self.state.stage = stage
        self.dir.save(self.state)

    def stage_plan(self) -> None:
        if not self.options.plan:
            self.progress("plan", "skipped (--no-plan): the model names each next part")
            return
        system = template("plan_system").replace("{mates}", _mate_table())
        msgs = [Message.user(template("plan_user").replace("{prompt}", self.prompt)
                             .replace("{image_note}", self._image_note()), *self.refs())]
        last = ""
        for attempt in range(1, self.options.plan_attempts + 1):
            text = self.call("plan", system, msgs)
            try:
                plan = parse_plan(text)
            except PlanError as exc:
                last = str(exc)
                self.progress("plan", f"attempt {attempt}: {exc}")
                msgs += [Message.assistant(text), Message.user(
                    "The plan has problems; fix all of them and reply with the whole plan:\n"
                    + "\n".join(f"- {p}" for p in exc.problems))]
                continue
            self.state.plan = plan.as_dict()
            self.state.repairs += list(plan.notes)
            self.progress("plan", f"{len(plan.parts)} parts: {', '.join(plan.names)}")
            return
        raise StagedError(f"no usable plan after {self.options.plan_attempts} attempts: {last}")

    def stage_review(self) -> None:
        plan = self.plan
        if plan is None or not self.options.review:
            return
        system = template("review_system").replace("{mates}", _mate_table())
        msgs = [Message.user(template("review_user").replace("{prompt}", self.prompt)
                             .replace("{image_note}", self._image_note()).replace("{plan}", plan.to_json()),
                             *self.refs())]
        text = self.call("review", system, msgs)
        try:
            reviewed = parse_plan(text)
        except PlanError as exc:
            self.state.repairs.append(f"review reply unusable, plan kept as it was: {exc}")
            self.progress("review", f"unusable reply, plan kept ({exc})")
            return
        merged, repairs = enforce_review(plan, reviewed)
        repairs = [f"review: {n}" for n in reviewed.notes] + repairs
        self.state.plan = merged.as_dict()
        self.state.repairs += repairs
        added = [n for n in merged.names if n not in plan.names]
        self.progress("review", f"{len(merged.parts)} parts (+{len(added)}: {', '.join(added) or 'none'})"
                      + (f"; {len(repairs)} repair(s)" if repairs else ""))

    @property
    def plan(self) -> Plan | None:
        return parse_plan(self.state.plan) if self.state.plan else None

    # build -----------------------------------------------------------------------------------

    def _current_model(self) -> CompiledModel | None:
        if self._model is None and self.state.source:
            try:
                self._model = self.tools.compile_model(self.state.source, self.name)
            except ProceduraError:
                self._model = None
        return self._model

    def _views(self) -> tuple[list[Image], str]:
        model = self._current_model()
        if not self.options.feedback or model is None or not model.parts:
            return [], ""
        views = list(self.options.views) if self.options.views else None
        return self.tools.render(model, views)

    def stage_build(self) -> None:
        plan = self.plan
        system = template("build_system").replace("{reference}", reference())
        if plan is None:
            return self._build_unplanned(system)
        done = {c.name for c in self.state.committed} | {s["name"] for s in self.state.skipped}
        for part in plan.parts:
            if part.name in done:
                continue
            skipped = {s["name"] for s in self.state.skipped}
            lost = [m.partner for m in part.mates if m.partner in skipped]
            if lost and len(lost) == len(part.mates):
                self._skip(part.name, f"its partner(s) {', '.join(lost)} were skipped")
                continue
            if lost:
                part = PlannedPart(part.name, part.detail, part.description,
                                   tuple(m for m in part.mates if m.partner not in skipped),
                                   part.couple if part.couple and part.couple.driver not in skipped else None)
            self._build_part(system, plan, part)
        if not self.state.committed:
            raise StagedError("no part could be built")

    def _skip(self, name: str, why: str) -> None:
        self.state.skipped.append({"name": name, "reason": why})
        self.progress("build", f"{name}: skipped ({why})")
        self.dir.save(self.state)

    def _build_part(self, system: str, plan: Plan, part: PlannedPart) -> None:
        k = plan.index(part.name) + 1
        t_views = time.perf_counter()
        views, legend = self._views()
        overhead = time.perf_counter() - t_views  # deterministic work: renders, splice, gates, writes
        got = self._attempts(system, plan, part, source=self.state.source, baseline=self.state.baseline,
                             place=splice, views=views, legend=legend, header=empty_program(self.prompt),
                             committed=self.state.committed, overhead=overhead)
        if got.ok:
            self._commit(got.result, got.verdict, overhead=got.overhead)
            self.progress("build", f"part {k}/{len(plan.parts)} {part.name}: committed "
                          f"(attempt {got.attempt})")
            return
        if got.result is not None:
            result, verdict = got.result, got.verdict
            failing = [f for f in verdict.errors if blocks(f)]
            if failing:  # it would fail the whole run on the same finding: never committed
                self._skip(part.name, f"after {self.options.attempts} attempts it still fails the "
                           f"gates: " + "; ".join(f.message for f in failing[:3]))
                return
            warning = "; ".join(f.message for f in verdict.errors[:3])
            self._commit(result, verdict, overhead=got.overhead, warning=warning)
            self.progress("build", f"part {k}/{len(plan.parts)} {part.name}: committed with a warning "
                          f"after {self.options.attempts} attempts ({warning})")
        else:
            self._skip(part.name, f"it did not compile in {self.options.attempts} attempts")

    def _attempts(self, system: str, plan: Plan, part: PlannedPart, *, source: str, baseline: int,
                  place: Callable[..., Any], views: list[Image], legend: str, header: str,
                  committed: Any, overhead: float = 0.0, history: list[Message] | None = None) -> _Attempts:
        """The build stage's attempts at one planned part: its build request, the reply spliced
        into ``source`` by ``place`` (``splice`` for a new part, ``replace_part`` for a rebuilt
        one), the part's gates against the N_vis ``baseline``, and each failed attempt's
        measured findings (and renders) fed back, up to ``options.attempts`` calls. Used by the
        build stage and by refine (a part added or rebuilt, issue 23.6)."""
        k = plan.index(part.name) + 1
        history = list(history or [])
        candidate: tuple[Any, PartVerdict] | None = None
        feedback = ""
        for attempt in range(1, self.options.attempts + 1):
            req = build_request(step=self.state.step, system=system, prompt=self.prompt, plan=plan,
                                header=header, committed=committed, part=part, views=views,
                                reference=self.reference, history=history, legend=legend)
            reply = self.client.complete(req)
            self.state.step += 1
            t0 = time.perf_counter()
            feedback, verdict, result = self._try_part(reply.text, part.name, source=source,
                                                       baseline=baseline, place=place)
            if verdict is not None and verdict.compiled:
                if verdict.ok:
                    return _Attempts(result, verdict, attempt, overhead + time.perf_counter() - t0)
                candidate = (result, verdict)
            self.progress("build", f"part {k}/{len(plan.parts)} {part.name}: attempt {attempt} failed: "
                          f"{feedback.splitlines()[0] if feedback else ''}")
            self.dir.attempt(self.state, part.name, attempt, feedback)
            retry_views, note = ([], "") if attempt == self.options.attempts else \
                self._attempt_views(verdict, part.name)
            overhead += time.perf_counter() - t0
            history += [Message.assistant(reply.text), Message.user(
                f"Part {part.name} did not pass. Fix every problem and reply with all five blocks again:\n"
                + feedback + note, *retry_views)]
        if candidate is not None:
            return _Attempts(candidate[0], candidate[1], self.options.attempts, overhead, feedback)
        return _Attempts(None, None, self.options.attempts, overhead, feedback)

    def _attempt_views(self, verdict: PartVerdict | None, name: str) -> tuple[list[Image], str]:
        """Renders of a failed attempt that compiled, with part ``name``'s origin and frames drawn
        as axes (:data:`RETRY_VIEWS`), and the note that introduces them; none without feedback
        renders (``--no-feedback``) or a compiled attempt."""
        if not self.options.feedback or verdict is None or not verdict.compiled or verdict.model is None:
            return [], ""
        images, _ = self.tools.render(verdict.model, list(RETRY_VIEWS), frames_of=(name,))
        note = (f"\n\nRenders of this attempt ({captions(RETRY_VIEWS)}), with {name}'s own "
                f"origin ('{name} origin') and every frame it publishes drawn as axes at their "
                f"assembly poses: X red, Y green, Z blue.")
        pair = pair_finding(verdict.errors)
        if pair is not None:  # the worst pair finding: the two in colour where they meet
            focus = f"{pair.part}+{pair.other}"
            close, _ = self.tools.render(verdict.model, list(PAIR_VIEWS), close_up=focus)
            images += [Image(img.png, f"closeup_{pair.part}_{pair.other}_{img.name}") for img in close]
            note += (f" Then a close-up of {pair.part} and {pair.other} where they meet "
                     f"({captions(PAIR_VIEWS)}; the two in colour, the other parts ghosted grey), for: "
                     f"{pair.message[:300]}")
        return images, note

    def _try_part(self, text: str, name: str, *, source: str | None = None, baseline: int | None = None,
                  place: Callable[..., Any] = splice) -> tuple[str, PartVerdict | None, Any]:
        """Parse, splice (into ``source``, default the committed program) and gate one reply
        (against ``baseline``, default the committed N_vis): (feedback, verdict or None, splice
        result)."""
        source = self.state.source if source is None else source
        baseline = self.state.baseline if baseline is None else baseline
        try:
            blocks = parse_reply(text)
            result = place(source or empty_program(self.prompt), blocks)
        except SpliceError as exc:
            return f"- {exc}", None, None
        if result.part != name:
            return (f"- the body defines part {result.part!r}; this call writes part {name!r}",
                    None, None)
        verdict = self.tools.gate_part(result.source, name, baseline=baseline, name=self.name)

        def where(line: int) -> str:  # a line of the reply's own block, not of the spliced program
            at = result.reply_line(line)
            return f"line {at[1]} of your {at[0]} block" if at else f"program line {line}"
        if not verdict.compiled:
            return findings_text(verdict.errors, where=where), verdict, result
        return (findings_text(verdict.errors, where=where) if verdict.errors else ""), verdict, result

    def _commit(self, result: Any, verdict: PartVerdict, *, overhead: float, warning: str = "") -> None:
        t0 = time.perf_counter()
        st = self.state
        st.source = result.source
        st.committed.append(CommittedPart(result.part, result.as_reply(), warning))
        st.baseline = max(st.baseline, verdict.n_vis) if warning else verdict.n_vis
        self._model = verdict.model
        from ..run import settle
        settle()  # the committed baseline is long-lived: later collections skip it
        self.dir.commit(st, result.part)
        st.per_part_s[result.part] = round(overhead + time.perf_counter() - t0, 4)

    def _build_unplanned(self, system: str) -> None:
        """--no-plan: the model names and writes each next part until it answers DONE."""
        while len(self.state.committed) + len(self.state.skipped) < self.options.max_parts:
            names = [c.name for c in self.state.committed]
            views, legend = self._views()
            msgs = [Message.user(f"Object to build: {self.prompt}\n\nThere is no plan: choose the next "
                                 f"part yourself, mated to parts already built, and write its five blocks; "
                                 f"reply with the single word {DONE_WORD} when the object is complete."
                                 f"\nParts so far: {', '.join(names) or 'none'}", *self.refs())]
            if self.state.source:
                msgs.append(Message.user(f"The program so far:\n```python\n{self.state.source}```", *views))
            text = self.call("build", system, msgs)
            if text.strip().upper().rstrip(".") == DONE_WORD:
                break
            feedback, verdict, result = self._try_part(text, _body_name(text) or "?")
            if verdict is not None and verdict.compiled:
                self._commit(result, verdict, overhead=0.0,
                             warning="; ".join(f.message for f in verdict.errors[:3]))
                self.progress("build", f"part {len(self.state.committed)} {result.part}: committed")
            else:
                self._skip(_body_name(text) or f"part_{len(names) + 1}", feedback.splitlines()[0] if feedback else "")
        if not self.state.committed:
            raise StagedError("no part could be built")

    # refine ----------------------------------------------------------------------------------

    def stage_refine(self) -> None:
        if not self.options.refine:
            return
        model = self._current_model()
        parts = ", ".join(p.name for p in model.parts) if model else ""
        intro = (f"Object: {self.prompt}\nParts: {parts}\n\nThe program:\n```python\n{self.state.source}```\n\n"
                 "Start by rendering views of the build.")
        self._refine_plan, self._refine_commits = self.plan, {}
        source, self.refine_report = refine(self, self.state.source, intro=intro,
                                            max_edits=self.options.max_edits,
                                            max_actions=self.options.max_actions)
        self.state.refine = self.refine_report = _plain(self.refine_report)
        if source != self.state.source:
            self.state.source = source
            self._model = None
        # parts refine added or rebuilt through the build path join the plan and the log
        if self._refine_plan is not None and self._refine_commits:
            self.state.plan = self._refine_plan.as_dict()
            by_name = {c.name: k for k, c in enumerate(self.state.committed)}
            for name, part in self._refine_commits.items():
                if name in by_name:
                    self.state.committed[by_name[name]] = part
                else:
                    self.state.committed.append(part)

    # refine routed back to the build stage (issue 23.6) -----------------------------------------

    def _refine_attempts(self, plan: Plan, part: PlannedPart, source: str, *, baseline: int,
                         place: Callable[..., Any], note: str) -> _Attempts:
        """The build stage's attempts at ``part`` from inside refine: its build request over the
        whole current program (refine's edits included), then the same splice and gates."""
        system = template("build_system").replace("{reference}", reference())
        views, legend = [], ""
        if self.options.feedback:
            try:
                model = self.tools.compile_model(source, self.name)
                views, legend = self.tools.render(
                    model, list(self.options.views) if self.options.views else None)
            except ProceduraError:
                pass
        return self._attempts(system, plan, part, source=source, baseline=baseline, place=place,
                              views=views, legend=legend, header=source, committed=(),
                              history=[Message.user(note)])

    def add_part(self, source: str, *, name: str, what: str, partner: str, mate_type: str,
                 nominal: str, detail: str, baseline: int) -> tuple[str, str]:
        """Refine's ``add_part``: a new part planned after the others, mated to ``partner``, built
        through the build path; (program, note) or EditRefused."""
        from .actions import EditRefused
        plan = self._refine_plan
        if plan is None:
            raise EditRefused("there is no plan to add a part to (a --no-plan run)")
        try:
            new_plan = parse_plan({"parts": [p.as_dict() for p in plan.parts] + [
                {"name": name, "detail": detail, "description": what,
                 "mates": [{"partner": partner, "type": mate_type, "nominal": nominal}]}]})
        except PlanError as exc:
            raise EditRefused("; ".join(exc.problems)) from None
        note = (f"Refine adds this part: the reviewer asked for it. The program above is the whole "
                f"current program; write only the new part {name} ({what}), mated to {partner} "
                f"({mate_type}, nominal {nominal}), in the five blocks.")
        got = self._refine_attempts(new_plan, new_plan.part(name), source, baseline=baseline,
                                    place=splice, note=note)
        if not got.ok:
            raise EditRefused(f"{name} was not added: its build failed {got.attempt} attempt(s): "
                              + " ".join((got.feedback or "").split())[:600])
        self._refine_plan = new_plan
        self._refine_commits[name] = CommittedPart(name, got.result.as_reply())
        return got.result.source, f"part {name} added, mated to {partner} (build attempt {got.attempt})"

    def rebuild_part(self, source: str, name: str, *, reasons: list[str], mates: list[str],
                     baseline: int) -> tuple[str, str]:
        """A part refine could not fix in place, rebuilt from its build request (replacing it);
        a mate that could not be satisfied goes back to the plan's mate: the request says so,
        and the plan takes the mates the rebuilt part declares. (program, note) or EditRefused."""
        from .actions import EditRefused
        plan = self._refine_plan
        if plan is None or name not in plan.names:
            raise EditRefused(f"{name} has no build request (it is not in the plan)")
        part = plan.part(name)
        note = (f"Part {name} is rebuilt from its build request: {len(reasons)} edits of it in "
                f"place were refused:\n" + "\n".join(f"- {r[:400]}" for r in reasons[-3:]) +
                f"\nThe program above holds its current version; reply with all five blocks of "
                f"{name}: they replace it.")
        if mates:
            planned = "; ".join(f"to {m.partner}: {m.type}, nominal {m.nominal}" for m in part.mates)
            note += (f"\nIts mate(s) {', '.join(mates)} could not be satisfied. The plan's mates for "
                     f"it: {planned or 'none'}. Declare mates that can be met (another type, or "
                     f"another earlier part as partner, if a planned one cannot be): the plan "
                     f"takes the mates you declare.")
        got = self._refine_attempts(plan, part, source, baseline=baseline, place=replace_part, note=note)
        if not got.ok:
            raise EditRefused(f"the rebuild of {name} failed {got.attempt} attempt(s): "
                              + " ".join((got.feedback or "").split())[:600])
        done = f"{name} rebuilt (build attempt {got.attempt})"
        declared = tuple(PlannedMate(m.parent, m.type, m.nominal_name)
                         for m in (got.verdict.model.mates if got.verdict.model else []) if m.child == name)
        if mates and declared and declared != part.mates:
            rows = [p.as_dict() for p in plan.parts]
            rows[plan.index(name)]["mates"] = [m.as_dict() for m in declared]
            try:
                self._refine_plan = parse_plan({"parts": rows})
                done += "; the plan's mates now read " + "; ".join(
                    f"to {m.partner}: {m.type}, nominal {m.nominal}" for m in declared)
            except PlanError as exc:
                done += f"; the plan keeps its mates ({exc})"
        self._refine_commits[name] = CommittedPart(name, got.result.as_reply())
        return got.result.source, done


    # materials -------------------------------------------------------------------------------

    def stage_materials(self) -> None:
        """The materials stage (:mod:`.materials`) on the refined program."""
        source = materials_stage(self)
        if source != self.state.source:
            self.state.source, self._model = source, None

    # articulation ----------------------------------------------------------------------------

    def stage_articulation(self) -> None:
        """Evidence, the planning call, gated mate edits, the battery and one battery fix
        (:mod:`.articulation`); the build it made is reused by the finish when nothing changed."""
        if self.options.articulation and self.state.source:
            from .articulation import ArticulationStage
            stage = ArticulationStage(self)
            try:
                source = stage.run(self.state.source)
            except LLMError:  # the provider failed: the run ends on it, as in every stage
                raise
            except ProceduraError as exc:  # the program as refined ships; the finish reports it
                source = self.state.source
                stage.report["findings"].append(f"the articulation stage stopped: {exc}")
            self.articulation_report = self.state.articulation = _plain(stage.report)
            self._prebuilt = (stage.built_source, stage.build)
            if source != self.state.source:
                self.state.source, self._model = source, None

    # finish ----------------------------------------------------------------------------------

    def stage_finish(self) -> StagedResult:
        return self._finish("ok")

    def _finish(self, status: str, message: str = "") -> StagedResult:
        st = self.state
        result = StagedResult(status, self.out_dir, st, refine=self.refine_report, message=message)
        if st.source:
            pre = self._prebuilt  # the articulation stage's build of this very program
            if pre[1] is not None and pre[0] == st.source:
                build = pre[1]
                self.progress("finish", "the articulation stage's build of this program is the run "
                                        "directory")
            else:
                self.progress("finish", "building the run directory (exports, gates"
                              + (", battery)" if self.options.simulate else ")"))
                build = self.tools.final_build(st.source, self.out_dir, simulate=self.options.simulate,
                                               formats=self.options.formats,
                                               progress=lambda line: self.progress("finish", line))
            result.build = build
            if status == "ok" and not build.ok:
                result.status, result.message = build.status, build.reason
            if status == "ok":
                self._advance("done")
        self._write_report(result)
        return result

    def interrupted(self) -> None:
        """Ctrl-C or SIGTERM: report.json says ``interrupted`` and where (state.json already holds
        every committed part, so ``--resume`` continues from here)."""
        st = self.state
        self._write_report(StagedResult("interrupted", self.out_dir, st, refine=self.refine_report,
                                        message=f"interrupted during the {st.stage} stage "
                                                f"(model call {st.step}); continue with --resume "
                                                f"{self.out_dir}"))

    def _write_report(self, result: StagedResult) -> None:
        path = self.out_dir / "report.json"
        report = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
        st = self.state
        per_part = list(st.per_part_s.values())
        report.update({
            "status": result.status, "mode": "staged",
            "reference": self.reference_info,
            "options": {k: v for k, v in self.options.__dict__.items() if k != "views"},
            "prompt": st.prompt,
            "plan": st.plan, "plan_repairs": st.repairs,
            "committed": [{"name": c.name, "warning": c.warning} for c in st.committed],
            "skipped": st.skipped,
            "refine": result.refine,
            "materials": st.materials,
            **({"articulation": self.articulation_report} if self.articulation_report else {}),
            "overhead_per_part_s": st.per_part_s,
            "overhead_median_s": sorted(per_part)[len(per_part) // 2] if per_part else None,
            "usage": self.client.ledger.summary(),
        })
        if result.message:
            report["reason"] = result.message
        write_atomic(path, json.dumps(report, indent=2, ensure_ascii=False, default=str) + "\n")
        from ..run.report import write_summary
        write_summary(self.out_dir, report)  # with the prompt and the staged run's status


def _plain(report: dict[str, Any]) -> dict[str, Any]:
    """A stage report as plain JSON values (it is kept in state.json)."""
    return json.loads(json.dumps(report, default=str))


def _body_name(text: str) -> str | None:
    try:
        import ast
        body = ast.parse(parse_reply(text).body).body
        return body[0].name if body and isinstance(body[0], ast.FunctionDef) else None
    except (SpliceError, SyntaxError):
        return None


def generate_staged(prompt: str | None, out_dir: Path, *, model: str, base_url: str | None = None,
                    options: StagedOptions = StagedOptions(), image: bytes | None = None,
                    image_model: str | None = None,
                    max_cost_usd: float | None = None, timeout_s: float | None = None,
                    resume: bool = False, progress: Progress | None = None) -> StagedResult:
    """Run (or resume) a staged generation into ``out_dir`` with the model ``model``.

    Args:
        prompt: the object to build (None on resume, or with a replay tape: the tape's own).
        out_dir: the run directory.
        model: ``provider:model``.
        image: a reference PNG (stage 1); without one, ``image_model`` (``provider:model`` of
            an image-capable provider) synthesises one, and a replayed tape that recorded a
            ``reference_image`` call gives its image back; else the run has no reference.
        resume: continue the run recorded in ``out_dir/state.json`` (with its reference).

    Raises:
        ConfigError / ProviderError: bad model name or key, unreachable endpoint (one line).
        ResumeError: ``resume`` on a directory without a staged run.
    """
    from ..llm import Ledger, Transcript, get_provider, preflight
    from ..llm.replay import ReplayProvider
    state = RunDir(out_dir).load() if resume else None
    provider = preflight(model, base_url=base_url)
    if timeout_s is not None:  # checked above; rebuilt with the caller's reply timeout
        provider = get_provider(model, base_url=base_url, timeout_s=timeout_s)
    if isinstance(provider, ReplayProvider):
        if state is not None:
            provider.skip_before(state.step)
        if prompt is None:
            prompt = tape_prompt(provider.path)
        options, notes = tape_options(provider.path, options)
        for note in notes:
            log.info("%s", note)
    if state is None:
        if not prompt:
            raise StagedError("no prompt: give one, or replay a tape that records one")
        state = RunState(prompt)
    out_dir.mkdir(parents=True, exist_ok=True)
    client = Client(provider, ledger=Ledger(max_cost_usd=max_cost_usd),
                    transcript=Transcript(out_dir / "transcript.jsonl"))
    try:
        ref = _reference(client, state, out_dir, image=image, image_model=image_model,
                         resume=resume, progress=progress)
        run = StagedRun(state.prompt, out_dir, client=client, options=options, image=ref.png,
                        progress=progress, state=state)
        run.reference_info = ref.as_dict()
        with interrupt.on_interrupt(run.interrupted):
            try:
                return run.run()
            except KeyboardInterrupt:  # library use: no watcher thread, Ctrl-C raised here
                run.interrupted()
                raise
    finally:
        client.close()  # a replay tape checks here that it was fully consumed


def _reference(client: Client, state: RunState, out_dir: Path, *, image: bytes | None,
               image_model: str | None, resume: bool, progress: Progress | None) -> Reference:
    """Stage 1: the run's reference image (see :mod:`procedura_brep.agent.reference`)."""
    from ..llm import preflight
    from ..llm.replay import ReplayProvider
    if resume:
        return reference_image.load(out_dir)
    if image is not None:
        ref = Reference(image, "file")
    else:
        ref = Reference(None, "none")
        image_client = None
        if image_model:
            image_client = Client(preflight(image_model), ledger=client.ledger,
                                     transcript=client.transcript)
        elif isinstance(client.provider, ReplayProvider) and \
                reference_image.ROLE in tape_roles(client.provider.path):
            image_client = client
        if image_client is not None:
            if progress is not None:
                progress("reference", f"synthesising a reference image with {image_client.provider.name}")
            ref = reference_image.synthesise(image_client, state.prompt, step=state.step)
            state.step += 1
    ref.save(out_dir)
    RunDir(out_dir).save(state)
    return ref


MATERIAL_ROLES = frozenset({"materials", "material_critic", "subparts"})
ARTICULATION_ROLES = frozenset({"articulation", "battery_fixer"})


def tape_roles(path: Path) -> set[str]:
    """The roles of the model calls a tape recorded (empty if it cannot be read)."""
    p = path / "transcript.jsonl" if path.is_dir() else path
    roles: set[str] = set()
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except OSError:
        return roles
    for line in lines:
        try:
            rec = json.loads(line)
        except ValueError:
            continue
        if isinstance(rec, dict) and isinstance(rec.get("role"), str):
            roles.add(rec["role"])
    return roles


def tape_options(path: Path, options: StagedOptions) -> tuple[StagedOptions, list[str]]:
    """``options`` with the model-calling stages a tape did not record switched off, so a tape
    recorded before a stage existed still replays; returns the notes saying which were."""
    roles = tape_roles(path)
    notes = []
    changes: dict[str, bool] = {}
    for stage, stage_roles in (("materials", MATERIAL_ROLES), ("articulation", ARTICULATION_ROLES)):
        if getattr(options, stage) and not roles & stage_roles:
            changes[stage] = False
            notes.append(f"the tape records no {stage} calls: the {stage} stage is off for this replay")
    return (replace(options, **changes) if changes else options), notes


def tape_prompt(path: Path) -> str | None:
    """The prompt a staged tape was recorded for (its first record's ``prompt`` field)."""
    p = path / "transcript.jsonl" if path.is_dir() else path
    try:
        first = json.loads(p.read_text(encoding="utf-8").split("\n", 1)[0])
    except (OSError, ValueError):
        return None
    return first.get("prompt") if isinstance(first, dict) else None
