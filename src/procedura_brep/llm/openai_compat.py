"""``openai:`` — OpenAI and any OpenAI-compatible server, through the official ``openai`` SDK.

The SDK is a core dependency (the client for OpenAI and every compatible server), imported only when a
provider is built, never at package import. Ollama, vLLM, llama.cpp server, LM Studio,
OpenRouter and Gemini's compatible endpoint are a base URL away. The SDK's own retries are off
(``max_retries=0``): retries are ours (see :mod:`.retry`) so behaviour is bounded and testable,
and SDK exceptions are mapped onto our one-line error types here.
"""

from __future__ import annotations

import base64
import binascii
import json
import logging
import time
from typing import Any
from urllib.parse import urlsplit

from .base import CONNECT_TIMEOUT_S, Provider
from .errors import ConfigError, ProviderError, one_line
from .keys import key_vars_for_openai, resolve_key, resolve_openai_base_url
from .messages import Image, Message, Reply, Request, Usage
from .network import ensure_network_allowed, is_loopback
from .retry import Retryable, RetryPolicy, call_with_retries, network_setup, parse_retry_after

__all__ = ["MISSING_SDK_MESSAGE", "OpenAIProvider", "parse_chat_completion", "to_openai_messages"]

log = logging.getLogger(__name__)

#: Hosts that want ``max_completion_tokens`` instead of ``max_tokens`` (quirks are data).
MAX_COMPLETION_TOKENS_HOSTS = frozenset({"api.openai.com"})
#: The one-line error when ``openai:`` is used without the SDK installed.
MISSING_SDK_MESSAGE = ("openai: the openai SDK is not installed; pip install openai "
                       "(a core dependency: reinstall procedura-brep)")
