"""The articulation stage (docs/agent.md, "The articulation stage"): evidence, one planning call,
gated mate edits, the MuJoCo battery, and the battery fixer in rounds on a failure.

1. Geometric evidence (:func:`procedura_brep.articulation.mates_evidence`) and the links and
   joints the mates make now are shown to the model with the program.
2. One ``articulation`` call returns a strict JSON plan (:mod:`.articulation_plan`); a malformed
   reply is retried with every problem listed (up to ``StagedOptions.plan_attempts`` calls).
3. Each planned change is one program edit (:func:`procedura_brep.program.mate_edit.set_mate`),
   compiled and gated: refused when it does not compile, adds a gate error, or breaks the tree;
   a promotion of a static mate is refused unless the evidence supports it
   (:func:`.articulation_plan.promotion_refusal`). The program stays the one source.
4. With the battery on, the run directory is built (exports, gates, battery). On a failed check
   a ``battery_fixer`` call sees the check (id, message, measured values), the other failing
   checks, the earlier rounds, up to 8 rendered frames of the failing phase and the program,
   and returns one action (``set_mate``, ``set_param``, ``edit_part`` or ``give_up``), gated
   the same way; the run directory is rebuilt and the battery rerun. Rounds go on until the
   battery passes, a round makes no progress (nothing applied, or as many failing checks or
   more; one that adds failing checks is undone) or :data:`BATTERY_ROUNDS` are spent. The
   finish stage rebuilds only if the program differs from the last build.

Everything lands in ``report.json``'s ``articulation`` section and in ``history/``.
"""

from __future__ import annotations

import json
import logging
from typing import Any

from ..articulation import Articulation, ArticulationError, articulate, mates_evidence
from ..errors import EditError, ProceduraError
from ..findings import blocking
from ..llm import Image, Message
from ..mates import TYPES
from ..paths import write_atomic
from ..program.mate_edit import REMOVE, set_mate
from ..program.model import CompiledModel
from ..text import did_you_mean
from .articulation_plan import (
    ArticulationPlan,
    ArticulationPlanError,
    JointEdit,
    _json_object,
    evidence_text,
    parse_articulation,
    promotion_refusal,
)
from .prompts import template
from .runstate import history_path
from .stages import StageHost

log = logging.getLogger(__name__)

#: The battery fixer's actions.
FIXER_ACTIONS = ("set_mate", "set_param", "edit_part", "give_up")
#: Calls the battery fixer gets to produce a readable action.
FIXER_ATTEMPTS = 2
#: Characters of a failing check's measured values shown to the fixer.
MEASURED_CHARS = 3000
#: Battery-fixer rounds (fix, rebuild, rerun the battery) at most.
BATTERY_ROUNDS = 3


class FixerError(ProceduraError):
    """The battery fixer's reply is not one usable action."""


def _errors(model: CompiledModel, source: str) -> set[tuple[str, str | None, str | None]]:
    from ..gates import check_model
    report = check_model(model, source)
    return {(f.code, f.part, f.mate) for f in blocking(report.findings)}


