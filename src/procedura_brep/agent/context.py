"""The build call's context, laid out so consecutive calls share a long byte-identical prefix.

Providers cache a prompt's prefix (OpenAI and Gemini automatically, Anthropic on request), so
everything that stays the same from one part to the next comes first and only grows by
appending:

1. the system text (rules, the generated API reference, the reply format);
2. the run's fixed context: the prompt, the reference image, the whole plan;
3. the program so far as the log of committed parts, in commit order, each as it was spliced
   (after renames, without repeated params) but with its body cut to its signature
   (:func:`abbreviate`): a new commit only appends to it;
4. last, what changes every call: this part's slice of the plan (its mates, the parts still to
   come, its size and pose mandate), the whole bodies of the parts it mates to, and the renders
   of the build so far.

The plan is sent as one compact JSON line per part. So a request grows by a part's params,
helpers, frames and mates, not by every body written so far (on the recorded robot arm tape:
64.2k characters at part 28 before, see docs/agent.md for after).

Retries of one part continue the same conversation (the reply and the measured findings are
appended), so they share the whole earlier request too. :func:`prefix_ratio` measures it.
"""

from __future__ import annotations

import json
import os.path
from collections.abc import Sequence
from dataclasses import dataclass, replace

from ..llm import Image, Message, Request, Settings
from ..program.splice import SpliceError, parse_reply
from .plan import Plan, PlannedPart


@dataclass(frozen=True)
class CommittedPart:
    """One committed part as it went into the program (blocks after the splice)."""

    name: str
    text: str  # the part's five blocks as spliced (fenced, as in a reply)
    warning: str = ""  # committed after its attempts ran out: what was still wrong


#: The line that stands for a committed part's body in the program log.
BODY_CUT = "    ...  # body of {n} lines, cut here; shown whole to the parts that mate to it"


def abbreviate(text: str) -> str:
    """A committed part's blocks with its body cut to the decorator and ``def`` line."""
    try:
        reply = parse_reply(text)
    except SpliceError:
        return text
    lines = reply.body.strip("\n").split("\n")
    k = next((i for i, ln in enumerate(lines) if ln.lstrip().startswith("def ")), None)
    if k is None or len(lines) - k - 1 <= 1:
        return text
    return replace(reply, body="\n".join(lines[:k + 1] + [BODY_CUT.format(n=len(lines) - k - 1)])).text()


def body_of(text: str) -> str:
    """The body block's code of a committed part (its whole ``@part`` function)."""
    try:
        return parse_reply(text).body
    except SpliceError:
        return ""


def program_log(header: str, committed: Sequence[CommittedPart]) -> str:
    """The program so far as an append-only log of committed parts, bodies cut."""
    out = ["The program so far. The compiler assembles these blocks, in this order, into one "
           "five-section program; everything shown compiles. A part listed below as a committed "
           "part has its body cut to its signature (its params, helpers, frames and mates are "
           "whole); the bodies of the parts the next part mates to follow with its task.",
           "```python", header.rstrip(), "```"]
    for k, c in enumerate(committed, start=1):
        out.append(f"### committed part {k}: {c.name}")
        if c.warning:
            out.append(f"(committed with a warning: {c.warning})")
        out.append(abbreviate(c.text).rstrip())  # its five fenced blocks
    return "\n".join(out)


def _stem(name: str) -> str:
    """``wheel`` for ``wheel_fl``, ``bolt`` for ``bolt_3``: a name without its last short suffix."""
    head, _, tail = name.rpartition("_")
    return head if head and len(tail) <= 3 else name


def partner_bodies(part: PlannedPart, committed: Sequence[CommittedPart]) -> str:
    """The whole bodies of the committed parts ``part`` mates to, and of its latest committed
    sibling (``wheel_fl`` for ``wheel_fr``: a mirror or a copy is written from it); "" for none."""
    by_name = {c.name: c for c in committed}
    stem = _stem(part.name)
    sibling = next((c.name for c in reversed(committed) if stem != part.name and _stem(c.name) == stem), None)
    rows = []
    for name in dict.fromkeys([*part.partners, *([sibling] if sibling else [])]):
        c = by_name.get(name)
        code = body_of(c.text) if c else ""
        if code.strip():
            rows += [f"### {name}", "```python", code.rstrip(), "```"]
    return ("The bodies of the parts it mates to" + (f" and of {sibling}, a part like it" if sibling else "")
            + ":\n" + "\n".join(rows)) if rows else ""


