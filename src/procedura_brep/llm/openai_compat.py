"""``openai:`` — OpenAI and any OpenAI-compatible server (Chat Completions over HTTP).

Talks the Chat Completions wire format with ``httpx`` (a core dependency), so Ollama, vLLM,
llama.cpp server, LM Studio, OpenRouter and Gemini's compatible endpoint are a base URL away
and no extra package is needed. Retries are our own (see :mod:`.retry`) so behaviour is bounded
and testable.
"""

from __future__ import annotations

import json
import logging
import time
from typing import Any
from urllib.parse import urlsplit

import httpx

from .base import CONNECT_TIMEOUT_S, DEFAULT_MAX_RETRIES, DEFAULT_TIMEOUT_S, Provider
from .errors import ConfigError, ProviderError
from .keys import key_vars_for_openai, resolve_key, resolve_openai_base_url
from .messages import Message, Reply, Request, Usage
from .network import ensure_network_allowed, is_loopback
from .retry import RetryPolicy, Retryable, call_with_retries, parse_retry_after

__all__ = ["OpenAIProvider", "parse_chat_completion", "to_openai_messages"]

log = logging.getLogger(__name__)

#: Hosts that want ``max_completion_tokens`` instead of ``max_tokens`` (quirks are data).
MAX_COMPLETION_TOKENS_HOSTS = frozenset({"api.openai.com"})


def to_openai_messages(system: str, messages: tuple[Message, ...]) -> list[dict[str, Any]]:
    """Convert a request to Chat Completions messages (images as PNG data URLs).

    Args:
        system: The system text.
        messages: The conversation.

    Returns:
        The ``messages`` array.
    """
    out: list[dict[str, Any]] = []
    if system:
        out.append({"role": "system", "content": system})
    for m in messages:
        if not m.images:
            out.append({"role": m.role, "content": m.text})
            continue
        parts: list[dict[str, Any]] = [{"type": "text", "text": m.text}]
        parts += [{"type": "image_url", "image_url": {"url": img.data_url()}} for img in m.images]
        out.append({"role": m.role, "content": parts})
    return out


def parse_chat_completion(data: Any) -> tuple[str, Usage]:
    """Pull the text and usage out of a Chat Completions response body.

    Args:
        data: The decoded JSON body.

    Returns:
        ``(text, usage)``.

    Raises:
        ValueError: The body has no usable text.
    """
    if not isinstance(data, dict):
        raise ValueError("reply body is not a JSON object")
    if "error" in data and "choices" not in data:
        raise ValueError(f"server returned an error object: {data['error']}")
    choices = data.get("choices")
    if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
        raise ValueError("reply has no choices")
    message = choices[0].get("message") or {}
    text = message.get("content")
    if isinstance(text, list):  # some servers return content parts
        text = "".join(p.get("text", "") for p in text if isinstance(p, dict))
    if not isinstance(text, str) or not text.strip():
        refusal = message.get("refusal")
        raise ValueError(f"model refused: {refusal}" if refusal else "reply has no text")
    usage = data.get("usage") or {}
    details = usage.get("prompt_tokens_details") or {}
    return text, Usage(
        int(usage.get("prompt_tokens") or 0),
        int(details.get("cached_tokens") or 0),
        int(usage.get("completion_tokens") or 0),
    )


