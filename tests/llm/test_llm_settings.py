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


def test_image_model_from_flag_env_then_config(tmp_path, monkeypatch):
    from procedura_brep.llm.settings import ENV_CONFIG, ENV_IMAGE_MODEL, resolve_image_model
    cfg = tmp_path / "config.toml"
    cfg.write_text('model = "openai:gpt-4o"\nimage_model = "openai:gpt-image-1"\n')
    monkeypatch.setenv(ENV_CONFIG, str(cfg))
    monkeypatch.delenv(ENV_IMAGE_MODEL, raising=False)
    assert resolve_image_model().model == "openai:gpt-image-1" and resolve_image_model().source == str(cfg)
    monkeypatch.setenv(ENV_IMAGE_MODEL, "exchange:/tmp/x")
    assert resolve_image_model().model == "exchange:/tmp/x"
    assert resolve_image_model("openai:dall-e-3").source == "--image-model"
    cfg.write_text('image_modle = "typo"\n')
    monkeypatch.delenv(ENV_IMAGE_MODEL)
    import pytest

    from procedura_brep.llm import ConfigError
    with pytest.raises(ConfigError, match="unknown key.*image_modle.*image_model"):
        resolve_image_model()
