"""The client the agent talks to: a provider plus accounting plus a transcript.

:func:`build_client` turns ``--model/--base-url/--max-cost`` into a :class:`Client`;
:func:`preflight` checks a model name, key and endpoint before a run starts, and fails within
seconds (naming the endpoint) when the server cannot be reached.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path

from .base import CONNECT_TIMEOUT_S, Provider, get_provider
from .errors import ConfigError, LLMError, MalformedReplyError
from .ledger import Ledger
from .messages import Image, Message, Reply, Request, Settings
from .transcript import Transcript

__all__ = ["Client", "build_client", "preflight"]

log = logging.getLogger(__name__)


class Client:
    """Sends requests through a provider, enforcing the cap and recording every call.

    Args:
        provider: The provider.
        ledger: Accounting (a fresh uncapped one if omitted).
        transcript: Where to append each call, if anywhere.

    Raises:
        ConfigError: A cost cap is set and the model has no price.
    """

    def __init__(
        self, provider: Provider, *, ledger: Ledger | None = None, transcript: Transcript | None = None
    ) -> None:
        self.provider = provider
        self.ledger = ledger or Ledger()
        self.transcript = transcript
        self.ledger.validate(provider.name, free=provider.free)

    def complete(self, request: Request) -> Reply:
        """Send one request.

        Returns:
            The reply with ``cost_usd`` filled in.

        Raises:
            BudgetExceeded: The cap is reached; nothing was sent.
            LLMError: The provider failed (the failure is also written to the transcript).
        """
        p = self.provider
        image = request.settings.output == "image"
        if image and not p.image_output:
            raise ConfigError(f"{p.name} cannot generate images; give --image PNG, or an image "
                              f"model (--image-model openai:gpt-image-1), or none")
        self.ledger.check_budget(p.name, role=request.role, free=p.free)
        try:
            reply = p.complete(request)
            if image and not reply.images:
                raise MalformedReplyError(f"{p.name} returned no image for {request.label}")
        except LLMError as exc:
            if self.transcript is not None:
                self.transcript.record_error(request, exc, model=p.name)
            raise
        cost = self.ledger.record(request.role, p.name, reply.usage, free=p.free)
        reply = replace(reply, cost_usd=cost, model=reply.model or p.name)
        if self.transcript is not None:
            self.transcript.record(request, reply, model=p.name)
        log.debug("%s %s: %.1f s, %s", p.name, request.label, reply.latency_s, reply.usage)
        return reply

    def ask(
        self,
        role: str,
        step: int,
        system: str,
        text: str,
        *images: Image,
        settings: Settings | None = None,
    ) -> Reply:
        """Shorthand for a one-message request."""
        request = Request(role, step, system, (Message.user(text, *images),), settings or Settings())
        return self.complete(request)

    def close(self) -> None:
        """Close the provider (a replay tape checks it was fully consumed)."""
        self.provider.close()


def build_client(
    model: str,
    *,
    base_url: str | None = None,
    timeout_s: float | None = None,
    max_retries: int | None = None,
    max_cost_usd: float | None = None,
    transcript_path: str | Path | None = None,
    store_images: bool = False,
) -> Client:
    """Build a client from command-line options.

    Args:
        model: ``provider:model``.
        base_url: ``--base-url``.
        timeout_s: Per-reply timeout.
        max_retries: Retries for transient failures.
        max_cost_usd: ``--max-cost``.
        transcript_path: Usually ``OUT/transcript.jsonl``.
        store_images: Store PNGs as base64 in the transcript.

    Returns:
        The client.

    Raises:
        ConfigError: A configuration mistake (one line, says how to fix it).
    """
    provider = get_provider(model, base_url=base_url, timeout_s=timeout_s, max_retries=max_retries)
    transcript = Transcript(transcript_path, store_images=store_images) if transcript_path else None
    return Client(provider, ledger=Ledger(max_cost_usd=max_cost_usd), transcript=transcript)


def preflight(
    model: str, *, base_url: str | None = None, timeout_s: float = CONNECT_TIMEOUT_S * 2
) -> Provider:
    """Resolve the provider, its key and its endpoint before a run, without a model call.

    OpenAI-compatible endpoints get one ``GET /models`` (any HTTP answer counts as reachable).

    Args:
        model: ``provider:model``.
        base_url: ``--base-url``.
        timeout_s: Limit for the reachability check (well under 15 s).

    Returns:
        A provider built with default timeouts (callers may reuse it or build their own).

    Raises:
        ConfigError: Bad model name, missing key, network switched off.
        ProviderError: The endpoint cannot be reached; the message names it.
    """
    provider = get_provider(model, base_url=base_url)
    probe = getattr(provider, "probe", None)
    if callable(probe):
        probe(timeout_s=timeout_s)
    return provider
