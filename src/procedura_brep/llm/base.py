"""The provider interface and the registry keyed by ``provider:`` prefix.

A provider is one class with one method, :meth:`Provider.complete`, and capability flags. An
OpenAI-compatible host is a base URL, not a class. Provider modules are imported only when their
prefix is used, and SDKs only when a provider is built.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any, ClassVar

from .errors import UnknownProviderError
from .messages import Reply, Request

__all__ = [
    "CONNECT_TIMEOUT_S",
    "DEFAULT_MAX_RETRIES",
    "DEFAULT_TIMEOUT_S",
    "Provider",
    "get_provider",
    "known_prefixes",
    "register_provider",
    "split_model_name",
]

#: Default time a reply may take (large models can think for minutes).
DEFAULT_TIMEOUT_S = 300.0
#: Connect timeout of network providers; keeps an unreachable endpoint under 15 s in total.
CONNECT_TIMEOUT_S = 4.0
DEFAULT_MAX_RETRIES = 3


class Provider(ABC):
    """A model provider.

    Subclasses set :attr:`prefix` and the capability flags and implement :meth:`complete`.

    Attributes:
        model: The part of the model name after ``prefix:``.
        endpoint: What the provider talks to (a URL, a file, a directory), for messages.
        free: Calls cost nothing unless the price table says otherwise.
    """

    prefix: ClassVar[str] = ""
    #: Accepts PNG images in user messages.
    vision: ClassVar[bool] = True
    #: Can be asked for a JSON object reply.
    json_mode: ClassVar[bool] = False
    #: Reports or uses prompt caching.
    prompt_caching: ClassVar[bool] = False
    #: Makes network calls (subject to the no-network switch).
    network: ClassVar[bool] = False
    #: Answers ``Settings(output="image")`` requests with a generated PNG.
    image_output: ClassVar[bool] = False

    def __init__(self, model: str) -> None:
        self.model = model
        self.endpoint = ""
        #: No money is spent when no price is known (tapes, files, local servers).
        self.free = not self.network

    @property
    def name(self) -> str:
        """The full ``provider:model`` name."""
        return f"{self.prefix}:{self.model}"

    @abstractmethod
    def complete(self, request: Request) -> Reply:
        """Answer one request.

        Args:
            request: The request.

        Returns:
            The reply with usage and latency.

        Raises:
            LLMError: A subclass saying what went wrong, on one line.
        """

    def close(self) -> None:  # noqa: B027 - a provider with nothing to release keeps this no-op
        """Release resources and run end-of-run checks (replay tapes check consumption)."""

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name}>"


ProviderFactory = Callable[..., Provider]

# prefix -> "module:Class" (imported lazily) or a factory registered at run time.
_REGISTRY: dict[str, str | ProviderFactory] = {
    "openai": "procedura_brep.llm.openai_compat:OpenAIProvider",
    "anthropic": "procedura_brep.llm.anthropic_provider:AnthropicProvider",
    "gemini": "procedura_brep.llm.gemini_provider:GeminiProvider",
    "replay": "procedura_brep.llm.replay:ReplayProvider",
    "exchange": "procedura_brep.llm.exchange:ExchangeProvider",
    "scripted": "procedura_brep.llm.scripted:ScriptedProvider",
}


def register_provider(prefix: str, factory: str | ProviderFactory) -> None:
    """Register a provider under ``prefix``.

    Args:
        prefix: The name before the colon.
        factory: A callable ``(model, *, base_url, timeout_s, max_retries, **options)`` or a
            ``"module:Class"`` string imported on first use.
    """
    _REGISTRY[prefix] = factory


def known_prefixes() -> list[str]:
    """The registered prefixes, sorted."""
    return sorted(_REGISTRY)


def split_model_name(name: str) -> tuple[str, str]:
    """Split ``provider:model`` at the first colon.

    Args:
        name: The model name.

    Returns:
        ``(prefix, model)``.

    Raises:
        UnknownProviderError: No colon, or the prefix is not registered.
    """
    prefix, sep, model = name.partition(":")
    if not sep or prefix not in _REGISTRY:
        raise UnknownProviderError(name, [f"{p}:" for p in known_prefixes()])
    return prefix, model


def _factory(prefix: str) -> ProviderFactory:
    entry = _REGISTRY[prefix]
    if isinstance(entry, str):
        module, _, attr = entry.partition(":")
        entry = getattr(importlib.import_module(module), attr)
        _REGISTRY[prefix] = entry
    return entry


def get_provider(
    name: str,
    *,
    base_url: str | None = None,
    timeout_s: float | None = None,
    max_retries: int | None = None,
    **options: Any,
) -> Provider:
    """Build the provider for a ``provider:model`` name.

    Args:
        name: For example ``openai:gpt-4o``, ``anthropic:claude-sonnet-4-5``,
            ``gemini:gemini-2.5-flash``, ``replay:run/transcript.jsonl``, ``exchange:xchg/``.
        base_url: Endpoint override (``openai:`` any OpenAI-compatible server; also honoured by
            ``anthropic:`` and ``gemini:``).
        timeout_s: Seconds a reply may take (exchange: seconds to wait for the reply file).
        max_retries: Retries after the first attempt for transient failures.
        **options: Provider-specific options.

    Returns:
        The provider.

    Raises:
        UnknownProviderError: Bad prefix.
        MissingKeyError: The API key variable is not set.
        NetworkDisabledError: Network calls are switched off and the endpoint is not loopback.
        ConfigError: Other configuration mistakes (missing SDK, bad path).
    """
    prefix, model = split_model_name(name)
    return _factory(prefix)(
        model, base_url=base_url, timeout_s=timeout_s, max_retries=max_retries, **options
    )
