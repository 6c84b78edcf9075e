"""Provider checks for ``procedura-brep doctor`` (no CAD here) and the generic :class:`Check`."""

from __future__ import annotations

import importlib.util
import os
import time
from dataclasses import dataclass

from .base import get_provider, known_prefixes, split_model_name
from .errors import ConfigError, LLMError, MalformedReplyError
from .keys import (
    ANTHROPIC_KEY_VARS,
    GEMINI_KEY_VARS,
    key_vars_for_openai,
    resolve_openai_base_url,
)
from .messages import Message, Request, Settings
from .network import ENV_NO_NETWORK, is_loopback, network_allowed
from .transcript import read_tape

__all__ = ["Check", "check_provider"]

# provider prefix -> (SDK module, how to install it). openai is a core dependency (the client of
# every OpenAI-compatible server); anthropic and gemini are extras.
_SDK = {
    "openai": ("openai", "pip install openai (a core dependency: reinstall procedura-brep)"),
    "anthropic": ("anthropic", "pip install 'procedura-brep[anthropic]'"),
    "gemini": ("google.genai", "pip install 'procedura-brep[gemini]'"),
}


@dataclass(frozen=True)
class Check:
    """One doctor finding.

    Attributes:
        name: What was checked (``"model name"``, ``"API key"`` ...).
        ok: Whether it passed.
        detail: What was found.
        fix: How to fix it when not ok.
        optional: A failure does not stop the tool from working.
    """

    name: str
    ok: bool
    detail: str = ""
    fix: str = ""
    optional: bool = False

    def line(self) -> str:
        """One line: ``ok|MISSING name: detail (fix: ...)``."""
        mark = "ok" if self.ok else ("optional" if self.optional else "MISSING")
        tail = f" (fix: {self.fix})" if self.fix and not self.ok else ""
        return f"{mark:8} {self.name}: {self.detail}{tail}"


def _key_check(prefix: str, base_url: str | None) -> Check:
    if prefix == "openai":
        url = resolve_openai_base_url(base_url)
        env_vars, required = key_vars_for_openai(url)
    elif prefix in ("anthropic", "gemini"):
        env_vars, required = (ANTHROPIC_KEY_VARS if prefix == "anthropic" else GEMINI_KEY_VARS), True
    else:
        return Check("API key", True, f"{prefix}: no key needed")
    found = next((v for v in env_vars if os.environ.get(v, "").strip()), None)
    if found:
        return Check("API key", True, f"{found} is set")
    if not required:
        return Check("API key", True, f"not required for {url} ({env_vars[0]} is used if set)")
    return Check("API key", False, f"{env_vars[0]} is not set", f"export {env_vars[0]}=...")


def _endpoint_check(prefix: str, model: str, base_url: str | None) -> Check:
    if prefix == "openai":
        url = resolve_openai_base_url(base_url)
    elif prefix in ("replay", "exchange"):
        return Check("endpoint", True, f"{prefix} reads local files ({model})")
    elif prefix == "scripted":
        return Check("endpoint", True, "scripted test double")
    else:
        from . import anthropic_provider, gemini_provider
        module = anthropic_provider if prefix == "anthropic" else gemini_provider
        url = base_url or module.DEFAULT_ENDPOINT
    if not network_allowed() and not is_loopback(url):
        return Check("endpoint", False, f"{url}: network model calls are disabled",
                     f"unset {ENV_NO_NETWORK}")
    return Check("endpoint", True, url)


def check_provider(
    model: str | None, base_url: str | None = None, *, ping: bool = False, timeout_s: float = 15.0
) -> list[Check]:
    """Check that ``model`` can be used: name, SDK, key, endpoint and (if asked) a 1-token call.

    Args:
        model: ``provider:model``; ``None`` reports that no model is configured.
        base_url: ``--base-url``.
        ping: Make one tiny model call to prove the endpoint answers.
        timeout_s: Limit of the ping.

    Returns:
        The findings, in order; later checks are skipped when an earlier one makes them moot.
    """
    if not model:
        return [Check("model", False, "no model configured",
                      "pass --model PROVIDER:MODEL, e.g. openai:gpt-4o", optional=True)]
    try:
        prefix, name = split_model_name(model)
    except ConfigError as exc:
        return [Check("model", False, str(exc), f"use one of {', '.join(known_prefixes())}")]
    checks = [Check("model", True, model)]
    if prefix in _SDK:
        module, fix = _SDK[prefix]
        if importlib.util.find_spec(module.split(".")[0]) is None or (
            "." in module and importlib.util.find_spec(module) is None
        ):
            checks.append(Check("SDK", False, f"{module} is not installed",
                                fix))
        else:
            checks.append(Check("SDK", True, f"{module} installed"))
    checks += [_key_check(prefix, base_url), _endpoint_check(prefix, name, base_url)]
    if not all(c.ok for c in checks):
        return checks
    if prefix in ("exchange", "scripted"):
        return checks
    if prefix == "replay":
        try:
            entries = read_tape(name)
        except LLMError as exc:
            return [*checks, Check("tape", False, str(exc), "record a run first, or fix the path")]
        return [*checks, Check("tape", True, f"{len(entries)} recorded call(s) in {name}")]
    try:
        provider = get_provider(model, base_url=base_url, timeout_s=timeout_s, max_retries=0)
    except LLMError as exc:
        return [*checks, Check("provider", False, str(exc))]
    try:
        if not ping:
            return [*checks, Check("reachability", True,
                                   "not checked (ask for a ping to make a 1-token call)",
                                   optional=True)]
        request = Request("doctor", 0, "", (Message.user("Reply with: ok"),),
                          Settings(max_tokens=1))
        start = time.monotonic()
        try:
            provider.complete(request)
            detail = f"answered a 1-token call in {time.monotonic() - start:.1f} s"
        except MalformedReplyError:
            detail = f"reachable (empty 1-token reply) in {time.monotonic() - start:.1f} s"
        except LLMError as exc:
            return [*checks, Check("reachability", False, str(exc),
                                   "check --base-url, the server and the key")]
        return [*checks, Check("reachability", True, detail)]
    finally:
        provider.close()
