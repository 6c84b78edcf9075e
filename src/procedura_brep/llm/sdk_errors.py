"""Map exceptions of the official SDKs to retry classes without importing the SDKs.

SDK exception hierarchies change between versions, so classification goes by status code and
class names (``...Timeout...``, ``...Connection...``) rather than by ``isinstance``.
"""

from __future__ import annotations

from typing import Any

from .errors import ProviderError
from .retry import Retryable, parse_retry_after

__all__ = ["classify_sdk_error"]


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
    """
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
