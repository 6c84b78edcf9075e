"""``procedura-brep revise DIR "INSTRUCTION"``: a person's change request as gated edits.

The request runs through the refine loop (:mod:`.refine`): render, a critic that reads the
request and localises it to parts, then one gated edit per diagnosis. Edits touch only the parts
named with ``--part`` (or, without it, the parts the critic names); a param may change only if
no other part reads it. Every other part's source stays byte for byte.

Each applied edit (spliced, compiled and gated) is written back to ``program.py`` (and
``state.json``) at once, besides its ``history/`` entry, so a revise that is stopped (Ctrl-C, a
provider error, its call bound) keeps every edit it made. A revise makes at most ``max_calls``
model calls (fixer and critic together); it then stops with the edits so far. It ends with a
line in ``history/revisions.jsonl`` and, when the program changed, a rebuild with the gates (and
the battery).
"""

from __future__ import annotations

import ast
import json
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ProceduraError
from ..llm import Client, Image, Message, Request, Settings
from ..paths import write_atomic
from ..program.splice import param_readers, program_parts
from ..text import did_you_mean
from .actions import EditRefused
from .prompts import part_format, template
from .refine import RefineBench, refine
from .runstate import RunDir
from .tools import Tools

log = logging.getLogger(__name__)


class ReviseError(ProceduraError):
    """The run directory or the request cannot be revised (one line naming what is wrong)."""


@dataclass
class ReviseResult:
    """How a revise ended."""

    status: str
    out_dir: Path
    source: str
    report: dict[str, Any] = field(default_factory=dict)
    build: Any = None


class _CallsSpent(ProceduraError):
    """The revise's bound on model calls is reached (the edits so far are kept)."""


class _Host:
    """The model calls and tools of one revise: the refine loop's host (a
    :class:`~.stages.StageHost` without a staged run's options or state)."""

    def __init__(self, client: Client, out_dir: Path, prompt: str, step: int, tools: Tools,
                 progress: Callable[[str, str], None], max_calls: int) -> None:
        self.client, self.out_dir, self.prompt, self.step = client, out_dir, prompt, step
        self.tools, self.name, self.progress = tools, "model", progress
        self.options = self.state = None  # a revise hosts refine alone: no staged options or state
        self.max_calls, self.calls = max_calls, 0
        self.applied = 0  # edits written back to the run directory

    def call(self, role: str, system: str, messages: list[Message], *, max_tokens: int = 8000) -> str:
        if self.calls >= self.max_calls:
            raise _CallsSpent(f"the revise's {self.max_calls} model calls are spent")
        reply = self.client.complete(Request(role, self.step, system, tuple(messages), Settings(max_tokens=max_tokens)))
        self.step += 1
        self.calls += 1
        return reply.text

    def refs(self) -> list[Image]:
        return []


def _first_step(out_dir: Path) -> int:
    """The step after the last model call recorded in the run directory."""
    state = out_dir / "state.json"
    if state.is_file():
        try:
            return int(json.loads(state.read_text(encoding="utf-8")).get("step", 0))
        except ValueError:
            pass
    tr = out_dir / "transcript.jsonl"
    steps = []
    if tr.is_file():
        for line in tr.read_text(encoding="utf-8").splitlines():
            try:
                steps.append(int(json.loads(line)["step"]))
            except (ValueError, KeyError, TypeError):
                continue
    return max(steps) + 1 if steps else 0


def _prompt_of(source: str, out_dir: Path) -> str:
    state = out_dir / "state.json"
    if state.is_file():
        try:
            return str(json.loads(state.read_text(encoding="utf-8"))["prompt"])
        except (ValueError, KeyError):
            pass
    doc = ast.get_docstring(ast.parse(source)) or "the assembly"
    return doc.strip().splitlines()[0]


class _RestrictedBench(RefineBench):
    """Edits only on the allowed parts; param changes only where no other part reads the param.
    Every edit it applies is written back to the run directory at once (:func:`_write_back`)."""

    def set_param(self, source: str, name: str, value: float) -> str:
        readers = param_readers(source).get(name, set())
        outside = sorted(readers - (self.allowed or set()))
        if self.allowed is not None and outside:
            raise EditRefused(f"param {name} is also read by {', '.join(outside)}, which this change "
                              "may not touch; add a new param in an edit_part instead")
        return _write_back(self.host, super().set_param(source, name, value))

    def edit_part(self, source: str, part: str, reply: str) -> str:
        return _write_back(self.host, super().edit_part(source, part, reply))


def _write_back(host: Any, source: str) -> str:
    """``source`` (an edit the session is about to apply: it passed its gates) as the run
    directory's program.py and state.json source."""
    _save(host.out_dir, source, host.step)
    host.applied += 1
    return source


def _save(out_dir: Path, source: str, step: int) -> None:
    """program.py, and a staged run's state.json (its source and next model-call step)."""
    rd = RunDir(out_dir)
    if not rd.state_path.is_file():
        write_atomic(out_dir / "program.py", source)
        return
    state = rd.load()
    state.source, state.step = source, step
    rd.save(state)  # program.py first, then state.json


