"""The model layer: providers, retries, replay tapes, exchange, accounting, doctor checks.

Knows nothing of CAD. Models are named ``provider:model``::

    from procedura_brep.llm import build_client, Request, Message

    client = build_client("openai:gpt-4o", max_cost_usd=2.0, transcript_path="out/transcript.jsonl")
    reply = client.complete(Request("plan", 0, "You plan.", (Message.user("a hinge"),)))
"""

from __future__ import annotations

from .base import Provider, get_provider, known_prefixes, register_provider, split_model_name
from .client import Client, build_client, preflight
from .doctor import Check, check_provider
from .errors import (
    BudgetExceeded,
    ConfigError,
    ExchangeTimeout,
    LLMError,
    MalformedReplyError,
    MissingKeyError,
    NetworkDisabledError,
    ProviderError,
    ProviderTimeoutError,
    ReplayMismatch,
    TapeNotConsumed,
    UnknownProviderError,
)
from .ledger import Ledger, Price, PriceTable, RoleStats
from .messages import Image, Message, Reply, Request, Settings, Usage
from .network import allow_network, network_allowed
from .retry import RetryPolicy
from .scripted import ScriptedProvider
from .transcript import Transcript, read_tape

__all__ = [
    "BudgetExceeded",
    "Check",
    "Client",
    "ConfigError",
    "ExchangeTimeout",
    "Image",
    "LLMError",
    "Ledger",
    "MalformedReplyError",
    "Message",
    "MissingKeyError",
    "NetworkDisabledError",
    "Price",
    "PriceTable",
    "Provider",
    "ProviderError",
    "ProviderTimeoutError",
    "ReplayMismatch",
    "Reply",
    "Request",
    "RetryPolicy",
    "RoleStats",
    "ScriptedProvider",
    "Settings",
    "TapeNotConsumed",
    "Transcript",
    "UnknownProviderError",
    "Usage",
    "allow_network",
    "build_client",
    "check_provider",
    "get_provider",
    "known_prefixes",
    "network_allowed",
    "preflight",
    "read_tape",
    "register_provider",
    "split_model_name",
]