def part_slice(plan: Plan, part: PlannedPart) -> str:
    """This part's mandate: its description, its mates, and the parts still to come."""
    k = plan.index(part.name)
    later = plan.parts[k + 1:]
    rows = [f"Write part {k + 1} of {len(plan.parts)}: {part.name} (detail: {part.detail}).",
            f"Mandate (size, aspect, pose against its neighbours): {part.description}"]
    if part.mates:
        rows.append("Its mates (declare each in the mates block; the nominal is a param name):")
        rows += [f"- to {m.partner}: {m.text()}" for m in part.mates]
        if not all(m.features for m in part.mates):
            rows.append("(features=False: pass it to mate(...); the compiler adds no peg or bore "
                        "there, it only places the part: model the contact surfaces yourself)")
    else:
        rows.append("It is the root: it mates to nothing; publish the frames later parts need.")
    from ..program import GEARING_ALIASES
    if part.name in GEARING_ALIASES.values():
        rows.append(f"Its name is also the helper {part.name}(...): inside the program that name is "
                    f"this part's function, so build its geometry with make_{part.name}(...), the "
                    f"same helper under a name no part takes.")
    if part.couple is not None:
        c = part.couple
        rows.append(f"Its first joint follows {c.driver}'s ({c.type}): after its mate, write "
                    f"couple(\"<its mate's name>\", \"<{c.driver}'s mate name>\", \"{c.type}\", ...) "
                    f"with every number named by a param (couple in the reference); size the teeth, "
                    f"lead or pulleys from those same params.")
    drivers = [p for p in later if p.couple is not None and p.couple.driver == part.name]
    if drivers:
        rows.append("Later parts whose joints it drives: " +
                    ", ".join(f"{p.name} ({p.couple.type})" for p in drivers)  # type: ignore[union-attr]
                    + "; name its tooth count, module, lead or pitch diameter as params they can share.")
    kids = [p for p in later if part.name in p.partners]
    if kids:
        rows.append("Later parts that mate to it (publish frames for them): " +
                    ", ".join(f"{p.name} ({next(m.type for m in p.mates if m.partner == part.name)})" for p in kids))
    if later:
        rows.append("Still to come: " + ", ".join(p.name for p in later))
    return "\n".join(rows)


def build_request(*, step: int, system: str, prompt: str, plan: Plan, header: str,
                  committed: Sequence[CommittedPart], part: PlannedPart, views: Sequence[Image] = (),
                  reference: Image | None = None, history: Sequence[Message] = (),
                  legend: str = "", settings: Settings | None = None) -> Request:
    """The request for one build call (``history``: earlier attempts at this part)."""
    fixed = (f"Object to build: {prompt}\n\nThe assembly plan (the parts in build order; "
             f"each mates to earlier parts):\n```json\n{plan_json(plan)}\n```")
    msgs = [Message.user(fixed, *([reference] if reference else [])),
            Message.user(program_log(header, committed))]
    tail = part_slice(plan, part)
    bodies = partner_bodies(part, committed)
    if bodies:
        tail += "\n\n" + bodies
    if views:
        names = [img.name for img in views]
        tail += ("\n\nRenders of the build so far, one colour per part" +
                 (f" ({legend})" if legend else "") + "." +
                 (f" Views, in order: {captions(names)}." if all(names) else ""))
    msgs.append(Message.user(tail, *views))
    return Request("build", step, system, (*msgs, *history), settings or Settings(max_tokens=8000))


def plan_json(plan: Plan) -> str:
    """The plan as JSON with one line per part."""
    rows = [json.dumps(p.as_dict(), ensure_ascii=False) for p in plan.parts]
    return '{"parts": [\n' + ",\n".join(rows) + "\n]}"


def captions(names: Sequence[str]) -> str:
    """The view names with the side each camera looks from (``front (from -Y, ortho)``)."""
    from ..render.views import caption
    return ", ".join(caption(n) for n in names)


def serialise(request: Request) -> str:
    """The request as the text a provider sees, images by content hash (for prefix checks)."""
    parts = [request.system]
    for m in request.messages:
        parts.append(f"\n<{m.role}>\n{m.text}")
        parts += [f"<image {img.sha256}>" for img in m.images]
    return "".join(parts)


def prefix_ratio(previous: Request, current: Request) -> float:
    """The byte-identical prefix of two requests as a fraction of the current one's length."""
    return prefix_fraction(serialise(previous), serialise(current))


def prefix_fraction(a: str, b: str) -> float:
    """The length of the common prefix of ``a`` and ``b`` as a fraction of ``b``'s length."""
    return len(os.path.commonprefix([a, b])) / max(len(b), 1)