class ArticulationStage:
    """One run of the stage over ``source``; :meth:`run` returns the new program and the report."""

    def __init__(self, host: StageHost) -> None:
        self.host = host
        self.report: dict[str, Any] = {"edits": [], "findings": []}
        self.build: Any = None  # the run-directory build of the final program, when made here
        self.built_source: str | None = None
        self._gates: dict[str, set] = {}

    # gating ----------------------------------------------------------------------------------

    def _compile(self, source: str) -> CompiledModel:
        return self.host.tools.compile_model(source, self.host.name)

    def gate(self, before: str, after: str) -> tuple[CompiledModel | None, str | None]:
        """(model, None) when ``after`` may replace ``before``; (None, why) when refused."""
        try:
            model = self._compile(after)
        except ProceduraError as exc:
            return None, f"it does not compile: {exc}"
        if before not in self._gates:
            self._gates[before] = _errors(self._compile(before), before)
        errs = _errors(model, after)
        new = sorted(errs - self._gates[before], key=str)
        if new or not model.parts:
            bad = blocking(model.findings)[:3]
            text = "; ".join(f.message for f in bad) or ", ".join(f"{c} ({p or m})" for c, p, m in new[:3])
            return None, f"it adds gate errors: {text}"
        try:
            articulate(model)
        except ArticulationError as exc:
            return None, f"the mates no longer make a tree: {exc}"
        self._gates[after] = errs
        return model, None

    def _history(self, source: str, what: str) -> None:
        write_atomic(history_path(self.host.out_dir, what), source)

    # the planning call -----------------------------------------------------------------------

    def plan(self, source: str, model: CompiledModel, evidence: dict[str, Any],
             art: Articulation | None) -> ArticulationPlan | None:
        system = template("articulation_system")
        user = (template("articulation_user").replace("{prompt}", self.host.prompt)
                .replace("{evidence}", evidence_text(model, evidence, art)).replace("{program}", source))
        msgs = [Message.user(user, *self.host.refs())]
        problems: list[list[str]] = []
        for attempt in range(1, self.host.options.plan_attempts + 1):
            text = self.host.call("articulation", system, msgs, max_tokens=4000)
            try:
                plan = parse_articulation(text, model)
            except ArticulationPlanError as exc:
                problems.append(exc.problems)
                self.host.progress("articulation", f"attempt {attempt}: {exc}")
                msgs += [Message.assistant(text), Message.user(
                    "The articulation plan has problems; fix all of them and reply with the whole "
                    "JSON object again:\n" + "\n".join(f"- {p}" for p in exc.problems))]
                continue
            self.report.update(plan=plan.raw, attempts=attempt, plan_problems=problems)
            return plan
        self.report.update(plan=None, attempts=len(problems), plan_problems=problems)
        self.report["findings"].append(f"no usable articulation plan after {len(problems)} attempts; "
                                       "the mates are kept as they are")
        return None

    def _edit_source(self, source: str, model: CompiledModel, e: JointEdit,
                     evidence: dict[str, Any]) -> str:
        """The program with edit ``e`` applied (raises EditError when it cannot be)."""
        mate = next((m for m in model.mates if m.name == e.mate), None)
        if mate is None:
            names = [m.name for m in model.mates]
            raise EditError(f"no mate named {e.mate!r}{did_you_mean(e.mate, names)}; mates: {', '.join(names)}")
        new_type = e.promote_to or mate.type
        mtype = TYPES[new_type]
        if e.promote_to:
            why = promotion_refusal(mate, e.promote_to, evidence)
            if why:
                raise EditError(why)
        bad = sorted(k for k in e.options if k not in mtype.options)
        if bad:
            raise EditError(f"option(s) {', '.join(bad)} do not apply to a {new_type} mate")
        opts: dict[str, Any] = dict(e.options)
        fit = None
        if e.promote_to:
            opts.update({k: REMOVE for k in mate.options if k not in mtype.options})
            fit = mate.fit.get("fit") if mate.fit.get("fit") in mtype.fits else mtype.default_fit
        elif all(mate.options.get(k) == v for k, v in opts.items()):
            return source
        return set_mate(source, e.mate, type=e.promote_to, fit=fit, options=opts)

    def apply(self, source: str, model: CompiledModel, plan: ArticulationPlan,
              evidence: dict[str, Any]) -> str:
        """Apply the plan's edits one at a time, each gated; refused ones are logged."""
        for e in plan.edits:
            row: dict[str, Any] = {"mate": e.mate, "options": {k: v for k, v in e.options.items()},
                                   "promote_to": e.promote_to}
            try:
                new = self._edit_source(source, model, e, evidence)
            except EditError as exc:
                new, why = None, str(exc)
            else:
                if new == source:
                    row.update(accepted=True, note="unchanged")
                    self.report["edits"].append(row)
                    continue
                got, why = self.gate(source, new)
                if got is not None:
                    source, model = new, got
                    self._history(source, f"articulation-{e.mate}")
            row.update(accepted=new is not None and why is None, **({"reason": why} if why else {}))
            self.report["edits"].append(row)
            self.host.progress("articulation", f"{e.mate}: " + ("applied" if row["accepted"] else f"refused ({why})"))
        return source

    def compare(self, plan: ArticulationPlan, art: Articulation) -> None:
        """Record where the plan's links, base and wheels differ from what the mates and the
        evidence make (findings; nothing is changed)."""
        out = self.report["findings"]
        if plan.base is not None and plan.base != art.base:
            out.append(f"base: the plan says {plan.base}, the articulation makes it {art.base} "
                       f"(the base is free exactly when wheels are found by evidence)")
        if plan.wheels is not None and sorted(plan.wheels) != sorted(art.wheels):
            out.append(f"wheels: the plan lists {sorted(plan.wheels)}, the evidence finds "
                       f"{sorted(art.wheels)}")
        if plan.links is not None:
            want = sorted(sorted(lk) for lk in plan.links)
            have = sorted(sorted(lk.parts) for lk in art.links)
            if want != have:
                out.append(f"links: the plan groups {want}, the static mates make {have}")

    # battery ---------------------------------------------------------------------------------

    def battery(self, source: str) -> list[dict[str, Any]]:
        """Build the run directory of ``source`` with the battery; the failed checks."""
        opts = self.host.options
        self.build = self.host.tools.final_build(
            source, self.host.out_dir, simulate=True, formats=opts.formats,
            progress=lambda line: self.host.progress("articulation", f"battery build: {line}"))
        self.built_source = source
        bat = self.build.report.get("battery") or {}
        failed = [c for c in bat.get("checks", []) if not c.get("passed") and not c.get("skipped")]
        verdict = {"passed": bool(bat.get("passed", False)) if bat else None,
                   "failed": [c.get("id") for c in failed], "status": self.build.status}
        self.report.setdefault("battery_first", verdict)
        self.report["battery_last"] = verdict
        return failed

    def frames(self, check: dict[str, Any], round_no: int = 1) -> list[Image]:
        """Up to 8 frames of the failing phase (the battery's own, else drawn again here),
        kept under ``history/articulation/`` as ``<check>_<k>.png`` (``<check>_r<n>_<k>.png``
        from round 2 on, so each round's row names its own frames)."""
        out_dir = self.host.out_dir
        keep = out_dir / "history" / "articulation"
        paths = [out_dir / p for p in check.get("frames") or []]
        if not paths:
            from ..sim.replay_frames import failure_frames
            try:
                paths = [keep / p for p in failure_frames(out_dir, str(check.get("id")),
                                                          str(check.get("message", "")), keep)]
            except Exception as exc:  # frames are best effort: the fixer still gets the check
                log.warning("could not draw battery frames: %s", exc)
                paths = []
        images = []
        stem = f"{check.get('id')}" + (f"_r{round_no}" if round_no > 1 else "")
        for k, p in enumerate(paths[:8]):
            try:
                data = p.read_bytes()
            except OSError:
                continue
            write_atomic(keep / f"{stem}_{k}.png", data)
            images.append(Image(data, f"{stem}_{k}"))
        return images

    def fix(self, source: str, failed: list[dict[str, Any]], art: Articulation | None,
            rounds: list[dict[str, Any]] | None = None) -> tuple[str, dict[str, Any]]:
        """One battery-fixer call on the first failed check (the others listed) and its gated
        edit; returns the (possibly edited) program and the round's report row. ``rounds``: the
        earlier rounds, told to the fixer."""
        check = failed[0]
        images = self.frames(check, len(rounds or []) + 1)
        measured = json.dumps(check.get("measured", {}), default=str)[:MEASURED_CHARS]
        joints = "\n".join(f"- {j.name}: {j.type}, {j.parent} -> {j.child}, limits "
                           f"{j.mate.options.get('limits')}" for j in (art.joints if art else []))
        others = "\n".join(f"- {c.get('id')} ({c.get('name')}): {str(c.get('message', ''))[:300]}"
                           for c in failed[1:]) or "- none"
        earlier = "\n".join(_round_line(r) for r in rounds or []) or "- none (this is the first round)"
        user = (template("battery_fixer_user").replace("{prompt}", self.host.prompt)
                .replace("{check}", f"{check.get('id')} ({check.get('name')})")
                .replace("{message}", str(check.get("message", ""))).replace("{measured}", measured)
                .replace("{limits}", json.dumps(check.get("limits", {}), default=str))
                .replace("{others}", others).replace("{rounds}", earlier)
                .replace("{round}", str(len(rounds or []) + 1)).replace("{max_rounds}", str(BATTERY_ROUNDS))
                .replace("{joints}", joints or "- none").replace("{frames}", str(len(images)))
                .replace("{program}", source))
        msgs = [Message.user(user, *images)]
        row: dict[str, Any] = {"round": len(rounds or []) + 1, "check": check.get("id"),
                               "message": check.get("message"),
                               "failing_before": [c.get("id") for c in failed],
                               "frames": [f"history/articulation/{i.name}.png" for i in images]}
        action = None
        for _ in range(FIXER_ATTEMPTS):
            text = self.host.call("battery_fixer", template("battery_fixer_system"), msgs, max_tokens=8000)
            try:
                action = parse_fixer(text)
                break
            except FixerError as exc:
                msgs += [Message.assistant(text), Message.user(f"{exc}. Reply with one JSON action.")]
        row["action"] = action
        if action is None:
            row.update(accepted=False, reason="no readable action")
            return source, row
        if action["action"] == "give_up":
            row.update(accepted=False, reason=f"give_up: {action.get('reason', '')}")
            return source, row
        try:
            new = self._fixer_source(source, action)
        except (EditError, ProceduraError) as exc:
            row.update(accepted=False, reason=str(exc))
            return source, row
        model, why = self.gate(source, new)
        row.update(accepted=model is not None, **({"reason": why} if why else {}))
        self.host.progress("articulation", f"battery fixer round {row['round']} {action['action']}: "
                           + ("applied" if model is not None else f"refused ({why})"))
        if model is None:
            return source, row
        self._history(new, f"battery_fixer-{action['action']}")
        return new, row

    def fix_rounds(self, source: str, failed: list[dict[str, Any]], art: Articulation | None) -> str:
        """The battery fixer in rounds (issue 23.6): fix, rebuild, rerun the battery, until it
        passes, a round makes no progress (no change applied, or as many failing checks or
        more: a round that adds failing checks is undone) or :data:`BATTERY_ROUNDS` are spent.
        Each round is a row of ``report["battery_fixer"]``."""
        rounds: list[dict[str, Any]] = self.report.setdefault("battery_fixer", [])
        while failed and len(rounds) < BATTERY_ROUNDS:
            new, row = self.fix(source, failed, art, rounds)
            rounds.append(row)
            if new == source:
                row["stop"] = "no change applied"
                break
            after = self.battery(new)
            row["failing_after"] = [c.get("id") for c in after]
            if len(after) > len(failed):
                row["stop"] = (f"no progress: {len(after)} failing checks after the edit, "
                               f"{len(failed)} before; the edit is undone")
                self.host.progress("articulation", f"battery fixer round {row['round']}: {row['stop']}")
                break  # the program before the edit ships (the finish rebuilds it)
            source = new
            try:
                art = articulate(self._compile(source))
            except (ArticulationError, ProceduraError):
                pass
            if after and len(after) == len(failed):
                row["stop"] = f"no progress: still {len(after)} failing check(s)"
                break
            failed = after
        else:
            if failed and rounds:
                rounds[-1]["stop"] = f"the round bound ({BATTERY_ROUNDS}) is reached"
        if rounds and not failed:
            rounds[-1]["stop"] = "the battery passes"
        return source

    def _fixer_source(self, source: str, action: dict[str, Any]) -> str:
        if action["action"] == "set_param":
            from ..program.edit import set_params
            return set_params(source, {action["name"]: action["value"]})
        if action["action"] == "edit_part":
            from ..program.splice import replace_part
            result = replace_part(source, action["reply"])
            if result.part != action["part"]:
                raise EditError(f"the reply defines part {result.part!r}, not {action['part']!r}")
            return result.source
        model = self._compile(source)
        e = JointEdit(action["mate"], {k: (tuple(v) if isinstance(v, list) else v)
                                       for k, v in action.items() if k not in ("action", "mate")})
        new = self._edit_source(source, model, e, {"parts": {}})
        if new == source:
            raise EditError(f"set_mate {action['mate']}: nothing changes")
        return new

    # the stage -------------------------------------------------------------------------------

    def run(self, source: str) -> str:
        """Run the stage over ``source``; returns the program to finish with."""
        model = self._compile(source)
        evidence = mates_evidence(model)
        try:
            art: Articulation | None = articulate(model, evidence=evidence)
        except ArticulationError as exc:
            art = None
            self.report["findings"].append(f"the mates do not make a tree: {exc}")
        self.report["evidence"] = {
            "symmetry": {n: r["symmetry"].get("kind") for n, r in evidence["parts"].items()},
            "contacts": len(evidence["contacts"])}
        plan = self.plan(source, model, evidence, art)
        if plan is not None:
            source = self.apply(source, model, plan, evidence)
            try:
                art = articulate(self._compile(source))
                self.compare(plan, art)
            except (ArticulationError, ProceduraError) as exc:
                self.report["findings"].append(str(exc))
        if art is not None:
            self.report["articulation"] = summary(art)
        if self.host.options.simulate:
            failed = self.battery(source)
            if failed:
                source = self.fix_rounds(source, failed, art)
        return source


