"""Helpers for test suites: forbid network model calls and fail on unconsumed tapes.

In a root ``conftest.py``::

    import pytest
    from procedura_brep.llm.testing import no_network, tape_guard

    @pytest.fixture(autouse=True)
    def _llm_guards():
        with no_network(), tape_guard():
            yield
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from . import network, replay
from .errors import TapeNotConsumed

__all__ = ["no_network", "tape_guard"]


@contextmanager
def no_network() -> Iterator[None]:
    """Forbid non-loopback model calls inside the block (restores the previous setting)."""
    previous = network._override
    network.allow_network(False)
    try:
        yield
    finally:
        network.allow_network(previous)


@contextmanager
def tape_guard() -> Iterator[list[replay.ReplayProvider]]:
    """Fail when a replay tape opened inside the block is not fully consumed at its end.

    Yields:
        The replay providers opened so far inside the block.

    Raises:
        TapeNotConsumed: On exit, naming the left-over calls (only if the block itself did not
            raise).
    """
    opened: list[replay.ReplayProvider] = []
    replay._GUARDS.append(opened)
    try:
        yield opened
    finally:
        replay._GUARDS.remove(opened)
    problems = []
    for provider in opened:
        try:
            provider.assert_consumed()
        except TapeNotConsumed as exc:
            problems.append(str(exc))
    if problems:
        raise TapeNotConsumed("; ".join(problems))
