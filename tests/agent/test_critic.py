"""The critic's reply format: a defect between two parts names both."""

from __future__ import annotations

import pytest

from procedura_brep.agent.critic import CritiqueError, parse_critique

PARTS = {"tube", "ring", "mount"}


def test_a_pair_defect_names_both_parts_the_first_to_change_first():
    c = parse_critique("SUMMARY: the tube floats in its ring\nISSUES:\n"
                       "- [HIGH] tube+ring: a 3 mm gap all round; widen the tube to the ring's bore.\n"
                       "- [MED] `mount` + `ring`: the ring sits 5 mm high; lower its seat.\n"
                       "- [LOW] mount: add a fillet.", parts=PARTS)
    assert [i.parts for i in c.issues] == [("tube", "ring"), ("mount", "ring"), ("mount",)]
    assert c.issues[0].part == "tube" and c.issues[0].other == "ring"
    assert c.issues[0].line() == "[HIGH] tube+ring: a 3 mm gap all round; widen the tube to the ring's bore."
    assert parse_critique(c.text(), parts=PARTS) == c  # the trail text reads back the same


def test_a_pair_naming_an_unknown_part_is_refused_with_the_format():
    with pytest.raises(CritiqueError, match="part_a\\+part_b.*no part 'sleeve'"):
        parse_critique("SUMMARY: s\nISSUES:\n- [HIGH] tube+sleeve: gap", parts=PARTS)


def test_a_revise_without_parts_may_edit_both_parts_of_a_pair_issue():
    """revise localises to the parts the critic names: a pair issue allows both."""
    from types import SimpleNamespace

    from procedura_brep.agent.refine import RefineBench
    model = SimpleNamespace(parts=[SimpleNamespace(name=n) for n in sorted(PARTS)])
    host = SimpleNamespace(
        tools=SimpleNamespace(compile_model=lambda source, name: model), name="m", prompt="a telescope",
        refs=lambda: [],
        call=lambda role, system, msgs, max_tokens=0: "SUMMARY: s\nISSUES:\n- [HIGH] tube+ring: gap")
    bench = RefineBench(host, allowed=set())
    bench.critique("program", [], [])
    assert bench.allowed == {"tube", "ring"}


def test_a_plan_that_leaves_the_base_to_the_tool_records_no_disagreement():
    from types import SimpleNamespace

    from procedura_brep.agent.articulation import ArticulationStage
    from procedura_brep.agent.articulation_plan import ArticulationPlan
    stage = SimpleNamespace(report={"findings": []})
    art = SimpleNamespace(base="welded", wheels=[], links=[])
    ArticulationStage.compare(stage, ArticulationPlan([], None), art)
    assert stage.report["findings"] == []
    ArticulationStage.compare(stage, ArticulationPlan([], "free"), art)
    assert stage.report["findings"][0].startswith("base: the plan says free")
