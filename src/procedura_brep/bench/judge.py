"""The blind judge: grey-clay renders from one fixed view set, named by an opaque hash, scored
by a vision model with one shared prompt.

The judge sees an item id (a salted hash of case and variant), the case's prompt and the
renders, never the variant, the case id or a part name: clay mode draws every part the same
grey. Items are judged in the order of their ids; the call for the k-th id is ``role=judge,
step=k``, so a judge transcript replays call for call (``--judge-model replay:DIR/judge/
transcript.jsonl``) as long as the salt (``DIR/bench.json``) is the same.

Scores are integers 1-10 on geometry, aesthetics and semantic fidelity, mapped to 0-1 by
``clamp((v - 1) / 9)``.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from ..llm import Client, Image, LLMError, Message, Request, Settings
from .settings import BENCH

log = logging.getLogger(__name__)
AXES: tuple[str, ...] = ("geometry", "aesthetics", "semantic")
JSON_RE = re.compile(r"\{.*\}", re.S)


def template(name: str) -> str:
    """A bench prompt file (``prompts/<name>.md``)."""
    return (resources.files(__package__) / "prompts" / f"{name}.md").read_text(encoding="utf-8")


def item_id(salt: str, case: str, variant: str) -> str:
    """The opaque name a judged model goes by."""
    return hashlib.sha256(f"{salt}\0{case}\0{variant}".encode()).hexdigest()[:BENCH.hash_chars]


def normalise(v: float) -> float:
    """clamp((v - low) / (high - low)) into [0, 1]."""
    x = (float(v) - BENCH.score_low) / (BENCH.score_high - BENCH.score_low)
    return min(1.0, max(0.0, x))


def parse_scores(text: str) -> dict[str, float]:
    """Raw 1-10 scores from a judge reply: a JSON object, else ``axis: N`` lines.

    Raises:
        ValueError: an axis is missing or not a number.
    """
    raw: dict[str, Any] = {}
    m = JSON_RE.search(text)
    if m:
        try:
            obj = json.loads(m.group(0))
            if isinstance(obj, dict):
                raw = {k.lower(): v for k, v in obj.items()}
        except ValueError:
            raw = {}
    out: dict[str, float] = {}
    for axis in AXES:
        v = raw.get(axis)
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            hit = re.search(rf"{axis}\W{{0,6}}(\d+(?:\.\d+)?)", text, re.I)
            v = float(hit.group(1)) if hit else None
        if v is None:
            raise ValueError(f"the judge reply has no {axis} score")
        out[axis] = float(v)
    return out


@dataclass(frozen=True)
class Item:
    """One shipped model to judge."""

    id: str
    case: str
    variant: str
    prompt: str
    program: Path


def render_item(item: Item, images_dir: Path) -> list[Path]:
    """The item's grey-clay views (cached by the program's hash), named by its id."""
    source = item.program.read_text(encoding="utf-8")
    digest = hashlib.sha256(source.encode()).hexdigest()
    paths = [images_dir / f"{item.id}_{k}.png" for k in range(len(BENCH.judge_views))]
    stamp = images_dir / f"{item.id}.sha256"
    if stamp.is_file() and stamp.read_text().strip() == digest and all(p.is_file() for p in paths):
        return paths
    from ..program.sandbox import compile_source
    from ..render.api import render_images
    model = compile_source(source, name="model")
    imgs = render_images(model, list(BENCH.judge_views), mode="clay", size=BENCH.judge_size)
    images_dir.mkdir(parents=True, exist_ok=True)
    for p, view in zip(paths, BENCH.judge_views):
        buf = io.BytesIO()
        imgs[view].save(buf, format="PNG")
        p.write_bytes(buf.getvalue())
    stamp.write_text(digest + "\n")
    return paths


def judge_request(step: int, item: Item, images: list[Path]) -> Request:
    """The one shared judge request for an item (no variant, no case id, no part names)."""
    text = (template("judge_user").replace("{item}", item.id).replace("{prompt}", item.prompt)
            .replace("{views}", ", ".join(BENCH.judge_views)))
    pngs = [Image(p.read_bytes(), p.stem) for p in images]
    return Request("judge", step, template("judge_system"), (Message.user(text, *pngs),),
                   Settings(max_tokens=BENCH.judge_max_tokens, temperature=0.0))


def judge_items(items: list[Item], client: Client, images_dir: Path, *,
                cached: dict[str, dict[str, Any]] | None = None) -> dict[str, dict[str, Any]]:
    """Judge every item (in id order); returns id -> ``{raw, scores, reply, images, error}``.

    ``cached`` results whose image digest matches are kept without a call (resume).
    """
    out: dict[str, dict[str, Any]] = {}
    for step, item in enumerate(sorted(items, key=lambda i: i.id)):
        images = render_item(item, images_dir)
        digest = hashlib.sha256(b"".join(p.read_bytes() for p in images)).hexdigest()
        old = (cached or {}).get(item.id)
        if old and old.get("images") == digest and old.get("error") is None:
            out[item.id] = old
            continue
        rec: dict[str, Any] = {"images": digest, "raw": None, "scores": None, "reply": "", "error": None}
        try:
            reply = client.complete(judge_request(step, item, images))
            rec["reply"] = reply.text
            rec["raw"] = parse_scores(reply.text)
            rec["scores"] = {a: round(normalise(v), 6) for a, v in rec["raw"].items()}
        except (LLMError, ValueError) as exc:
            rec["error"] = f"{type(exc).__name__}: {exc}"
            log.warning("judge %s: %s", item.id, rec["error"])
        out[item.id] = rec
    return out
