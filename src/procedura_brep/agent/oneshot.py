"""One-shot generation: the whole program in one model call, then compile, gate, build.

This is the control mode of docs/agent.md (the staged plan/build/refine agent builds on
the same pieces). Up to ``attempts`` calls: a reply that is not a program, or a program that
fails to compile or pass its mates, is answered with the measured findings and retried.
Every request and reply goes to ``OUT/transcript.jsonl``, which replays with ``replay:OUT``.
"""

from __future__ import annotations

import logging
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..llm import (
    BudgetExceeded,
    Client,
    Image,
    Ledger,
    LLMError,
    Message,
    Request,
    Settings,
    Transcript,
    build_client,
    preflight,
)
from ..llm.errors import MalformedReplyError
from ..paths import write_atomic
from ..program.model import Finding
from ..run.build import BuildResult, build, dump_json
from .prompts import system_prompt, template

log = logging.getLogger(__name__)
FENCE_RE = re.compile(r"```(?:python|py)?[ \t]*\n(.*?)```", re.S)


def extract_program(text: str) -> str:
    """The program in a reply: its first fenced python block, or the whole reply if bare.

    Raises:
        MalformedReplyError: no program could be found in the reply.
    """
    m = FENCE_RE.search(text)
    body = m.group(1) if m else text
    if "procedura_brep.program" not in body or "# === assembly ===" not in body:
        raise MalformedReplyError("the reply holds no program: expected one ```python block with "
                                  "the five marked sections")
    return body.strip() + "\n"


def format_findings(findings: list[Finding], source: str) -> str:
    """Model feedback: each finding with its part, line and 1-3 lines of program context."""
    try:
        from ..gates.feedback import format_feedback
        return format_feedback(source, findings)
    except ImportError:  # pragma: no cover - gates ship with the package
        return "\n".join(f"- {f.message}" for f in findings)


@dataclass
class GenerateResult:
    status: str
    out_dir: Path
    attempts: int = 0
    build: BuildResult | None = None
    usage: dict[str, Any] = field(default_factory=dict)
    message: str = ""


def generate(prompt: str, out_dir: Path, *, model: str, base_url: str | None = None,
             max_cost_usd: float | None = None, attempts: int = 3, image: bytes | None = None,
             timeout_s: float | None = None, formats: tuple[str, ...] | None = None,
             progress: Callable[[str], None] | None = None) -> GenerateResult:
    """Generate a program for ``prompt`` and build it into ``out_dir``.

    ``progress`` (the CLI's stage lines) hears each call, the build's stages and, after a
    failed attempt, what the feedback to the model says.

    Raises:
        ConfigError / ProviderError: bad model name or key, unreachable endpoint (one line).
    """
    provider = preflight(model, base_url=base_url)
    out_dir.mkdir(parents=True, exist_ok=True)
    transcript = out_dir / "transcript.jsonl"
    if timeout_s is None:  # reuse the checked provider (a replay tape is opened once)
        client = Client(provider, ledger=Ledger(max_cost_usd=max_cost_usd),
                        transcript=Transcript(transcript))
    else:
        client = build_client(model, base_url=base_url, timeout_s=timeout_s,
                              max_cost_usd=max_cost_usd, transcript_path=transcript)
    system = system_prompt()
    images = (Image(image, "reference.png"),) if image else ()
    messages: list[Message] = [Message.user(template("oneshot_user").replace("{prompt}", prompt), *images)]
    result = GenerateResult("failed", out_dir)
    say = progress or (lambda line: None)
    note = getattr(progress, "note", say)
    try:
        for attempt in range(attempts):
            result.attempts = attempt + 1
            say(f"attempt {attempt + 1}/{attempts}: asking {model}")
            reply = client.complete(Request("oneshot", attempt, system, tuple(messages),
                                            Settings(max_tokens=16000, temperature=0.2)))
            messages.append(Message.assistant(reply.text))
            try:
                source = extract_program(reply.text)
            except MalformedReplyError as exc:
                result.message = str(exc)
                note(f"attempt {attempt + 1}/{attempts}: {exc}"
                     + ("; sent back to the model as feedback" if attempt + 1 < attempts else ""))
                messages.append(Message.user(template("feedback").replace("{findings}", f"- {exc}")))
                continue
            write_atomic(out_dir / "history" / f"{attempt + 1:03d}.py", source)
            # export_failed: the run dir always holds the last assembly that compiled, even
            # one that fails its gates (never an empty result)
            result.build = build(out_dir / "program.py", out_dir, source=source, formats=formats,
                                 name=None, progress=progress, export_failed=True)
            if result.build.ok:
                result.status = "ok"
                note(f"attempt {attempt + 1}/{attempts}: built")
                break
            result.message = result.build.reason
            sent = result.build.errors or _gate_findings(result.build)
            feedback = format_findings(result.build.findings or _gate_findings(result.build), source)
            note(f"attempt {attempt + 1}/{attempts}: build {result.build.status}: {result.message}")
            if attempt + 1 < attempts:
                note(f"  feedback to the model: {_feedback_summary(sent)}")
            messages.append(Message.user(template("feedback").replace("{findings}", feedback)))
    except BudgetExceeded as exc:
        result.status, result.message = "budget_exceeded", str(exc)
    finally:
        result.usage = client.ledger.summary()
        _annotate_report(result, model, base_url)
        in_flight = sys.exc_info()[0] is not None
        try:
            client.close()  # a replay tape checks here that it was fully consumed
        except LLMError:
            if not in_flight:
                raise
    return result


def _feedback_summary(findings: list[Finding]) -> str:
    """The findings sent back, in a line: how many, and each one's message (program line)."""
    if not findings:
        return "the build failed without findings"
    from ..run.build import describe
    shown = "; ".join(describe(f) for f in findings[:3])
    more = f" (+{len(findings) - 3} more)" if len(findings) > 3 else ""
    return f"{len(findings)} finding(s): {shown}{more}"


def _gate_findings(b: BuildResult) -> list[Finding]:
    gates = b.report.get("gates", {})
    return [Finding(**{k: v for k, v in f.items() if k in Finding.__dataclass_fields__})
            for f in gates.get("findings", [])]


def _annotate_report(result: GenerateResult, model: str, base_url: str | None) -> None:
    path = result.out_dir / "report.json"
    import json
    report = json.loads(path.read_text()) if path.exists() else {}
    report.update({"status": result.status, "mode": "oneshot", "model": model, "endpoint": base_url,
                   "attempts": result.attempts, "usage": result.usage})
    if result.message and result.status != "ok":
        report["reason"] = result.message
    write_atomic(path, dump_json(report))
