"""openai: through the official SDK against a fake OpenAI-compatible server on 127.0.0.1."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from procedura_brep.llm import (
    ConfigError,
    Image,
    MalformedReplyError,
    Message,
    ProviderError,
    ProviderTimeoutError,
    Request,
    RetryPolicy,
    Settings,
    check_provider,
    get_provider,
    preflight,
)
from procedura_brep.llm.openai_compat import MISSING_SDK_MESSAGE, NO_KEY_PLACEHOLDER, OpenAIProvider
from procedura_brep.llm.retry import Retryable

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


@pytest.mark.parametrize(
    "body",
    [
        b"<html>not json at all",
        b'{"choices": []}',
        b'{"choices": [{"message": {"content": null}}]}',
        b"[1, 2]",
        b'{"error": {"message": "overloaded"}}',
    ],
)
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


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
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


def test_uses_the_sdk_with_its_retries_off(fake_server):
    import openai

    p = OpenAIProvider("m", base_url=fake_server.url)
    assert isinstance(p._client, openai.OpenAI)
    assert p._client.max_retries == 0  # our bounded loop (llm/retry.py) is in charge
    p.close()


def test_local_server_without_key_gets_placeholder(fake_server, monkeypatch):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    fake_server.push(fake_server.Behaviour())
    assert get_provider("openai:m", base_url=fake_server.url).complete(req()).text == "hello"
    assert fake_server.headers[0]["authorization"] == f"Bearer {NO_KEY_PLACEHOLDER}"


def test_unauthorized_is_not_retried_and_names_the_key(fake_server):
    fake_server.push(fake_server.Behaviour(401, {"error": {"message": "invalid api key"}}))
    p = OpenAIProvider("m", base_url=fake_server.url, policy=FAST)
    with pytest.raises(ProviderError) as info:
        p.complete(req())
    msg = str(info.value)
    assert msg.startswith(fake_server.url + "/chat/completions: HTTP 401: invalid api key")
    assert "check the API key" in msg and info.value.status == 401 and len(fake_server.requests) == 1


def test_connect_timeout_and_transport_errors_are_classified(fake_server):
    import openai

    p = OpenAIProvider("m", base_url=fake_server.url)

    def sdk_error(cls: type, cause_name: str, text: str) -> Exception:
        exc = cls.__new__(cls)  # no request object needed to classify
        exc.__cause__ = type(cause_name, (Exception,), {})(text)
        return exc

    connect = p._map_error(sdk_error(openai.APITimeoutError, "ConnectTimeout", ""))
    assert isinstance(connect, Retryable) and connect.kind == "connect" and "unreachable" in connect.message
    read = p._map_error(sdk_error(openai.APITimeoutError, "ReadTimeout", ""))
    assert isinstance(read, Retryable) and read.kind == "timeout"
    dropped = p._map_error(sdk_error(openai.APIConnectionError, "RemoteProtocolError", "Server disconnected"))
    assert isinstance(dropped, Retryable) and dropped.kind == "server" and "disconnected" in dropped.message
    assert p._map_error(KeyError("not the SDK's")) is None


def test_missing_sdk_is_one_line_config_error(monkeypatch, fake_server):
    monkeypatch.setitem(sys.modules, "openai", None)  # makes `import openai` raise ImportError
    with pytest.raises(ConfigError) as info:
        get_provider("openai:m", base_url=fake_server.url)
    assert str(info.value) == MISSING_SDK_MESSAGE
    assert "is not installed" in MISSING_SDK_MESSAGE and "pip install openai" in MISSING_SDK_MESSAGE
    sdk = {c.name: c for c in check_provider("openai:m", fake_server.url)}["SDK"]
    assert not sdk.ok and sdk.fix.startswith("pip install openai")


def test_sdk_is_not_imported_at_package_import():
    code = (
        "import sys, procedura_brep.llm, procedura_brep.llm.openai_compat\n"
        "assert 'openai' not in sys.modules, 'openai imported eagerly'\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
