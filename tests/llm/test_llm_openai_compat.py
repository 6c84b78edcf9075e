"""openai: against a fake OpenAI-compatible server on 127.0.0.1."""

from __future__ import annotations

import time

import pytest

from procedura_brep.llm import (
    Image,
    MalformedReplyError,
    Message,
    ProviderError,
    ProviderTimeoutError,
    Request,
    RetryPolicy,
    Settings,
    get_provider,
    preflight,
)
from procedura_brep.llm.openai_compat import OpenAIProvider

FAST = RetryPolicy(max_retries=2, base_delay_s=0.05, max_delay_s=0.1)


def req(png: bytes | None = None, **settings: object) -> Request:
    images = (Image(png, "iso"),) if png else ()
    return Request("plan", 0, "You are terse.", (Message("user", "hi", images),), Settings(**settings))  # type: ignore[arg-type]


def test_success_parses_text_usage_and_sends_images(fake_server, png, monkeypatch):
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test")
    fake_server.push(fake_server.Behaviour(body=fake_server.completion("a plan", prompt=100, cached=60, out=7)))
    p = get_provider("openai:my-model", base_url=fake_server.url + "/")
    reply = p.complete(req(png, json_mode=True, temperature=0.2, max_tokens=50))
    assert reply.text == "a plan"
    assert (reply.usage.input_tokens, reply.usage.cached_input_tokens, reply.usage.output_tokens) == (100, 60, 7)
    assert reply.model == "openai:my-model" and reply.latency_s > 0
    body = fake_server.requests[0]
    assert body["model"] == "my-model" and body["max_tokens"] == 50 and body["temperature"] == 0.2
    assert body["response_format"] == {"type": "json_object"}
    assert body["messages"][0] == {"role": "system", "content": "You are terse."}
    parts = body["messages"][1]["content"]
    assert parts[0] == {"type": "text", "text": "hi"}
    assert parts[1]["image_url"]["url"].startswith("data:image/png;base64,iVBORw0KGgo")
    assert fake_server.headers[0]["authorization"] == "Bearer sk-test"
    assert p.free  # loopback server: no price means no cost


def test_429_honours_retry_after_then_succeeds(fake_server):
    B = fake_server.Behaviour
    fake_server.push(B(429, {"error": {"message": "slow down"}}, {"Retry-After": "1"}), B())
    p = OpenAIProvider("m", base_url=fake_server.url, policy=FAST)
    start = time.monotonic()
    reply = p.complete(req())
    elapsed = time.monotonic() - start
    assert reply.text == "hello"
    assert len(fake_server.requests) == 2
    assert fake_server.times[1] - fake_server.times[0] >= 0.95
    assert elapsed < 5


def test_repeated_500_ends_in_provider_error_naming_endpoint(fake_server):
    B = fake_server.Behaviour
    fake_server.push(*[B(500, {"error": "boom"})] * 5)
    p = OpenAIProvider("m", base_url=fake_server.url, policy=FAST)
    with pytest.raises(ProviderError) as info:
        p.complete(req())
    msg = str(info.value)
    assert fake_server.url + "/chat/completions" in msg and "500" in msg and "3 attempts" in msg
    assert "\n" not in msg and info.value.status == 500
    assert len(fake_server.requests) == 3


def test_reply_slower_than_timeout(fake_server):
    B = fake_server.Behaviour
    fake_server.push(B(delay_s=3), B(delay_s=3))
    p = OpenAIProvider("m", base_url=fake_server.url, timeout_s=0.3, policy=RetryPolicy(max_retries=1, base_delay_s=0.05))
    start = time.monotonic()
    with pytest.raises(ProviderTimeoutError) as info:
        p.complete(req())
    assert isinstance(info.value, TimeoutError) and isinstance(info.value, ProviderError)
    assert "timeout" in str(info.value) and fake_server.url in str(info.value)
    assert time.monotonic() - start < 2.5


@pytest.mark.parametrize("body", [b"<html>not json at all", b'{"choices": []}', b'{"choices": [{"message": {"content": null}}]}'])
def test_garbage_body_is_malformed_after_retries(fake_server, body):
    B = fake_server.Behaviour
    fake_server.push(*[B(200, body)] * 3)
    p = OpenAIProvider("m", base_url=fake_server.url, policy=FAST)
    with pytest.raises(MalformedReplyError) as info:
        p.complete(req())
    assert "malformed" in str(info.value) and "\n" not in str(info.value)
    assert len(fake_server.requests) == 3


def test_client_error_is_not_retried(fake_server):
    fake_server.push(fake_server.Behaviour(404, {"error": {"message": "model 'm' not found"}}))
    p = OpenAIProvider("m", base_url=fake_server.url, policy=FAST)
    with pytest.raises(ProviderError, match="404: model 'm' not found") as info:
        p.complete(req())
    assert "check the model name" in str(info.value)
    assert len(fake_server.requests) == 1


def test_unreachable_endpoint_fails_within_15s_naming_it(closed_port_url):
    p = get_provider("openai:m", base_url=closed_port_url)  # default retries and backoff
    start = time.monotonic()
    with pytest.raises(ProviderError) as info:
        p.complete(req())
    assert time.monotonic() - start < 15
    assert closed_port_url in str(info.value) and "refused" in str(info.value)
    assert "\n" not in str(info.value)


def test_preflight_reachable_and_unreachable(fake_server, closed_port_url):
    provider = preflight("openai:m", base_url=fake_server.url)
    assert provider.name == "openai:m"
    start = time.monotonic()
    with pytest.raises(ProviderError, match="unreachable") as info:
        preflight("openai:m", base_url=closed_port_url)
    assert closed_port_url in str(info.value) and time.monotonic() - start < 15


def test_base_url_from_environment(fake_server, monkeypatch):
    monkeypatch.setenv("OPENAI_BASE_URL", fake_server.url)
    p = get_provider("openai:m")
    assert p.endpoint == fake_server.url + "/chat/completions"
