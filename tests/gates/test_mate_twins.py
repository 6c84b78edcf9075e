"""Twin pairs (the same two local geometries, the same relative pose, only moved) are measured
once by the mate gate, and a measure taken from another pair is the one the pair gets alone."""

from __future__ import annotations

import numpy as np
import pytest

from procedura_brep.gates import clear_caches, mate_gate
from procedura_brep.program.model import clear_mesh_cache
from procedura_brep.testing.models import compiled
from tests.program.test_twins import LEGS, table

PADS = [f"pad_{n[-1]}_seat" for n in LEGS]


@pytest.fixture(scope="module")
def model():
    return compiled(table(pads=True), cache=False)


def _mate(model, name):
    return next(m for m in model.mates if m.name == name)


def test_pads_on_twin_legs_share_one_key_and_one_common(model, monkeypatch):
    names = {m.name for m in model.mates}
    assert set(PADS) <= names, names
    assert len({mate_gate.pair_key(model, _mate(model, n)) for n in PADS}) == 1
    # the legs stand at different places in the top: each leg's mate has its own key
    legs = [m for m in model.mates if m.parent == "top"]
    assert len({mate_gate.pair_key(model, m) for m in legs}) == len(legs) == 5
    clear_caches()
    calls: list[str] = []
    real = mate_gate.common
    monkeypatch.setattr(mate_gate, "common", lambda ga, *a: calls.append(ga.name) or real(ga, *a))
    measured = [mate_gate.measure(model, _mate(model, n)) for n in PADS]
    assert calls == ["pad_a"]
    assert measured[0].penetration_mm > 0  # a press fit: the pin overlaps, at a point
    assert len({m.point for m in measured}) == 5  # each pair's own point, where it stands


def test_a_measure_taken_from_a_twin_pair_is_the_pairs_own(model):
    clear_caches()
    first = mate_gate.measure(model, _mate(model, "pad_a_seat"))
    shared = mate_gate.measure(model, _mate(model, "pad_d_seat"))
    clear_caches()
    clear_mesh_cache()
    alone = mate_gate.measure(model, _mate(model, "pad_d_seat"))
    assert shared.area_mm2 == pytest.approx(alone.area_mm2, rel=1e-9)
    assert shared.penetration_mm == pytest.approx(alone.penetration_mm, abs=1e-9)
    assert np.allclose(shared.point, alone.point, atol=1e-6)
    assert not np.allclose(shared.point, first.point, atol=1.0)
