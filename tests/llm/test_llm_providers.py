"""Registry, keys, the no-network switch, SDK message conversion and the scripted double."""

from __future__ import annotations

import base64
import json
from types import SimpleNamespace

import pytest

from procedura_brep.llm import (
    ConfigError,
    Image,
    LLMError,
    Message,
    MissingKeyError,
    NetworkDisabledError,
    ProviderError,
    ReplayMismatch,
    Request,
    ScriptedProvider,
    Settings,
    TapeNotConsumed,
    UnknownProviderError,
    allow_network,
    get_provider,
    network_allowed,
)
from procedura_brep.llm.anthropic_provider import AnthropicProvider, to_anthropic_messages
from procedura_brep.llm.gemini_provider import GeminiProvider, gemini_config, to_gemini_contents
from procedura_brep.llm.network import is_loopback
from procedura_brep.llm.openai_compat import to_openai_messages
from procedura_brep.llm.retry import RetryPolicy
from procedura_brep.llm.testing import no_network

FAST = RetryPolicy(max_retries=2, base_delay_s=0.01)


@pytest.fixture
def network_on():
    allow_network(True)
    yield
    allow_network(False)


def test_unknown_provider_lists_known_prefixes():
    with pytest.raises(UnknownProviderError, match="openai:, replay:, scripted:") as info:
        get_provider("foo:bar")
    assert "anthropic:" in str(info.value) and isinstance(info.value, ConfigError)
    with pytest.raises(UnknownProviderError, match="PROVIDER:MODEL"):
        get_provider("gpt-4o")


@pytest.mark.parametrize(
    ("name", "var", "clear"),
    [
        ("anthropic:claude-sonnet-4-5", "ANTHROPIC_API_KEY", ["ANTHROPIC_API_KEY"]),
        ("gemini:gemini-2.5-flash", "GEMINI_API_KEY", ["GEMINI_API_KEY", "GOOGLE_API_KEY"]),
        ("openai:gpt-4o", "OPENAI_API_KEY", ["OPENAI_API_KEY", "OPENAI_BASE_URL", "PROCEDURA_BREP_BASE_URL"]),
    ],
)
def test_missing_key_is_one_line_naming_the_variable(monkeypatch, network_on, name, var, clear):
    for v in clear:
        monkeypatch.delenv(v, raising=False)
    with pytest.raises(MissingKeyError) as info:
        get_provider(name)
    assert info.value.env_var == var and f"export {var}=" in str(info.value) and "\n" not in str(info.value)


def test_openrouter_key_variable(monkeypatch, network_on):
    monkeypatch.delenv("OPENROUTER_API_KEY", raising=False)
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    with pytest.raises(MissingKeyError, match="OPENROUTER_API_KEY"):
        get_provider("openai:meta-llama/llama-3.3-70b-instruct", base_url="https://openrouter.ai/api/v1")
    monkeypatch.setenv("OPENROUTER_API_KEY", "k")
    p = get_provider("openai:x", base_url="https://openrouter.ai/api/v1")
    assert p.api_key == "k" and not p.free


def test_local_servers_need_no_key(monkeypatch):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    p = get_provider("openai:qwen2.5vl", base_url="http://localhost:11434/v1")
    assert p.api_key is None and p.free


def test_no_network_switch(monkeypatch):
    assert not network_allowed()  # set for the whole suite
    monkeypatch.setenv("ANTHROPIC_API_KEY", "k")
    monkeypatch.setenv("OPENAI_API_KEY", "k")
    with pytest.raises(NetworkDisabledError, match="api.openai.com"):
        get_provider("openai:gpt-4o")
    with pytest.raises(NetworkDisabledError, match="PROCEDURA_BREP_NO_NETWORK"):
        get_provider("anthropic:claude-sonnet-4-5")
    get_provider("openai:m", base_url="http://127.0.0.1:9/v1")  # loopback stays allowed
    get_provider("openai:m", base_url="http://[::1]:9/v1")
    allow_network(None)  # back to the environment
    monkeypatch.setenv("PROCEDURA_BREP_NO_NETWORK", "1")
    assert not network_allowed()
    monkeypatch.setenv("PROCEDURA_BREP_NO_NETWORK", "0")
    assert network_allowed()
    with no_network():
        assert not network_allowed()


def test_switch_checked_at_call_time_too(monkeypatch, network_on):
    monkeypatch.setenv("OPENAI_API_KEY", "k")
    p = get_provider("openai:gpt-4o")
    allow_network(False)
    with pytest.raises(NetworkDisabledError):
        p.complete(Request("plan", 0, "", (Message.user("x"),)))


def test_is_loopback():
    assert is_loopback("http://localhost:1234/v1") and is_loopback("http://127.0.0.5/v1")
    assert is_loopback("http://[::1]:8000/v1")
    assert not is_loopback("https://openrouter.ai/api/v1") and not is_loopback("http://10.0.0.2/v1")


def test_bad_base_url_and_empty_model():
    with pytest.raises(ConfigError, match="http://"):
        get_provider("openai:m", base_url="localhost:11434/v1")
    with pytest.raises(ConfigError, match="openai:MODEL"):
        get_provider("openai:", base_url="http://localhost:1/v1")


def test_capability_flags():
    p = get_provider("openai:m", base_url="http://localhost:1/v1")
    assert p.vision and p.json_mode and p.prompt_caching and p.network
    assert not AnthropicProvider.json_mode and AnthropicProvider.prompt_caching
    assert not ScriptedProvider.network