def revise(out_dir: Path, instruction: str, *, model: str, base_url: str | None = None,
           parts: list[str] | None = None, max_edits: int = 4, max_actions: int = 24,
           max_calls: int = 32, simulate: bool = True,
           progress: Callable[[str, str], None] | None = None,
           tools: Tools | None = None) -> ReviseResult:
    """Apply ``instruction`` to the program in ``out_dir`` through diagnosed, gated edits.

    Ends after at most ``max_calls`` model calls (``max_actions`` fixer actions among them),
    with the program rewritten, rebuilt and gated, or with the reason in ``report["verdict"]``
    (``give_up``, ``budget``: the edits are spent, ``steps``: the actions are spent, ``calls``:
    the model calls are spent); the edits applied before the end are kept either way.

    Raises:
        ReviseError: no program in ``out_dir``, an empty instruction, or a ``--part`` that is not a part.
        ConfigError / ProviderError: the model cannot be used.
    """
    from ..llm import Ledger, Transcript, preflight
    from ..llm.replay import ReplayProvider
    prog = out_dir / "program.py"
    if not prog.is_file():
        raise ReviseError(f"cannot revise {out_dir}: no program.py (build or generate into it first)")
    if not instruction.strip():
        raise ReviseError("the change request is empty; say what to change, e.g. \"make the wheels 20% bigger\"")
    source = prog.read_text(encoding="utf-8")
    names = program_parts(source)
    unknown = [p for p in parts or [] if p not in names]
    if unknown:
        raise ReviseError(f"--part {', '.join(unknown)}: not a part{did_you_mean(unknown[0], names)}; "
                          f"parts: {', '.join(names)}")
    progress = progress or (lambda stage, text: log.info("%s: %s", stage, text))
    step = _first_step(out_dir)
    provider = preflight(model, base_url=base_url)
    if isinstance(provider, ReplayProvider):
        provider.skip_before(step)
    client = Client(provider, ledger=Ledger(), transcript=Transcript(out_dir / "transcript.jsonl"))
    host = _Host(client, out_dir, _prompt_of(source, out_dir), step, tools or Tools(), progress, max_calls)
    allowed = set(parts) if parts else set()
    scope = ", ".join(sorted(allowed)) if allowed else "the parts the review names"
    intro = (f"A person asks for this change to the assembly ({host.prompt}):\n\n    {instruction}\n\n"
             f"You may edit only: {scope}. Every other part stays as it is.\nParts: {', '.join(names)}\n\n"
             f"The program:\n```python\n{source}```\n\n"
             "An edit_part's \"reply\" is the part written whole again, in the format its build "
             "used:\n\n" + part_format() + "\n\nA param that other parts read cannot change in a "
             "revise limited to some parts: add a new param for this part in its params block "
             f"instead. You have {max_edits} edits and at most {max_calls} model calls.\n\n"
             "Start by rendering views of the build.")
    task = f"The change request: {instruction}\n(The assembly: {host.prompt})"
    try:
        new, report = refine(host, source, intro=intro, max_edits=max_edits, max_actions=max_actions,
                             critic_system=template("critic_revise"),
                             task=task, allowed=allowed, stage="revise", roles=("revise", "revise_critic"),
                             bench_type=_RestrictedBench)
    except _CallsSpent as exc:  # the edits applied so far are in program.py already
        new = prog.read_text(encoding="utf-8")
        report = {"verdict": "calls", "reason": str(exc), "edits": host.applied}
    finally:
        client.close()
    report = {"instruction": instruction, "parts": parts or [], **report, "changed": new != source,
              "calls": host.calls}
    result = ReviseResult("ok" if report["verdict"] == "ok" else str(report["verdict"]), out_dir, new, report)
    if new != source:  # the edits are on disk already; state.json learns the last call's step
        _save(out_dir, new, host.step)
        result.build = host.tools.final_build(new, out_dir, simulate=simulate,
                                              progress=lambda line: progress("build", line))
        if not result.build.ok and result.status == "ok":
            result.status = "gates_failed"
    _log_revision(out_dir, report)
    return result


def _log_revision(out_dir: Path, report: dict[str, Any]) -> None:
    path = out_dir / "history" / "revisions.jsonl"
    old = path.read_text(encoding="utf-8") if path.is_file() else ""
    write_atomic(path, old + json.dumps(report, ensure_ascii=False) + "\n")
    rep_path = out_dir / "report.json"
    if rep_path.is_file():
        rep = json.loads(rep_path.read_text(encoding="utf-8"))
        rep["revisions"] = [json.loads(x) for x in (old + json.dumps(report) + "\n").splitlines() if x.strip()]
        write_atomic(rep_path, json.dumps(rep, indent=2, ensure_ascii=False) + "\n")
        from ..run.report import write_summary
        write_summary(out_dir, rep)
