"""API keys and endpoints, resolved in one place.

Per-host quirks are data: :data:`OPENAI_COMPATIBLE_HOSTS` says which environment variable holds
the key for well-known OpenAI-compatible hosts. Local servers need no key.
"""

from __future__ import annotations

import os
from urllib.parse import urlsplit

from .errors import MissingKeyError
from .network import is_loopback

__all__ = [
    "ANTHROPIC_KEY_VARS",
    "GEMINI_KEY_VARS",
    "OPENAI_BASE_URL_VARS",
    "OPENAI_COMPATIBLE_HOSTS",
    "OPENAI_DEFAULT_BASE_URL",
    "key_vars_for_openai",
    "resolve_key",
    "resolve_openai_base_url",
]

OPENAI_DEFAULT_BASE_URL = "https://api.openai.com/v1"
#: Environment variables read, in order, when no ``--base-url`` is given.
OPENAI_BASE_URL_VARS: tuple[str, ...] = ("PROCEDURA_BREP_BASE_URL", "OPENAI_BASE_URL")
ANTHROPIC_KEY_VARS: tuple[str, ...] = ("ANTHROPIC_API_KEY",)
GEMINI_KEY_VARS: tuple[str, ...] = ("GEMINI_API_KEY", "GOOGLE_API_KEY")

#: Host -> key variables for OpenAI-compatible hosts that require a key.
OPENAI_COMPATIBLE_HOSTS: dict[str, tuple[str, ...]] = {
    "api.openai.com": ("OPENAI_API_KEY",),
    "openrouter.ai": ("OPENROUTER_API_KEY", "OPENAI_API_KEY"),
    "generativelanguage.googleapis.com": GEMINI_KEY_VARS,
    "api.groq.com": ("GROQ_API_KEY", "OPENAI_API_KEY"),
    "api.together.xyz": ("TOGETHER_API_KEY", "OPENAI_API_KEY"),
    "api.deepseek.com": ("DEEPSEEK_API_KEY", "OPENAI_API_KEY"),
    "api.mistral.ai": ("MISTRAL_API_KEY", "OPENAI_API_KEY"),
}


def resolve_openai_base_url(base_url: str | None) -> str:
    """The base URL for ``openai:``: the argument, then the environment, then OpenAI's.

    Args:
        base_url: The ``--base-url`` value, if any.

    Returns:
        The base URL without a trailing slash.
    """
    url = base_url or next(
        (os.environ[v] for v in OPENAI_BASE_URL_VARS if os.environ.get(v)), OPENAI_DEFAULT_BASE_URL
    )
    return url.rstrip("/")


def key_vars_for_openai(base_url: str) -> tuple[tuple[str, ...], bool]:
    """The key variables to try for an OpenAI-compatible base URL and whether a key is required.

    Args:
        base_url: The resolved base URL.

    Returns:
        ``(variables, required)``. Unknown hosts and loopback servers do not require a key but
        use ``OPENAI_API_KEY`` when it is set.
    """
    host = (urlsplit(base_url).hostname or "").lower()
    if host in OPENAI_COMPATIBLE_HOSTS and not is_loopback(base_url):
        return OPENAI_COMPATIBLE_HOSTS[host], True
    return ("OPENAI_API_KEY",), False


def resolve_key(provider: str, env_vars: tuple[str, ...], *, required: bool = True) -> str | None:
    """Read an API key from the first set variable of ``env_vars``.

    Args:
        provider: The provider name, for the error message.
        env_vars: Candidate environment variables, in order.
        required: Raise when none is set.

    Returns:
        The key, or ``None`` when not required and not set.

    Raises:
        MissingKeyError: ``required`` and no variable is set; names the first variable.
    """
    for var in env_vars:
        value = os.environ.get(var, "").strip()
        if value:
            return value
    if required:
        raise MissingKeyError(provider, env_vars[0])
    return None
