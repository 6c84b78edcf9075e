"""The articulation reply states only what it changes: the links, wheels and base the tool
already knows are optional."""

from __future__ import annotations

from pathlib import Path

import pytest

from procedura_brep.agent.articulation_plan import ArticulationPlanError, parse_articulation

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"


@pytest.fixture(scope="module")
def lamp(worker):
    from procedura_brep.program import compile_source
    model = compile_source(LAMP.read_text(), name="lamp", worker=worker)
    assert model.ok, model.findings
    return model


def test_a_reply_need_not_restate_links_base_or_wheels(lamp):
    plan = parse_articulation('{"joints": [{"mate": "arm_pivot", "effort": 4}]}', lamp)
    assert plan.base is None and plan.links is None and plan.wheels is None
    assert plan.edits[0].options == {"effort": 4.0}
    assert parse_articulation('{"joints": []}', lamp).edits == []


def test_a_stated_base_is_still_checked(lamp):
    assert parse_articulation('{"joints": [], "base": "welded"}', lamp).base == "welded"
    with pytest.raises(ArticulationPlanError, match="base must be"):
        parse_articulation('{"joints": [], "base": "bolted"}', lamp)