def test_message_conversion(png):
    msgs = (Message.user("see", Image(png)), Message.assistant("ok"), Message.user("again"))
    oa = to_openai_messages("sys", msgs)
    assert oa[1]["content"][1]["image_url"]["url"] == "data:image/png;base64," + base64.b64encode(png).decode()
    assert oa[2] == {"role": "assistant", "content": "ok"}
    system, an = to_anthropic_messages("sys", msgs)
    assert system == [{"type": "text", "text": "sys", "cache_control": {"type": "ephemeral"}}]
    assert an[0]["content"][0] == {"type": "image", "source": {"type": "base64", "media_type": "image/png", "data": base64.b64encode(png).decode()}}
    assert an[0]["content"][1] == {"type": "text", "text": "see"} and an[1]["role"] == "assistant"
    ge = to_gemini_contents(msgs)
    assert ge[0]["parts"][1] == {"inline_data": {"mime_type": "image/png", "data": png}}
    assert [c["role"] for c in ge] == ["user", "model", "user"]
    cfg = gemini_config(Request("plan", 0, "sys", msgs, Settings(max_tokens=9, temperature=0.1, json_mode=True)))
    assert cfg == {"max_output_tokens": 9, "system_instruction": "sys", "temperature": 0.1, "response_mime_type": "application/json"}


class RateLimitError(Exception):
    __module__ = "anthropic._exceptions"  # an SDK's exception (ours would be raised as is)
    status_code = 429
    response = SimpleNamespace(headers={"retry-after": "0.01"})


def test_anthropic_with_fake_client_retries_and_counts_cache(network_on):
    calls = []

    def create(**kwargs):
        calls.append(kwargs)
        if len(calls) == 1:
            raise RateLimitError("rate limited")
        return SimpleNamespace(
            content=[SimpleNamespace(type="text", text="hi")],
            usage=SimpleNamespace(input_tokens=5, cache_read_input_tokens=100, cache_creation_input_tokens=10, output_tokens=3),
        )

    p = AnthropicProvider("claude-x", client=SimpleNamespace(messages=SimpleNamespace(create=create)), policy=FAST)
    reply = p.complete(Request("plan", 0, "sys", (Message.user("x"),), Settings(max_tokens=7, temperature=0)))
    assert reply.text == "hi" and reply.usage.input_tokens == 115 and reply.usage.cached_input_tokens == 100
    assert len(calls) == 2 and calls[1]["max_tokens"] == 7 and calls[1]["temperature"] == 0


def test_sdk_auth_error_is_not_retried(network_on):
    class AuthenticationError(Exception):
        __module__ = "anthropic._exceptions"
        status_code = 401

    def create(**kwargs):
        raise AuthenticationError("invalid x-api-key")

    p = AnthropicProvider("claude-x", client=SimpleNamespace(messages=SimpleNamespace(create=create)), policy=FAST)
    with pytest.raises(ProviderError, match="invalid x-api-key.*check the API key"):
        p.complete(Request("plan", 0, "", (Message.user("x"),)))


def test_gemini_with_fake_client(network_on):
    class APITimeoutError(Exception):
        __module__ = "httpx"

    answers = [APITimeoutError("slow"), SimpleNamespace(text="g", usage_metadata=SimpleNamespace(
        prompt_token_count=50, cached_content_token_count=20, candidates_token_count=4, thoughts_token_count=6))]

    def generate_content(**kwargs):
        a = answers.pop(0)
        if isinstance(a, Exception):
            raise a
        return a

    p = GeminiProvider("gemini-x", client=SimpleNamespace(models=SimpleNamespace(generate_content=generate_content)), policy=FAST)
    reply = p.complete(Request("plan", 0, "", (Message.user("x"),)))
    assert reply.text == "g" and (reply.usage.input_tokens, reply.usage.cached_input_tokens, reply.usage.output_tokens) == (50, 20, 10)


def test_scripted_queue(tmp_path):
    p = ScriptedProvider(replies=["one", lambda r: f"echo {r.role}", ProviderError("down")])
    req = Request("plan", 0, "", (Message.user("x"),))
    assert p.complete(req).text == "one"
    assert p.complete(req).text == "echo plan"
    with pytest.raises(ProviderError):
        p.complete(req)
    with pytest.raises(ReplayMismatch, match="no reply queued"):
        p.complete(req)
    assert len(p.requests) == 4
    f = tmp_path / "r.json"
    f.write_text(json.dumps(["a", "b"]))
    q = get_provider(f"scripted:{f}")
    assert q.complete(req).text == "a"
    with pytest.raises(TapeNotConsumed):
        q.assert_consumed()


def test_errors_share_a_base_and_are_one_line():
    err = ProviderError("a\n  b\tc")
    assert str(err) == "a b c" and isinstance(err, LLMError)
    with pytest.raises(ValueError, match="not PNG"):
        Image(b"GIF89a")


def test_own_bug_is_not_wrapped_as_provider_error(network_on):
    def create(**kwargs):
        raise KeyError("our own bug")

    p = AnthropicProvider("claude-x", client=SimpleNamespace(messages=SimpleNamespace(create=create)), policy=FAST)
    with pytest.raises(KeyError, match="our own bug"):
        p.complete(Request("plan", 0, "", (Message.user("x"),)))


def test_sdk_providers_close_their_clients(network_on):
    closed = []
    client = SimpleNamespace(close=lambda: closed.append(1))
    AnthropicProvider("claude-x", client=client, policy=FAST).close()
    GeminiProvider("gemini-x", client=client, policy=FAST).close()
    GeminiProvider("gemini-x", client=SimpleNamespace(), policy=FAST).close()  # no close: fine
    assert closed == [1, 1]