#: Sent as the key to servers that need none (local servers); the SDK insists on some key.
NO_KEY_PLACEHOLDER = "sk-no-key-required"


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
        data: The decoded JSON body, or the SDK's ``ChatCompletion`` object.

    Returns:
        ``(text, usage)``.

    Raises:
        ValueError: The body has no usable text.
    """
    data = _as_dict(data)
    if not isinstance(data, dict):
        raise ValueError("reply body is not a JSON object")
    if data.get("error") and not data.get("choices"):
        raise ValueError(f"server returned an error object: {data['error']}")
    choices = data.get("choices")
    if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
        raise ValueError("reply has no choices")
    message = choices[0].get("message") or {}
    if not isinstance(message, dict):
        raise ValueError("reply choice has no message object")
    text = message.get("content")
    if isinstance(text, list):  # some servers return content parts
        text = "".join(p.get("text", "") for p in text if isinstance(p, dict))
    if not isinstance(text, str) or not text.strip():
        refusal = message.get("refusal")
        raise ValueError(f"model refused: {refusal}" if refusal else "reply has no text")
    usage = data.get("usage") or {}
    if not isinstance(usage, dict):
        usage = {}
    details = usage.get("prompt_tokens_details") or {}
    if not isinstance(details, dict):
        details = {}
    return text, Usage(
        int(usage.get("prompt_tokens") or 0),
        int(details.get("cached_tokens") or 0),
        int(usage.get("completion_tokens") or 0),
    )


def _as_dict(data: Any) -> Any:
    """A plain ``dict`` for an SDK response model (extra fields kept); anything else as is."""
    dump = getattr(data, "model_dump", None)
    if not callable(dump):
        return data
    try:
        return dump(warnings=False)
    except TypeError:  # older pydantic or SDK signatures without ``warnings``
        return dump()


def _import_openai() -> Any:
    """Import the ``openai`` SDK on first use.

    Raises:
        ConfigError: The SDK is not installed (one line saying how to install it).
    """
    try:
        import openai
    except ImportError:
        raise ConfigError(MISSING_SDK_MESSAGE) from None
    return openai


class OpenAIProvider(Provider):
    """Chat Completions against ``base_url`` (default ``https://api.openai.com/v1``) via the SDK.

    Args:
        model: The model name the server knows (``gpt-4o``, ``qwen2.5vl:7b`` ...).
        base_url: Server base URL ending in ``/v1``; else ``PROCEDURA_BREP_BASE_URL`` or
            ``OPENAI_BASE_URL``; else OpenAI.
        timeout_s: Seconds a reply may take.
        max_retries: Retries for transient failures (ours; the SDK's are off).
        api_key: Key override; else resolved from the environment by host.
        policy: Full retry policy override (tests).
        client: A prebuilt ``openai.OpenAI`` client (tests); it must have ``max_retries=0``.

    Raises:
        ConfigError: No model name, a bad base URL, a missing key, or the ``openai`` SDK is not
            installed.
        NetworkDisabledError: Network calls are off and the base URL is not loopback.
    """

    prefix = "openai"
    vision = True
    json_mode = True
    prompt_caching = True
    network = True
    image_output = True  # ``images.generate`` (gpt-image-1, dall-e-3, compatible servers)

    def __init__(
        self,
        model: str,
        *,
        base_url: str | None = None,
        timeout_s: float | None = None,
        max_retries: int | None = None,
        api_key: str | None = None,
        policy: RetryPolicy | None = None,
        client: Any = None,
    ) -> None:
        super().__init__(model)
        base = resolve_openai_base_url(base_url)
        if model and not urlsplit(base).scheme.startswith("http"):
            raise ConfigError(f"openai: base URL {base!r} must start with http:// or https://")
        self.base_url, self.timeout_s, self.policy = network_setup(
            "openai", model, base, timeout_s, max_retries, policy, example="openai:gpt-4o")
        self.free = is_loopback(self.base_url)
        key_vars, required = key_vars_for_openai(self.base_url)
        self.api_key = api_key or resolve_key("openai", key_vars, required=required)
        self.endpoint = f"{self.base_url}/chat/completions"
        connect = min(CONNECT_TIMEOUT_S, self.timeout_s)
        self._sdk = _import_openai()
        if client is None:
            client = self._sdk.OpenAI(
                api_key=self.api_key or NO_KEY_PLACEHOLDER,
                base_url=self.base_url,
                max_retries=0,  # retries are ours (call_with_retries), bounded and testable
                timeout=self._sdk.Timeout(self.timeout_s, connect=connect),
            )
        self._client = client
        self._max_tokens_key = (
            "max_completion_tokens"
            if urlsplit(self.base_url).hostname in MAX_COMPLETION_TOKENS_HOSTS
            else "max_tokens"
        )

    def payload(self, request: Request) -> dict[str, Any]:
        """The JSON body sent for ``request`` (the keyword arguments of ``chat.completions.create``)."""
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

    def _map_error(self, exc: Exception) -> Retryable | ProviderError | None:
        """Our error for an exception of one SDK call; ``None`` when it is not the SDK's."""
        sdk = self._sdk
        if isinstance(exc, sdk.APITimeoutError):
            if "connect" in type(exc.__cause__).__name__.lower():
                return Retryable("connection timed out (endpoint unreachable)", kind="connect")
            return Retryable(f"no reply within {self.timeout_s:g} s (timeout)", kind="timeout")
        if isinstance(exc, sdk.APIConnectionError):
            cause = exc.__cause__
            reason = one_line(str(cause) if cause is not None else str(exc), limit=200)
            if "refused" in reason.lower():
                reason = "connection refused"
            if cause is None or "connect" in type(cause).__name__.lower():
                return Retryable(f"cannot connect: {reason or 'connection failed'}", kind="connect")
            return Retryable(f"transport error: {reason or type(cause).__name__}", kind="server")
        if isinstance(exc, sdk.APIStatusError):
            status = int(exc.status_code)
            if status == 429:
                headers = getattr(exc.response, "headers", None) or {}
                return Retryable(
                    "HTTP 429 rate limited",
                    kind="rate_limit",
                    retry_after=parse_retry_after(headers.get("retry-after")),
                    status=status,
                )
            if status >= 500 or status == 408:
                return Retryable(f"HTTP {status} server error", kind="server", status=status)
            hint = _HINTS.get(status)
            return ProviderError(
                f"{self.endpoint}: HTTP {status}: {_error_text(exc)}" + (f" ({hint})" if hint else ""),
                endpoint=self.endpoint,
                status=status,
            )
        if isinstance(exc, (sdk.APIResponseValidationError, json.JSONDecodeError)):
            # The body is not JSON, or the SDK could not read it as a chat completion.
            status = getattr(exc, "status_code", None)
            return Retryable(f"malformed reply: {one_line(str(exc), limit=200)}", kind="malformed",
                             status=status if isinstance(status, int) else None)
        if isinstance(exc, sdk.OpenAIError):
            return ProviderError(f"{self.endpoint}: {one_line(str(exc), limit=200)}", endpoint=self.endpoint)
        return None

    def image_payload(self, request: Request) -> dict[str, Any]:
        """The keyword arguments of ``images.generate`` for an image request: the prompt is the
        system text and the message texts (images of the request are not sent)."""
        prompt = "\n\n".join(t for t in [request.system, *(m.text for m in request.messages)] if t)
        return {"model": self.model, "prompt": prompt, "n": 1, "size": request.settings.image_size}

    def _attempt_image(self, body: dict[str, Any]) -> tuple[bytes, Usage]:
        try:
            resp = self._client.images.generate(**body)
        except Exception as exc:  # noqa: BLE001 - mapped below; anything unknown is re-raised
            mapped = self._map_error(exc)
            if mapped is None:
                raise
            raise mapped from None
        data = _as_dict(resp)
        try:
            png = base64.b64decode(data["data"][0]["b64_json"], validate=True)
        except (KeyError, IndexError, TypeError, ValueError, binascii.Error) as exc:
            raise Retryable(f"malformed image reply: {type(exc).__name__}: {exc}",
                            kind="malformed") from None
        usage = data.get("usage") or {}
        return png, Usage(int(usage.get("input_tokens") or 0), 0, int(usage.get("output_tokens") or 0))

    def _attempt(self, body: dict[str, Any]) -> tuple[str, Usage]:
        try:
            resp = self._client.chat.completions.create(**body)
        except Exception as exc:  # noqa: BLE001 - mapped below; anything unknown is re-raised
            mapped = self._map_error(exc)
            if mapped is None:
                raise
            raise mapped from None
        try:
            return parse_chat_completion(resp)
        except (ValueError, TypeError, AttributeError) as exc:
            raise Retryable(f"malformed reply: {exc}", kind="malformed") from None

    def complete(self, request: Request) -> Reply:
        """Send ``request`` with bounded retries; see :class:`Provider`."""
        ensure_network_allowed(self.base_url)
        start = time.monotonic()
        if request.settings.output == "image":
            body = self.image_payload(request)
            png, usage = call_with_retries(
                lambda: self._attempt_image(body), endpoint=self.endpoint, policy=self.policy
            )
            return Reply("", usage, time.monotonic() - start, self.name,
                         images=(Image(png, f"{request.role}.png"),))
        body = self.payload(request)
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
        sdk = self._sdk
        client = self._client.with_options(
            timeout=sdk.Timeout(timeout_s, connect=min(CONNECT_TIMEOUT_S, timeout_s)), max_retries=0
        )
        try:
            return int(client.models.with_raw_response.list().status_code)
        except sdk.APIStatusError as exc:
            return int(exc.status_code)
        except sdk.APITimeoutError:
            raise ProviderError(
                f"{self.base_url}: endpoint unreachable (no answer within {timeout_s:g} s)",
                endpoint=self.base_url,
            ) from None
        except sdk.APIConnectionError as exc:
            reason = one_line(str(exc.__cause__ or exc), limit=200)
            if "refused" in reason.lower():
                reason = "connection refused"
            raise ProviderError(
                f"{self.base_url}: endpoint unreachable ({reason or type(exc).__name__})",
                endpoint=self.base_url,
            ) from None

    def close(self) -> None:
        """Close the SDK client's connection pool."""
        self._client.close()


_HINTS = {401: "check the API key", 403: "check the API key", 404: "check the model name and base URL"}


def _error_text(exc: Any) -> str:
    """The server's error message of an SDK ``APIStatusError`` (its parsed body, else the raw text)."""
    body = getattr(exc, "body", None)
    if isinstance(body, dict):
        err = body.get("error", body)
        if isinstance(err, dict):
            return one_line(str(err.get("message") or err), limit=200)
        return one_line(str(err), limit=200)
    if body:
        return one_line(str(body), limit=200)
    response = getattr(exc, "response", None)
    text = getattr(response, "text", "") or ""
    return one_line(text, limit=200) or str(getattr(response, "reason_phrase", "") or "no error text")
