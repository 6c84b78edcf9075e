"""Which model a command uses when ``--model`` is not given: one place, one order.

1. ``--model`` on the command line;
2. the environment variable ``PROCEDURA_BREP_MODEL`` (and ``PROCEDURA_BREP_BASE_URL`` for the
   endpoint, already read by the openai provider);
3. the user config file: ``$PROCEDURA_BREP_CONFIG``, else ``$XDG_CONFIG_HOME/procedura-brep/config.toml``
   (``~/.config/procedura-brep/config.toml``), a TOML file such as::

       model = "openai:gpt-4o"
       base_url = "http://localhost:11434/v1"   # optional

The result says where the model came from, so ``doctor`` can show which setting is in force.

The image model that synthesises a reference picture when no ``--image`` is given resolves the
same way: ``--image-model``, then ``PROCEDURA_BREP_IMAGE_MODEL``, then ``image_model = "..."`` in
the config file; unset means no synthesised reference.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .errors import ConfigError

__all__ = ["ENV_CONFIG", "ENV_IMAGE_MODEL", "ENV_MODEL", "ModelSetting", "config_path",
           "resolve_image_model", "resolve_model"]

ENV_MODEL = "PROCEDURA_BREP_MODEL"
ENV_IMAGE_MODEL = "PROCEDURA_BREP_IMAGE_MODEL"
_KEYS = ("model", "base_url", "image_model")
ENV_CONFIG = "PROCEDURA_BREP_CONFIG"


@dataclass(frozen=True)
class ModelSetting:
    """The model in force: ``provider:model``, an optional base URL, and where they came from."""

    model: str | None
    base_url: str | None
    source: str  # "--model", "PROCEDURA_BREP_MODEL", "<config path>", or "none"


def config_path() -> Path:
    """The user config file path (it may not exist)."""
    if os.environ.get(ENV_CONFIG):
        return Path(os.environ[ENV_CONFIG]).expanduser()
    base = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config")
    return base / "procedura-brep" / "config.toml"


def _read_config(path: Path) -> dict:
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return {}
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the config file {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"config file {path} is not valid TOML: {exc}") from None
    for key in _KEYS:
        if key in data and not isinstance(data[key], str):
            raise ConfigError(f"config file {path}: {key} must be a string, got {data[key]!r}")
    unknown = sorted(set(data) - set(_KEYS))
    if unknown:
        raise ConfigError(f"config file {path}: unknown key(s) {', '.join(unknown)}; keys: "
                          f"{', '.join(_KEYS)}")
    return data


def _resolve(value: str | None, flag: str, env_var: str, key: str,
             base_url: str | None = None) -> ModelSetting:
    """``value`` (from ``flag``), else ``$env_var``, else ``key`` in the config file."""
    if value:
        return ModelSetting(value, base_url, flag)
    env = os.environ.get(env_var, "").strip()
    if env:
        return ModelSetting(env, base_url, env_var)
    path = config_path()
    data = _read_config(path)
    if data.get(key):
        return ModelSetting(data[key], base_url or (data.get("base_url") if key == "model" else None),
                            str(path))
    return ModelSetting(None, base_url, "none")


def resolve_model(model: str | None = None, base_url: str | None = None) -> ModelSetting:
    """The model to use: the argument, else the environment, else the config file.

    Raises:
        ConfigError: the config file exists but cannot be read or has unknown keys.
    """
    return _resolve(model, "--model", ENV_MODEL, "model", base_url)


def resolve_image_model(model: str | None = None) -> ModelSetting:
    """The image model: the argument, else ``PROCEDURA_BREP_IMAGE_MODEL``, else the config
    file's ``image_model``; ``model=None`` with source ``none`` when none is set.

    Raises:
        ConfigError: the config file exists but cannot be read or has unknown keys.
    """
    return _resolve(model, "--image-model", ENV_IMAGE_MODEL, "image_model")
