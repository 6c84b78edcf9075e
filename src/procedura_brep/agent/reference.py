"""Stage 1, the reference image: the user's ``--image``, one synthesised by an image model when
one is configured, or none. When present it grounds every later stage.

The image is kept in the run directory as ``reference.png`` with ``reference.json`` (where it
came from), so ``--resume`` grounds the rest of the run on the same picture. A synthesised image
is a model call of role ``reference_image``: the transcript stores the PNG, so a replay of the run
gets the same image offline.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from ..llm import Client, Message, Request, Settings
from ..paths import write_atomic
from .prompts import template

ROLE = "reference_image"
IMAGE_FILE = "reference.png"
INFO_FILE = "reference.json"
IMAGE_SIZE = "1024x1024"

Source = Literal["file", "synthesised", "none"]


@dataclass(frozen=True)
class Reference:
    """The reference image of a run and where it came from."""

    png: bytes | None
    source: Source
    model: str | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"source": self.source, "model": self.model,
                "sha256": hashlib.sha256(self.png).hexdigest() if self.png else None,
                "file": IMAGE_FILE if self.png else None}

    def save(self, root: Path) -> None:
        """Write ``reference.png`` and ``reference.json`` into the run directory."""
        if self.png:
            write_atomic(root / IMAGE_FILE, self.png)
        write_atomic(root / INFO_FILE, json.dumps(self.as_dict(), indent=1) + "\n")


def synthesise(client: Client, prompt: str, *, step: int, size: str = IMAGE_SIZE) -> Reference:
    """Ask ``client``'s image model for a picture of ``prompt`` (one call, role ``reference_image``)."""
    request = Request(ROLE, step, template("reference_image"), (Message.user(f"The object: {prompt}"),),
                      Settings(output="image", image_size=size))
    reply = client.complete(request)
    return Reference(reply.images[0].png, "synthesised", reply.model or client.provider.name)


def load(root: Path) -> Reference:
    """The reference a run directory recorded (``none`` when it has none)."""
    try:
        info = json.loads((root / INFO_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        info = {}
    png_path = root / IMAGE_FILE
    png = png_path.read_bytes() if png_path.is_file() else None
    source = info.get("source") if info.get("source") in ("file", "synthesised") else "file"
    return Reference(png, source if png else "none", info.get("model"))
