"""Bounded retries with backoff, shared by the network providers.

A provider wraps one attempt in a function that raises :class:`Retryable` for transient
failures (timeouts, 429, 5xx, refused connections, malformed bodies). :func:`call_with_retries`
retries it a bounded number of times, honouring ``Retry-After``, and then raises the matching
one-line :class:`~procedura_brep.llm.errors.LLMError`. Connection failures also stop once
:attr:`RetryPolicy.unreachable_deadline_s` would be passed, so an unreachable endpoint fails
within 15 seconds.
"""

from __future__ import annotations

import email.utils
import logging
import random
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, TypeVar

from .base import CONNECT_TIMEOUT_S
from .errors import LLMError, MalformedReplyError, ProviderError, ProviderTimeoutError

__all__ = ["FailureKind", "RetryPolicy", "Retryable", "call_with_retries", "parse_retry_after"]

log = logging.getLogger(__name__)
T = TypeVar("T")
FailureKind = Literal["timeout", "rate_limit", "server", "connect", "malformed"]


class Retryable(Exception):
    """A transient failure of one attempt (internal to providers).

    Args:
        message: What went wrong, one line.
        kind: The failure class.
        retry_after: Seconds the server asked to wait, if it said.
        status: The HTTP status, if any.
    """

    def __init__(
        self,
        message: str,
        *,
        kind: FailureKind,
        retry_after: float | None = None,
        status: int | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.kind = kind
        self.retry_after = retry_after
        self.status = status


@dataclass(frozen=True)
class RetryPolicy:
    """How many times and how long to retry.

    Attributes:
        max_retries: Retries after the first attempt.
        base_delay_s: First backoff delay; doubled on each retry.
        max_delay_s: Largest backoff delay.
        max_retry_after_s: A ``Retry-After`` longer than this ends the retries at once.
        connect_timeout_s: Connect timeout of one attempt (used to keep within the deadline).
        unreachable_deadline_s: Total time after which connection failures are not retried.
    """

    max_retries: int = 3
    base_delay_s: float = 0.5
    max_delay_s: float = 20.0
    max_retry_after_s: float = 120.0
    connect_timeout_s: float = CONNECT_TIMEOUT_S
    unreachable_deadline_s: float = 14.0


def retry_settings(timeout_s: float | None, max_retries: int | None,
                   policy: "RetryPolicy | None" = None) -> tuple[float, "RetryPolicy"]:
    """(reply timeout, retry policy) of a network provider from its constructor arguments."""
    from .base import CONNECT_TIMEOUT_S, DEFAULT_MAX_RETRIES, DEFAULT_TIMEOUT_S
    timeout = float(timeout_s or DEFAULT_TIMEOUT_S)
    return timeout, policy or RetryPolicy(
        max_retries=DEFAULT_MAX_RETRIES if max_retries is None else max_retries,
        connect_timeout_s=min(CONNECT_TIMEOUT_S, timeout),
    )


def network_setup(prefix: str, model: str, endpoint: str, timeout_s: float | None,
                  max_retries: int | None, policy: "RetryPolicy | None" = None, *,
                  example: str = "") -> tuple[str, float, "RetryPolicy"]:
    """The preamble every network provider's constructor shares: a model name is required, the
    endpoint (trailing ``/`` dropped) must be allowed by the network switch, and the timeout and
    retry policy come from the arguments. Returns (endpoint, reply timeout, retry policy).

    Raises:
        ConfigError: no model name (the message shows ``prefix:MODEL`` and ``example``).
        NetworkDisabledError: network calls are off and the endpoint is not loopback.
    """
    from .errors import ConfigError
    from .network import ensure_network_allowed
    if not model:
        raise ConfigError(f"{prefix}: no model name; write {prefix}:MODEL" + (f", e.g. {example}" if example else ""))
    endpoint = endpoint.rstrip("/")
    ensure_network_allowed(endpoint)
    timeout, pol = retry_settings(timeout_s, max_retries, policy)
    return endpoint, timeout, pol


def parse_retry_after(value: str | None) -> float | None:
    """Parse a ``Retry-After`` header (seconds or an HTTP date).

    Args:
        value: The header value.

    Returns:
        Seconds to wait (never negative), or ``None`` if absent or unparsable.
    """
    if not value:
        return None
    value = value.strip()
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        when = email.utils.parsedate_to_datetime(value)
    except (TypeError, ValueError):
        return None
    return max(0.0, when.timestamp() - time.time())


def _final_error(exc: Retryable, endpoint: str, attempts: int) -> LLMError:
    msg = f"{endpoint}: {exc.message} (gave up after {attempts} attempt{'s' * (attempts > 1)})"
    if exc.kind == "timeout":
        return ProviderTimeoutError(msg, endpoint=endpoint, status=exc.status)
    if exc.kind == "malformed":
        return MalformedReplyError(msg, endpoint=endpoint)
    return ProviderError(msg, endpoint=endpoint, status=exc.status)


def call_with_retries(
    attempt: Callable[[], T],
    *,
    endpoint: str,
    policy: RetryPolicy,
    sleep: Callable[[float], None] = time.sleep,
    clock: Callable[[], float] = time.monotonic,
) -> T:
    """Run ``attempt`` with bounded retries.

    Args:
        attempt: One try; raises :class:`Retryable` for transient failures.
        endpoint: Named in log lines and the final error.
        policy: Retry limits.
        sleep: Sleep function (injectable for tests).
        clock: Monotonic clock (injectable for tests).

    Returns:
        What ``attempt`` returned.

    Raises:
        ProviderError: Retries exhausted (``ProviderTimeoutError`` for timeouts).
        MalformedReplyError: The last failure was a malformed body.
    """
    start = clock()
    tries = 0
    while True:
        tries += 1
        try:
            return attempt()
        except Retryable as exc:
            if tries > policy.max_retries:
                raise _final_error(exc, endpoint, tries) from None
            if exc.retry_after is not None:
                if exc.retry_after > policy.max_retry_after_s:
                    exc.message += f"; server asked to retry after {exc.retry_after:.0f} s"
                    raise _final_error(exc, endpoint, tries) from None
                delay = exc.retry_after
            else:
                delay = min(policy.max_delay_s, policy.base_delay_s * 2 ** (tries - 1))
                delay *= 1.0 + 0.1 * random.random()
            if exc.kind == "connect":
                projected = clock() - start + delay + policy.connect_timeout_s
                if projected > policy.unreachable_deadline_s:
                    raise _final_error(exc, endpoint, tries) from None
            log.warning(
                "%s: %s; retry %d/%d in %.1f s", endpoint, exc.message, tries, policy.max_retries, delay
            )
            sleep(delay)
