"""``gemini:`` — Gemini models through the official ``google-genai`` SDK (optional extra)."""

from __future__ import annotations

import time
from typing import Any

from .base import Provider
from .errors import ConfigError
from .keys import GEMINI_KEY_VARS, resolve_key
from .messages import Message, Reply, Request, Usage
from .network import ensure_network_allowed
from .retry import Retryable, RetryPolicy, call_with_retries, network_setup
from .sdk_errors import classify_sdk_error

__all__ = ["GeminiProvider", "gemini_config", "parse_gemini_response", "to_gemini_contents"]

DEFAULT_ENDPOINT = "https://generativelanguage.googleapis.com"


def to_gemini_contents(messages: tuple[Message, ...]) -> list[dict[str, Any]]:
    """Convert messages to ``generate_content`` contents (images as inline PNG parts).

    Args:
        messages: The conversation.

    Returns:
        A list of content dicts with roles ``user`` and ``model``.
    """
    out: list[dict[str, Any]] = []
    for m in messages:
        parts: list[dict[str, Any]] = [{"text": m.text}]
        parts += [{"inline_data": {"mime_type": img.media_type, "data": img.png}} for img in m.images]
        out.append({"role": "model" if m.role == "assistant" else "user", "parts": parts})
    return out


def gemini_config(request: Request) -> dict[str, Any]:
    """The ``GenerateContentConfig`` fields for ``request``."""
    config: dict[str, Any] = {"max_output_tokens": request.settings.max_tokens}
    if request.system:
        config["system_instruction"] = request.system
    if request.settings.temperature is not None:
        config["temperature"] = request.settings.temperature
    if request.settings.json_mode:
        config["response_mime_type"] = "application/json"
    return config


def parse_gemini_response(resp: Any) -> tuple[str, Usage]:
    """Text and usage of a ``generate_content`` response.

    Raises:
        ValueError: No text (blocked or empty).
    """
    try:
        text = resp.text
    except (AttributeError, ValueError):
        text = None
    if not isinstance(text, str) or not text.strip():
        raise ValueError("reply has no text (blocked or empty)")
    u = getattr(resp, "usage_metadata", None)

    def n(attr: str) -> int:
        return int(getattr(u, attr, None) or 0)

    return text, Usage(
        n("prompt_token_count"),
        n("cached_content_token_count"),
        n("candidates_token_count") + n("thoughts_token_count"),
    )


class GeminiProvider(Provider):
    """Gemini through ``google.genai.Client().models.generate_content`` with our own retries.

    Args:
        model: For example ``gemini-2.5-flash``.
        base_url: Endpoint override; default Google's API.
        timeout_s: Seconds a reply may take.
        max_retries: Retries for transient failures.
        client: A prebuilt SDK client (tests).
    """

    prefix = "gemini"
    vision = True
    json_mode = True
    prompt_caching = True
    network = True

    def __init__(
        self,
        model: str,
        *,
        base_url: str | None = None,
        timeout_s: float | None = None,
        max_retries: int | None = None,
        client: Any = None,
        policy: RetryPolicy | None = None,
    ) -> None:
        super().__init__(model)
        self.endpoint, self.timeout_s, self.policy = network_setup(
            "gemini", model, base_url or DEFAULT_ENDPOINT, timeout_s, max_retries, policy,
            example="gemini:gemini-2.5-flash")
        if client is None:
            key = resolve_key("gemini", GEMINI_KEY_VARS)
            try:
                from google import genai
            except ImportError:
                raise ConfigError(
                    "gemini: the 'google-genai' package is not installed; "
                    "pip install 'procedura-brep[gemini]'"
                ) from None
            options: dict[str, Any] = {
                "timeout": int(self.timeout_s * 1000),
                "retry_options": {"attempts": 1},  # our own retries only
            }
            if base_url:
                options["base_url"] = base_url
            client = genai.Client(api_key=key, http_options=options)
        self._client = client

    def close(self) -> None:
        """Close the SDK client's connection pool (clients without ``close`` are left alone)."""
        close = getattr(self._client, "close", None)
        if callable(close):
            close()

    def _attempt(self, request: Request) -> tuple[str, Usage]:
        try:
            resp = self._client.models.generate_content(
                model=self.model,
                contents=to_gemini_contents(request.messages),
                config=gemini_config(request),
            )
        except Exception as exc:  # noqa: BLE001 - SDK errors are classified by name
            raise classify_sdk_error(exc, endpoint=self.endpoint) from None
        try:
            return parse_gemini_response(resp)
        except ValueError as exc:
            raise Retryable(f"malformed reply: {exc}", kind="malformed") from None

    def complete(self, request: Request) -> Reply:
        """Send ``request``; see :class:`Provider`."""
        ensure_network_allowed(self.endpoint)
        start = time.monotonic()
        text, usage = call_with_retries(
            lambda: self._attempt(request), endpoint=self.endpoint, policy=self.policy
        )
        return Reply(text, usage, time.monotonic() - start, self.name)