class OpenAIProvider(Provider):
    """Chat Completions against ``base_url`` (default ``https://api.openai.com/v1``).

    Args:
        model: The model name the server knows (``gpt-4o``, ``qwen2.5vl:7b`` ...).
        base_url: Server base URL ending in ``/v1``; else ``PROCEDURA_BREP_BASE_URL`` or
            ``OPENAI_BASE_URL``; else OpenAI.
        timeout_s: Seconds a reply may take.
        max_retries: Retries for transient failures.
        api_key: Key override; else resolved from the environment by host.
        policy: Full retry policy override (tests).
    """

    prefix = "openai"
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
        api_key: str | None = None,
        policy: RetryPolicy | None = None,
    ) -> None:
        super().__init__(model)
        if not model:
            raise ConfigError("openai: no model name; write openai:MODEL, e.g. openai:gpt-4o")
        self.base_url = resolve_openai_base_url(base_url)
        if not urlsplit(self.base_url).scheme.startswith("http"):
            raise ConfigError(f"openai: base URL {self.base_url!r} must start with http:// or https://")
        ensure_network_allowed(self.base_url)
        self.free = is_loopback(self.base_url)
        key_vars, required = key_vars_for_openai(self.base_url)
        self.api_key = api_key or resolve_key("openai", key_vars, required=required)
        self.endpoint = f"{self.base_url}/chat/completions"
        self.timeout_s = float(timeout_s or DEFAULT_TIMEOUT_S)
        connect = min(CONNECT_TIMEOUT_S, self.timeout_s)
        self.policy = policy or RetryPolicy(
            max_retries=DEFAULT_MAX_RETRIES if max_retries is None else max_retries,
            connect_timeout_s=connect,
        )
        headers = {"Authorization": f"Bearer {self.api_key}"} if self.api_key else {}
        self._http = httpx.Client(
            timeout=httpx.Timeout(self.timeout_s, connect=connect), headers=headers
        )
        self._max_tokens_key = (
            "max_completion_tokens"
            if urlsplit(self.base_url).hostname in MAX_COMPLETION_TOKENS_HOSTS
            else "max_tokens"
        )

    def payload(self, request: Request) -> dict[str, Any]:
        """The JSON body sent for ``request``."""
        body: dict[str, Any] = {
            "model": self.model,
            "messages": to_openai_messages(request.system, request.messages),
            self._max_tokens_key: request.settings.max_tokens,
        }
        if request.settings.temperature is not None:
            body["temperature"] = request.settings.temperature
        if request.settings.json_mode:
            body["response_format"] = {"type": "json_object"}
        return body

    def _post(self, url: str, body: dict[str, Any]) -> httpx.Response:
        try:
            return self._http.post(url, json=body)
        except httpx.ConnectTimeout:
            raise Retryable("connection timed out (endpoint unreachable)", kind="connect") from None
        except httpx.TimeoutException:
            raise Retryable(f"no reply within {self.timeout_s:g} s (timeout)", kind="timeout") from None
        except httpx.ConnectError as exc:
            reason = str(exc) or "connection failed"
            if "refused" in reason.lower():
                reason = "connection refused"
            raise Retryable(f"cannot connect: {reason}", kind="connect") from None
        except httpx.TransportError as exc:
            raise Retryable(f"transport error: {exc or type(exc).__name__}", kind="server") from None

    def _attempt(self, body: dict[str, Any]) -> tuple[str, Usage]:
        resp = self._post(self.endpoint, body)
        status = resp.status_code
        if status == 429:
            raise Retryable(
                "HTTP 429 rate limited",
                kind="rate_limit",
                retry_after=parse_retry_after(resp.headers.get("retry-after")),
                status=status,
            )
        if status >= 500 or status == 408:
            raise Retryable(f"HTTP {status} server error", kind="server", status=status)
        if status >= 400:
            hint = {401: "check the API key", 403: "check the API key", 404: "check the model name and base URL"}
            raise ProviderError(
                f"{self.endpoint}: HTTP {status}: {_error_text(resp)}"
                + (f" ({hint[status]})" if status in hint else ""),
                endpoint=self.endpoint,
                status=status,
            )
        try:
            return parse_chat_completion(resp.json())
        except (ValueError, json.JSONDecodeError) as exc:
            raise Retryable(f"malformed reply: {exc}", kind="malformed", status=status) from None

    def complete(self, request: Request) -> Reply:
        """Send ``request`` with bounded retries; see :class:`Provider`."""
        ensure_network_allowed(self.base_url)
        body = self.payload(request)
        start = time.monotonic()
        text, usage = call_with_retries(
            lambda: self._attempt(body), endpoint=self.endpoint, policy=self.policy
        )
        return Reply(text, usage, time.monotonic() - start, self.name)

    def probe(self, *, timeout_s: float = CONNECT_TIMEOUT_S) -> int:
        """Check the server answers HTTP at all (``GET /models``), without a model call.

        Args:
            timeout_s: Connect and read timeout.

        Returns:
            The HTTP status (any status means the server is reachable).

        Raises:
            ProviderError: The server cannot be reached; names the endpoint.
        """
        ensure_network_allowed(self.base_url)
        url = f"{self.base_url}/models"
        try:
            return self._http.get(url, timeout=timeout_s).status_code
        except httpx.TimeoutException:
            raise ProviderError(
                f"{self.base_url}: endpoint unreachable (no answer within {timeout_s:g} s)",
                endpoint=self.base_url,
            ) from None
        except httpx.TransportError as exc:
            reason = "connection refused" if "refused" in str(exc).lower() else str(exc)
            raise ProviderError(
                f"{self.base_url}: endpoint unreachable ({reason or type(exc).__name__})",
                endpoint=self.base_url,
            ) from None

    def close(self) -> None:
        """Close the HTTP connection pool."""
        self._http.close()


def _error_text(resp: httpx.Response) -> str:
    try:
        err = resp.json().get("error")
        if isinstance(err, dict):
            return str(err.get("message") or err)
        if err:
            return str(err)
    except (ValueError, AttributeError):
        pass
    return resp.text[:200] or resp.reason_phrase
