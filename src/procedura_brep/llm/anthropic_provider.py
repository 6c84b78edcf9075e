"""``anthropic:`` — Claude models through the official ``anthropic`` SDK (optional extra)."""

from __future__ import annotations

import time
from typing import Any

from .base import Provider
from .errors import ConfigError
from .keys import ANTHROPIC_KEY_VARS, resolve_key
from .messages import Message, Reply, Request, Usage
from .network import ensure_network_allowed
from .retry import Retryable, RetryPolicy, call_with_retries, network_setup
from .sdk_errors import classify_sdk_error

__all__ = ["AnthropicProvider", "parse_anthropic_response", "to_anthropic_messages"]

DEFAULT_ENDPOINT = "https://api.anthropic.com"


def to_anthropic_messages(
    system: str, messages: tuple[Message, ...]
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Convert a request to Messages API ``system`` blocks and ``messages``.

    The system text is marked for prompt caching; images are base64 image blocks placed before
    the text of their message.

    Args:
        system: The system text.
        messages: The conversation.

    Returns:
        ``(system_blocks, messages)``.
    """
    system_blocks: list[dict[str, Any]] = []
    if system:
        system_blocks.append(
            {"type": "text", "text": system, "cache_control": {"type": "ephemeral"}}
        )
    out: list[dict[str, Any]] = []
    for m in messages:
        content: list[dict[str, Any]] = [
            {
                "type": "image",
                "source": {"type": "base64", "media_type": img.media_type, "data": img.b64()},
            }
            for img in m.images
        ]
        content.append({"type": "text", "text": m.text})
        out.append({"role": m.role, "content": content})
    return system_blocks, out


def parse_anthropic_response(resp: Any) -> tuple[str, Usage]:
    """Text and usage of a Messages API response (an SDK object or a dict).

    Args:
        resp: The response.

    Returns:
        ``(text, usage)``; input tokens include cache reads and writes.

    Raises:
        ValueError: No text block.
    """

    def get(obj: Any, key: str) -> Any:
        return obj.get(key) if isinstance(obj, dict) else getattr(obj, key, None)

    blocks = get(resp, "content") or []
    text = "".join(get(b, "text") or "" for b in blocks if get(b, "type") == "text")
    if not text.strip():
        raise ValueError(f"reply has no text (stop_reason={get(resp, 'stop_reason')})")
    u = get(resp, "usage") or {}
    cached = int(get(u, "cache_read_input_tokens") or 0)
    written = int(get(u, "cache_creation_input_tokens") or 0)
    return text, Usage(int(get(u, "input_tokens") or 0) + cached + written, cached,
                       int(get(u, "output_tokens") or 0))


class AnthropicProvider(Provider):
    """Claude through ``anthropic.Anthropic().messages.create`` with our own retries.

    Args:
        model: For example ``claude-sonnet-4-5``.
        base_url: Endpoint override (a proxy); default Anthropic's API.
        timeout_s: Seconds a reply may take.
        max_retries: Retries for transient failures.
        client: A prebuilt SDK client (tests).
    """

    prefix = "anthropic"
    vision = True
    json_mode = False
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
            "anthropic", model, base_url or DEFAULT_ENDPOINT, timeout_s, max_retries, policy)
        if client is None:
            key = resolve_key("anthropic", ANTHROPIC_KEY_VARS)
            try:
                import anthropic
                import httpx
            except ImportError:
                raise ConfigError(
                    "anthropic: the 'anthropic' package is not installed; "
                    "pip install 'procedura-brep[anthropic]'"
                ) from None
            client = anthropic.Anthropic(
                api_key=key,
                base_url=base_url,
                max_retries=0,
                timeout=httpx.Timeout(self.timeout_s, connect=self.policy.connect_timeout_s),
            )
        self._client = client

    def close(self) -> None:
        """Close the SDK client's connection pool (clients without ``close`` are left alone)."""
        close = getattr(self._client, "close", None)
        if callable(close):
            close()

    def _attempt(self, kwargs: dict[str, Any]) -> tuple[str, Usage]:
        try:
            resp = self._client.messages.create(**kwargs)
        except Exception as exc:  # noqa: BLE001 - SDK errors are classified by name
            mapped = classify_sdk_error(exc, endpoint=self.endpoint)
            raise mapped from None
        try:
            return parse_anthropic_response(resp)
        except ValueError as exc:
            raise Retryable(f"malformed reply: {exc}", kind="malformed") from None

    def complete(self, request: Request) -> Reply:
        """Send ``request``; see :class:`Provider`."""
        ensure_network_allowed(self.endpoint)
        system, messages = to_anthropic_messages(request.system, request.messages)
        kwargs: dict[str, Any] = {
            "model": self.model,
            "max_tokens": request.settings.max_tokens,
            "messages": messages,
        }
        if system:
            kwargs["system"] = system
        if request.settings.temperature is not None:
            kwargs["temperature"] = request.settings.temperature
        start = time.monotonic()
        text, usage = call_with_retries(
            lambda: self._attempt(kwargs), endpoint=self.endpoint, policy=self.policy
        )
        return Reply(text, usage, time.monotonic() - start, self.name)
