"""The global switch that forbids network model calls.

The switch is off (calls allowed) unless the environment variable ``PROCEDURA_BREP_NO_NETWORK``
is set to a true value or :func:`allow_network` was called with ``False``. Loopback endpoints
(``127.0.0.1``, ``localhost``, ``::1``) stay allowed, so tests can run a fake server.
"""

from __future__ import annotations

import ipaddress
import os
from urllib.parse import urlsplit

from .errors import NetworkDisabledError

__all__ = ["ENV_NO_NETWORK", "allow_network", "ensure_network_allowed", "is_loopback", "network_allowed"]

ENV_NO_NETWORK = "PROCEDURA_BREP_NO_NETWORK"
_override: bool | None = None


def allow_network(allowed: bool | None) -> None:
    """Allow or forbid network model calls for this process.

    Args:
        allowed: ``True`` or ``False`` to override the environment; ``None`` to go back to
            reading ``PROCEDURA_BREP_NO_NETWORK``.
    """
    global _override
    _override = allowed


def network_allowed() -> bool:
    """Whether non-loopback model calls are allowed now."""
    if _override is not None:
        return _override
    return os.environ.get(ENV_NO_NETWORK, "").strip().lower() not in {"1", "true", "yes", "on"}


def is_loopback(url: str) -> bool:
    """Whether the host of ``url`` is a loopback address or ``localhost``."""
    host = (urlsplit(url if "//" in url else f"//{url}").hostname or "").lower()
    if host == "localhost" or host.endswith(".localhost"):
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def ensure_network_allowed(endpoint: str) -> None:
    """Raise unless a call to ``endpoint`` is allowed by the switch.

    Args:
        endpoint: The URL the provider is about to call.

    Raises:
        NetworkDisabledError: Network calls are off and the endpoint is not loopback.
    """
    if network_allowed() or is_loopback(endpoint):
        return
    raise NetworkDisabledError(
        f"network model calls are disabled ({ENV_NO_NETWORK}=1 or allow_network(False)); "
        f"refusing to call {endpoint}; use replay:, exchange:, scripted: or a loopback server"
    )
