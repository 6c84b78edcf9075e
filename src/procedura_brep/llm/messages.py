"""The provider-neutral request and reply types.

A :class:`Request` is a system text, a list of :class:`Message` (text plus PNG images) and
:class:`Settings`, tagged with the ``role`` and ``step`` of the agent call that made it; replay
tapes match on ``(role, step)``. A :class:`Reply` is text plus :class:`Usage` and latency.
"""

from __future__ import annotations

import base64
import hashlib
from dataclasses import dataclass, field
from typing import Any, Literal

__all__ = ["Image", "Message", "Reply", "Request", "Settings", "Usage"]

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@dataclass(frozen=True)
class Image:
    """A PNG image attached to a message.

    Attributes:
        png: The PNG file bytes.
        name: An optional label (for example ``"iso"``), used in exchange file names.
    """

    png: bytes
    name: str = ""

    def __post_init__(self) -> None:
        if not self.png.startswith(PNG_MAGIC):
            raise ValueError(f"image {self.name or '?'} is not PNG data (bad signature)")

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of the PNG bytes (how transcripts reference the image)."""
        return hashlib.sha256(self.png).hexdigest()

    @property
    def media_type(self) -> str:
        """The MIME type, always ``image/png``."""
        return "image/png"

    def b64(self) -> str:
        """The PNG bytes as base64 text."""
        return base64.b64encode(self.png).decode("ascii")

    def data_url(self) -> str:
        """The image as a ``data:`` URL (OpenAI-compatible servers)."""
        return f"data:image/png;base64,{self.b64()}"


@dataclass(frozen=True)
class Message:
    """One turn of the conversation.

    Attributes:
        role: ``"user"`` or ``"assistant"``.
        text: The text of the turn.
        images: PNG images shown with the text (user turns only).
    """

    role: Literal["user", "assistant"]
    text: str
    images: tuple[Image, ...] = ()

    @classmethod
    def user(cls, text: str, *images: Image) -> Message:
        """Build a user message."""
        return cls("user", text, tuple(images))

    @classmethod
    def assistant(cls, text: str) -> Message:
        """Build an assistant message."""
        return cls("assistant", text)


@dataclass(frozen=True)
class Settings:
    """Sampling settings of a request.

    Attributes:
        max_tokens: Maximum number of output tokens.
        temperature: Sampling temperature; ``None`` leaves the provider default.
        json_mode: Ask for a JSON object reply where the provider supports it.
        output: ``"text"`` (a chat reply) or ``"image"`` (one generated PNG, in
            :attr:`Reply.images`; only providers with ``image_output`` answer it).
        image_size: ``WIDTHxHEIGHT`` of a generated image.
    """

    max_tokens: int = 4096
    temperature: float | None = None
    json_mode: bool = False
    output: Literal["text", "image"] = "text"
    image_size: str = "1024x1024"

    def to_dict(self) -> dict[str, Any]:
        """The settings as plain data (the image fields only for an image request)."""
        out: dict[str, Any] = {
            "max_tokens": self.max_tokens,
            "temperature": self.temperature,
            "json_mode": self.json_mode,
        }
        if self.output != "text":
            out.update(output=self.output, image_size=self.image_size)
        return out


@dataclass(frozen=True)
class Request:
    """A model request.

    Attributes:
        role: The agent role making the call (``"plan"``, ``"build"``, ``"critic"`` ...).
        step: The step number within the run; with ``role`` it identifies the call on a tape.
        system: The system text.
        messages: The conversation.
        settings: Sampling settings.
    """

    role: str
    step: int
    system: str
    messages: tuple[Message, ...]
    settings: Settings = field(default_factory=Settings)

    def __post_init__(self) -> None:
        if not self.messages:
            raise ValueError("a request needs at least one message")
        if isinstance(self.messages, list):
            object.__setattr__(self, "messages", tuple(self.messages))

    @property
    def images(self) -> list[Image]:
        """All images of all messages, in order."""
        return [img for m in self.messages for img in m.images]

    @property
    def label(self) -> str:
        """``role#step``, for messages."""
        return f"{self.role}#{self.step}"


@dataclass(frozen=True)
class Usage:
    """Token counts of one call.

    Attributes:
        input_tokens: All input tokens, cached ones included.
        cached_input_tokens: The part of ``input_tokens`` read from a prompt cache.
        output_tokens: Output tokens.
    """

    input_tokens: int = 0
    cached_input_tokens: int = 0
    output_tokens: int = 0

    def to_dict(self) -> dict[str, int]:
        """The counts as plain data."""
        return {
            "input_tokens": self.input_tokens,
            "cached_input_tokens": self.cached_input_tokens,
            "output_tokens": self.output_tokens,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None) -> Usage:
        """Inverse of :meth:`to_dict`; missing keys count as zero."""
        data = data or {}
        return cls(
            int(data.get("input_tokens") or 0),
            int(data.get("cached_input_tokens") or 0),
            int(data.get("output_tokens") or 0),
        )


@dataclass(frozen=True)
class Reply:
    """A model reply.

    Attributes:
        text: The reply text.
        usage: Token counts.
        latency_s: Wall time of the call, retries included.
        model: The ``provider:model`` name that answered.
        cost_usd: Cost of the call, filled in by :class:`~procedura_brep.llm.client.Client`;
            ``None`` when unknown.
        images: Generated images (an ``output="image"`` request).
    """

    text: str
    usage: Usage = field(default_factory=Usage)
    latency_s: float = 0.0
    model: str = ""
    cost_usd: float | None = None
    images: tuple[Image, ...] = ()
