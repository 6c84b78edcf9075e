"""Suite-wide settings: no network model calls, one shared warm compile worker."""

from __future__ import annotations

import os

import pytest

# Forbid real model calls for the whole suite (loopback fake servers stay allowed).
os.environ["PROCEDURA_BREP_NO_NETWORK"] = "1"
# Never compile through a warm server a developer left running (`procedura-brep serve`): the
# tests that exercise one start their own on a socket of their own.
os.environ["PROCEDURA_BREP_SERVER"] = "off"
# Keep the persistent part store out of the suite (a test that exercises it names its own).
os.environ["PROCEDURA_BREP_CACHE"] = "off"


@pytest.fixture(scope="session")
def worker():
    """One warm sandbox worker for the whole session (pays the build123d import once)."""
    from procedura_brep.program.sandbox import default_worker
    return default_worker()


@pytest.fixture(autouse=True)
def _llm_guards():
    """Forbid non-loopback model calls; fail a test that leaves a replay tape unconsumed."""
    from procedura_brep.llm.testing import no_network, tape_guard
    with no_network(), tape_guard():
        yield
