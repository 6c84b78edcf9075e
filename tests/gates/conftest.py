"""Fixtures for the gate tests (the hand-built models live in procedura_brep.testing.models)."""

from __future__ import annotations

import pytest

from procedura_brep.testing.models import peg_model


@pytest.fixture
def make_peg():
    return peg_model
