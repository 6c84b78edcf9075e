"""Provider checks for doctor."""

from __future__ import annotations

import importlib.util
import tomllib
from pathlib import Path

import pytest

from procedura_brep.llm import Check, ScriptedProvider, Transcript, check_provider


def by_name(checks: list[Check]) -> dict[str, Check]:
    return {c.name: c for c in checks}


def test_unknown_and_missing_model():
    (c,) = check_provider("nope:x")
    assert not c.ok and "openai" in c.fix
    (c,) = check_provider(None)
    assert not c.ok and "--model" in c.fix and c.optional


def test_missing_key_and_network_off(monkeypatch):
    """Key and endpoint checks do not depend on whether the (optional) anthropic SDK is here."""
    monkeypatch.delenv("ANTHROPIC_API_KEY", raising=False)
    checks = by_name(check_provider("anthropic:claude-sonnet-4-5"))
    assert checks["SDK"].ok == (importlib.util.find_spec("anthropic") is not None)
    assert not checks["API key"].ok and checks["API key"].fix == "export ANTHROPIC_API_KEY=..."
    assert not checks["endpoint"].ok and "PROCEDURA_BREP_NO_NETWORK" in checks["endpoint"].fix
    assert "MISSING  API key" in checks["API key"].line()


def test_ping_fake_server(fake_server):
    fake_server.push(fake_server.Behaviour(body=fake_server.completion("o", out=1)))
    checks = by_name(check_provider("openai:m", fake_server.url, ping=True))
    assert all(c.ok for c in checks.values()), checks
    assert "1-token" in checks["reachability"].detail
    assert fake_server.requests[0]["max_tokens"] == 1
    no_ping = by_name(check_provider("openai:m", fake_server.url))
    assert "not checked" in no_ping["reachability"].detail and len(fake_server.requests) == 1


def test_ping_unreachable_names_endpoint(closed_port_url):
    checks = by_name(check_provider("openai:m", closed_port_url, ping=True))
    assert not checks["reachability"].ok and closed_port_url in checks["reachability"].detail


def test_replay_tape_loads(tmp_path):
    path = tmp_path / "t.jsonl"
    from procedura_brep.llm import Client

    Client(ScriptedProvider(replies=["x"]), transcript=Transcript(path)).ask("plan", 0, "", "hi")
    checks = by_name(check_provider(f"replay:{path}"))
    assert checks["tape"].ok and "1 recorded call" in checks["tape"].detail
    assert not by_name(check_provider(f"replay:{tmp_path / 'none.jsonl'}"))["tape"].ok


@pytest.mark.parametrize("prefix,module,extra", [("anthropic", "anthropic", "anthropic"),
                                                 ("gemini", "google", "gemini")])
def test_absent_optional_sdk_says_which_extra(monkeypatch, prefix, module, extra):
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name.split(".")[0] == module else _find(name, *a))
    sdk = by_name(check_provider(f"{prefix}:m"))["SDK"]
    assert not sdk.ok and sdk.fix == f"pip install 'procedura-brep[{extra}]'"


_find = importlib.util.find_spec


def test_openai_sdk_is_a_core_dependency():
    """`pip install -e .` alone must be enough for --model openai:... (Ollama, vLLM, ...)."""
    meta = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())["project"]
    core = [d.split(">")[0].split("=")[0].strip() for d in meta["dependencies"]]
    assert "openai" in core
    extras = meta["optional-dependencies"]
    assert not any(d.startswith("anthropic") or d.startswith("google-genai") for d in meta["dependencies"])
    assert "anthropic" in " ".join(extras["anthropic"]) and "google-genai" in " ".join(extras["gemini"])
    assert importlib.util.find_spec("openai") is not None
