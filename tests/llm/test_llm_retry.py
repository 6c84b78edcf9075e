"""Retry loop: Retry-After parsing, bounds and the unreachable deadline (fake clock)."""

from __future__ import annotations

import pytest

from procedura_brep.llm import ProviderError, ProviderTimeoutError
from procedura_brep.llm.retry import Retryable, RetryPolicy, call_with_retries, parse_retry_after


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0
        self.sleeps: list[float] = []

    def __call__(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.sleeps.append(s)
        self.now += s


def test_parse_retry_after():
    assert parse_retry_after("2") == 2.0
    assert parse_retry_after("  0.5 ") == 0.5
    assert parse_retry_after(None) is None
    assert parse_retry_after("soon") is None
    assert parse_retry_after("Wed, 21 Oct 2015 07:28:00 GMT") == 0.0  # in the past


def test_unreachable_stops_before_15s_even_with_slow_connect_timeouts():
    clock = FakeClock()
    policy = RetryPolicy(max_retries=10)

    def attempt() -> str:
        clock.now += policy.connect_timeout_s  # each attempt burns a full connect timeout
        raise Retryable("connection timed out", kind="connect")

    with pytest.raises(ProviderError) as info:
        call_with_retries(attempt, endpoint="http://10.0.0.1/v1", policy=policy, sleep=clock.sleep, clock=clock)
    assert clock.now < 15
    assert "http://10.0.0.1/v1" in str(info.value)


def test_retry_after_longer_than_cap_gives_up_at_once():
    clock = FakeClock()
    calls = []

    def attempt() -> str:
        calls.append(1)
        raise Retryable("HTTP 429 rate limited", kind="rate_limit", retry_after=3600, status=429)

    with pytest.raises(ProviderError, match="retry after 3600 s") as info:
        call_with_retries(attempt, endpoint="E", policy=RetryPolicy(), sleep=clock.sleep, clock=clock)
    assert len(calls) == 1 and info.value.status == 429


def test_backoff_grows_and_is_bounded():
    clock = FakeClock()

    def attempt() -> str:
        raise Retryable("no reply", kind="timeout")

    with pytest.raises(ProviderTimeoutError):
        call_with_retries(attempt, endpoint="E", policy=RetryPolicy(max_retries=3, max_delay_s=1.5),
                          sleep=clock.sleep, clock=clock)
    assert len(clock.sleeps) == 3
    assert clock.sleeps[0] < clock.sleeps[1] <= 1.5 * 1.1 and clock.sleeps[2] <= 1.5 * 1.1


def test_success_after_transient_failure():
    clock = FakeClock()
    seq = [Retryable("HTTP 503", kind="server", status=503)]

    def attempt() -> str:
        if seq:
            raise seq.pop()
        return "ok"

    assert call_with_retries(attempt, endpoint="E", policy=RetryPolicy(), sleep=clock.sleep, clock=clock) == "ok"
