"""Exceptions of the model layer.

Every exception derives from :class:`LLMError` and renders as one line. The classes separate
the three kinds of trouble a caller handles differently:

* user or configuration mistakes (:class:`ConfigError` and its subclasses): fix the command line
  or environment, retrying will not help;
* provider failures after bounded retries (:class:`ProviderError`): the endpoint is down, slow or
  rate limited;
* model misbehaviour (:class:`MalformedReplyError`): the reply arrived but cannot be used.

Budget stops, replay mismatches and exchange timeouts have their own classes.
"""

from __future__ import annotations

import re

from ..errors import ProceduraError

__all__ = [
    "BudgetExceeded",
    "ConfigError",
    "ExchangeTimeout",
    "LLMError",
    "MalformedReplyError",
    "MissingKeyError",
    "NetworkDisabledError",
    "ProviderError",
    "ProviderTimeoutError",
    "ReplayMismatch",
    "TapeNotConsumed",
    "UnknownProviderError",
    "one_line",
]

_WS = re.compile(r"\s+")


def one_line(text: str, *, limit: int = 400) -> str:
    """Collapse whitespace so a message fits on one line, truncating very long text.

    Args:
        text: Any text.
        limit: Maximum number of characters kept.

    Returns:
        The text on a single line.
    """
    flat = _WS.sub(" ", str(text)).strip()
    return flat if len(flat) <= limit else flat[: limit - 3] + "..."


class LLMError(ProceduraError):
    """Base class of every error raised by ``procedura_brep.llm``; messages are one line. Under
    the package's root error, so a caller catches one type (a stage that must not swallow a
    provider's failure re-raises it by name)."""

    def __init__(self, message: str) -> None:
        super().__init__(one_line(message))


class ConfigError(LLMError):
    """A user or configuration mistake: a bad model name, a missing key, a bad option."""


class MissingKeyError(ConfigError):
    """The API key environment variable of a provider is not set."""

    def __init__(self, provider: str, env_var: str) -> None:
        self.provider = provider
        self.env_var = env_var
        super().__init__(
            f"{provider}: no API key; set the environment variable {env_var} "
            f"(export {env_var}=...)"
        )


class UnknownProviderError(ConfigError):
    """The ``provider:`` prefix of a model name is not registered."""

    def __init__(self, name: str, known: list[str]) -> None:
        self.name = name
        self.known = known
        super().__init__(
            f"unknown model provider in {name!r}; use PROVIDER:MODEL with PROVIDER one of "
            f"{', '.join(known)}"
        )


class NetworkDisabledError(ConfigError):
    """Network model calls are switched off (tests, ``PROCEDURA_BREP_NO_NETWORK=1``)."""


class ProviderError(LLMError):
    """A provider failed after bounded retries (connection, timeout, HTTP status)."""

    def __init__(self, message: str, *, endpoint: str = "", status: int | None = None) -> None:
        self.endpoint = endpoint
        self.status = status
        super().__init__(message)


class ProviderTimeoutError(ProviderError, TimeoutError):
    """The provider did not answer within the timeout, after retries."""


class MalformedReplyError(LLMError):
    """The provider answered, but the reply cannot be parsed or is empty."""

    def __init__(self, message: str, *, endpoint: str = "") -> None:
        self.endpoint = endpoint
        super().__init__(message)


class BudgetExceeded(LLMError):
    """The ``--max-cost`` cap is reached; no further call was started."""

    def __init__(self, spent_usd: float, cap_usd: float, *, role: str = "") -> None:
        self.spent_usd = spent_usd
        self.cap_usd = cap_usd
        self.role = role
        what = f" before the {role!r} call" if role else ""
        super().__init__(
            f"cost cap reached{what}: spent ${spent_usd:.4f} of --max-cost ${cap_usd:.4f}; "
            "stopping with the work so far kept"
        )


class ReplayMismatch(LLMError):
    """A request has no recorded reply on the replay tape."""


class TapeNotConsumed(ReplayMismatch):
    """A replay tape still holds recorded calls that no request used."""


class ExchangeTimeout(LLMError, TimeoutError):
    """No reply file appeared in the exchange directory within the timeout."""
