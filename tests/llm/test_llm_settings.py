"""The model in force: --model, then PROCEDURA_BREP_MODEL, then the user config file."""

from __future__ import annotations

import pytest

from procedura_brep.llm import ConfigError
from procedura_brep.llm.settings import resolve_model


@pytest.fixture
def cfg(tmp_path, monkeypatch):
    path = tmp_path / "config.toml"
    monkeypatch.setenv("PROCEDURA_BREP_CONFIG", str(path))
    monkeypatch.delenv("PROCEDURA_BREP_MODEL", raising=False)
    return path


def test_order_of_precedence(cfg, monkeypatch):
    assert resolve_model().source == "none" and resolve_model().model is None
    cfg.write_text('model = "openai:llama3"\nbase_url = "http://127.0.0.1:11434/v1"\n')
    s = resolve_model()
    assert (s.model, s.base_url, s.source) == ("openai:llama3", "http://127.0.0.1:11434/v1", str(cfg))
    monkeypatch.setenv("PROCEDURA_BREP_MODEL", "anthropic:claude")
    assert resolve_model().model == "anthropic:claude" and resolve_model().source == "PROCEDURA_BREP_MODEL"
    assert resolve_model("replay:t.jsonl").source == "--model"


@pytest.mark.parametrize("text,needle", [("model = 3\n", "must be a string"), ("modle = 'x'\n", "unknown key"),
                                         ("model = \n", "not valid TOML")])
def test_bad_config_files_are_named(cfg, text, needle):
    cfg.write_text(text)
    with pytest.raises(ConfigError, match=needle) as info:
        resolve_model()
    assert str(cfg) in str(info.value)
