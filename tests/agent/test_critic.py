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