def _round_line(row: dict[str, Any]) -> str:
    """One earlier battery-fixer round, as the next round's fixer is told it."""
    act = row.get("action") or {}
    what = json.dumps(act, default=str)[:300] if act else "no readable action"
    verdict = "applied" if row.get("accepted") else f"refused ({row.get('reason', '')})"
    after = row.get("failing_after")
    then = f"; the battery then failed {', '.join(map(str, after)) or 'nothing'}" if after is not None else ""
    return f"- round {row.get('round')}: {row.get('check')} failed; {what}: {verdict}{then}"


def summary(art: Articulation) -> dict[str, Any]:
    """The articulation as report rows."""
    return {"links": [{"name": lk.name, "parts": lk.parts} for lk in art.links],
            "joints": [{"name": j.name, "type": j.type, "parent": j.parent, "child": j.child,
                        "drive": j.drive, "lower": j.lower, "upper": j.upper,
                        "effort": j.effort, "velocity": j.velocity} for j in art.joints],
            "wheels": list(art.wheels), "base": art.base}


def parse_fixer(text: str) -> dict[str, Any]:
    """One battery-fixer action (a fenced JSON block or a bare object).

    Raises:
        FixerError: not an object, an unknown action, or missing/bad arguments.
    """
    data = _json_object(text)
    if not isinstance(data, dict) or data.get("action") not in FIXER_ACTIONS:
        raise FixerError(f"answer with one JSON object whose \"action\" is one of {', '.join(FIXER_ACTIONS)}")
    act = data["action"]
    if act == "set_mate":
        if not isinstance(data.get("mate"), str):
            raise FixerError("set_mate takes \"mate\" (a mate name) and the options to set")
        keys = set(data) - {"action", "mate"}
        if not keys:
            raise FixerError("set_mate needs at least one option (limits, home, effort, velocity, cone)")
        bad = sorted(keys - {"limits", "home", "effort", "velocity", "cone"})
        if bad:
            raise FixerError(f"set_mate: unknown option(s) {', '.join(bad)}")
    elif act == "set_param":
        v = data.get("value")
        if not isinstance(data.get("name"), str) or isinstance(v, bool) or not isinstance(v, (int, float)):
            raise FixerError("set_param takes \"name\" (a param) and a numeric \"value\"")
    elif act == "edit_part":
        if not isinstance(data.get("part"), str) or not isinstance(data.get("reply"), str):
            raise FixerError("edit_part takes \"part\" and \"reply\" (the part's five blocks)")
    return data


__all__ = ["ArticulationStage", "FixerError", "parse_fixer", "summary"]
