"""Map exceptions of the official SDKs to retry classes without importing the SDKs.

SDK exception hierarchies change between versions, so classification goes by status code and
class names (``...Timeout...``, ``...Connection...``) rather than by ``isinstance``. Exceptions
that come from neither an SDK, its HTTP stack nor the OS (a ``TypeError`` in our own code, say)
are bugs: they are raised again unchanged, never dressed up as a provider failure.
"""

from __future__ import annotations

from typing import Any

from .errors import ProviderError
from .retry import Retryable, parse_retry_after

__all__ = ["SDK_MODULES", "classify_sdk_error", "from_sdk"]

#: Top-level packages whose exceptions are provider/transport failures.
SDK_MODULES = frozenset({"anthropic", "google", "openai", "httpx", "httpcore", "h11", "h2",
                         "requests", "urllib3", "aiohttp", "websockets"})


def from_sdk(exc: BaseException) -> bool:
    """Whether ``exc`` comes from an SDK or its HTTP stack (:data:`SDK_MODULES`) or the OS
    (``OSError``: refused connections, socket timeouts), as opposed to a bug in our code."""
    if isinstance(exc, OSError):
        return True
    return any(c.__module__.split(".")[0] in SDK_MODULES for c in type(exc).__mro__)


def _status(exc: BaseException) -> int | None:
    for attr in ("status_code", "code", "status"):
        value = getattr(exc, attr, None)
        if isinstance(value, int):
            return value
    return None


def _names(exc: BaseException) -> str:
    return " ".join(c.__name__ for c in type(exc).__mro__).lower()


def _retry_after(exc: BaseException) -> float | None:
    response: Any = getattr(exc, "response", None)
    headers = getattr(response, "headers", None)
    if headers is None:
        return None
    try:
        return parse_retry_after(headers.get("retry-after"))
    except AttributeError:
        return None


def classify_sdk_error(exc: BaseException, *, endpoint: str) -> Retryable | ProviderError:
    """Turn an SDK exception into a :class:`Retryable` or a final :class:`ProviderError`.

    Args:
        exc: What the SDK raised.
        endpoint: Named in the final error.

    Returns:
        ``Retryable`` for timeouts, refused connections, 429 and 5xx; otherwise a
        ``ProviderError`` to raise at once.

    Raises:
        BaseException: ``exc`` itself, unchanged, when it does not come from an SDK
            (:func:`from_sdk`): our own bugs must surface as themselves.
    """
    if not from_sdk(exc):
        raise exc
    names = _names(exc)
    detail = str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__
    status = _status(exc)
    if "timeout" in names:
        return Retryable(f"no reply in time (timeout): {detail}", kind="timeout")
    if status is None and "connection" in names:
        return Retryable(f"cannot connect: {detail}", kind="connect")
    if status == 429:
        return Retryable(
            "HTTP 429 rate limited", kind="rate_limit", retry_after=_retry_after(exc), status=429
        )
    if status is not None and (status >= 500 or status == 408):
        return Retryable(f"HTTP {status} server error: {detail}", kind="server", status=status)
    hint = " (check the API key)" if status in (401, 403) else ""
    return ProviderError(f"{endpoint}: {detail}{hint}", endpoint=endpoint, status=status)
