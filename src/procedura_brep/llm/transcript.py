"""The run transcript, which is also the replay tape format.

``transcript.jsonl`` holds one JSON object per model call::

    {"v": 1, "role": "build", "step": 3, "model": "openai:gpt-4o",
     "request": {"system": "...", "settings": {...}, "sha256": "...",
                 "messages": [{"role": "user", "text": "...",
                               "images": [{"sha256": "...", "media_type": "image/png",
                                           "data_b64": "..."}]}]},
     "reply": {"text": "...", "usage": {"input_tokens": 0, "cached_input_tokens": 0,
                                         "output_tokens": 0}},
     "latency_s": 1.2, "cost_usd": 0.0012, "time": "2025-01-01T00:00:00+00:00"}

``data_b64`` is present only when images are stored. A failed call is written with ``"error"``
instead of ``"reply"``; replay skips such lines.
"""

from __future__ import annotations

import base64
import binascii
import hashlib
import json
import threading
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from .errors import ConfigError
from .messages import Image, Reply, Request, Usage

__all__ = ["TRANSCRIPT_VERSION", "TapeEntry", "Transcript", "read_tape", "request_digest", "request_to_dict"]

TRANSCRIPT_VERSION = 1


def request_digest(request: Request) -> str:
    """SHA-256 over the system text, message texts and image hashes of a request."""
    h = hashlib.sha256(request.system.encode())
    for m in request.messages:
        h.update(f"\0{m.role}\0{m.text}".encode())
        for img in m.images:
            h.update(img.sha256.encode())
    return h.hexdigest()


def request_to_dict(request: Request, *, store_images: bool = False) -> dict[str, Any]:
    """A request as plain data, images referenced by SHA-256 (and stored if asked).

    Args:
        request: The request.
        store_images: Include the PNG bytes as base64.

    Returns:
        The ``request`` object of a transcript line.
    """
    messages = []
    for m in request.messages:
        images = []
        for img in m.images:
            entry: dict[str, Any] = {"sha256": img.sha256, "media_type": img.media_type}
            if img.name:
                entry["name"] = img.name
            if store_images:
                entry["data_b64"] = img.b64()
            images.append(entry)
        messages.append({"role": m.role, "text": m.text, "images": images})
    return {
        "system": request.system,
        "messages": messages,
        "settings": request.settings.to_dict(),
        "sha256": request_digest(request),
    }


class Transcript:
    """Appends one JSON line per model call to a file (thread safe, flushed per line).

    Args:
        path: The ``.jsonl`` file; parent directories are created.
        store_images: Store PNG bytes as base64 in the transcript.
    """

    def __init__(self, path: str | Path, *, store_images: bool = False) -> None:
        self.path = Path(path)
        self.store_images = store_images
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()

    def _append(self, obj: dict[str, Any]) -> None:
        line = json.dumps(obj, ensure_ascii=False)
        with self._lock, self.path.open("a", encoding="utf-8") as f:
            f.write(line + "\n")

    def _head(self, request: Request, model: str) -> dict[str, Any]:
        return {
            "v": TRANSCRIPT_VERSION,
            "role": request.role,
            "step": request.step,
            "model": model,
            "request": request_to_dict(request, store_images=self.store_images),
        }

    def record(self, request: Request, reply: Reply, *, model: str | None = None) -> None:
        """Append a completed call.

        Args:
            request: The request.
            reply: Its reply (``cost_usd`` as filled in by the client).
            model: The model name; defaults to ``reply.model``.
        """
        obj = self._head(request, model or reply.model)
        obj["reply"] = {"text": reply.text, "usage": reply.usage.to_dict()}
        if reply.images:  # generated images are the reply itself: always stored
            obj["reply"]["images"] = [{"name": i.name, "sha256": i.sha256, "data_b64": i.b64()}
                                      for i in reply.images]
        obj["latency_s"] = round(reply.latency_s, 3)
        obj["cost_usd"] = reply.cost_usd
        obj["time"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        self._append(obj)

    def record_error(self, request: Request, error: BaseException, *, model: str) -> None:
        """Append a failed call (skipped by replay)."""
        obj = self._head(request, model)
        obj["error"] = f"{type(error).__name__}: {error}"
        obj["time"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        self._append(obj)


@dataclass(frozen=True)
class TapeEntry:
    """One recorded call of a tape.

    Attributes:
        line: 1-based line number in the file.
        role: Agent role.
        step: Step number.
        model: The model that answered when recorded.
        request_sha256: Digest of the recorded request (empty if absent).
        text: The reply text.
        usage: The recorded usage.
        images: Generated images of the reply (an image request).
    """

    line: int
    role: str
    step: int
    model: str
    request_sha256: str
    text: str
    usage: Usage
    images: tuple[Image, ...] = ()


def _reply_images(reply: dict[str, Any]) -> tuple[Image, ...]:
    """The generated images of a recorded reply (each checked against its digest)."""
    out = []
    for i in reply.get("images") or []:
        img = Image(base64.b64decode(i["data_b64"], validate=True), str(i.get("name", "")))
        if i.get("sha256") and i["sha256"] != img.sha256:
            raise ValueError(f"image {i.get('name')!r} does not match its sha256")
        out.append(img)
    return tuple(out)


def read_tape(path: str | Path) -> list[TapeEntry]:
    """Read the completed calls of a transcript.

    Args:
        path: A ``transcript.jsonl`` file, or a run directory holding one.

    Returns:
        The entries in file order (error lines skipped).

    Raises:
        ConfigError: Missing file or a line that is not a transcript object.
    """
    p = Path(path)
    if p.is_dir():
        p = p / "transcript.jsonl"
    if not p.is_file():
        raise ConfigError(f"replay tape {p} does not exist; pass replay:PATH/transcript.jsonl")
    entries = []
    for n, raw in enumerate(p.read_text(encoding="utf-8").splitlines(), start=1):
        if not raw.strip():
            continue
        try:
            obj = json.loads(raw)
            if "reply" not in obj:
                continue
            entries.append(
                TapeEntry(
                    n,
                    str(obj["role"]),
                    int(obj["step"]),
                    str(obj.get("model", "")),
                    str((obj.get("request") or {}).get("sha256", "")),
                    str(obj["reply"]["text"]),
                    Usage.from_dict(obj["reply"].get("usage")),
                    _reply_images(obj["reply"]),
                )
            )
        except (ValueError, KeyError, TypeError, binascii.Error) as exc:
            raise ConfigError(f"replay tape {p} line {n} is not a transcript record: {exc}") from None
    return entries
