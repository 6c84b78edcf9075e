"""The plan parser and the one-direction review."""

from __future__ import annotations

import json

import pytest

from procedura_brep.agent.plan import PlanError, parse_plan
from procedura_brep.agent.review import enforce_review


def part(name, *partners, mtype="bolt_pattern", detail="major", desc=None):
    return {"name": name, "detail": detail, "description": desc or f"the {name}, about 100 mm across",
            "mates": [{"partner": p, "type": mtype, "nominal": f"{name}_d"} for p in partners]}


ROVER = [part("chassis", detail="silhouette"), part("rocker_l", "chassis", mtype="revolute"),
         part("rocker_r", "chassis", mtype="revolute"), part("wheel_l", "rocker_l", mtype="revolute"),
         part("wheel_r", "rocker_r", mtype="revolute"), part("mast", "chassis")]


def plan(rows):
    return parse_plan("Here is the plan:\n```json\n" + json.dumps({"parts": rows}) + "\n```\n")


def test_a_good_plan_parses_in_order():
    p = plan(ROVER)
    assert p.names == ["chassis", "rocker_l", "rocker_r", "wheel_l", "wheel_r", "mast"]
    assert p.part("wheel_l").mates[0].type == "revolute" and p.children("chassis") == ["rocker_l", "rocker_r", "mast"]
    assert parse_plan(json.dumps(ROVER)).names == p.names  # a bare list is accepted too


def test_forward_mates_are_reordered_and_noted():
    rows = [ROVER[0], ROVER[3], ROVER[1]]  # wheel_l listed before its rocker
    p = plan(rows)
    assert p.names == ["chassis", "rocker_l", "wheel_l"]
    assert p.notes == ("moved wheel_l after its partner(s) rocker_l",)


def test_every_problem_is_reported_at_once():
    rows = [part("Chassis"), part("arm", "chassis", mtype="hinge"), part("arm", "chassis"),
            {"name": "leg", "detail": "huge", "description": "x", "mates": [{"partner": "leg", "type": "key",
                                                                           "nominal": 12}]},
            part("wheel_pair", "nowhere")]
    with pytest.raises(PlanError) as info:
        plan(rows)
    text = "\n".join(info.value.problems)
    for needle in ["part 1: name 'Chassis' must be snake_case", "type 'hinge' is not a mate type",
                   "part arm: the name is used twice", "detail 'huge' must be one of",
                   "give a description", "cannot mate to itself", "nominal 12 must be a param name",
                   "one entry stands for several parts", "partner 'nowhere' is not in the plan"]:
        assert needle in text, needle


@pytest.mark.parametrize("reply,needle", [
    ("no json here", "holds no JSON object"),
    ('```json\n{"parts": [\n```', "does not parse"),
    ('{"items": []}', 'expected an object {"parts"'),
    ('{"parts": []}', "no parts"),
])
def test_malformed_replies(reply, needle):
    with pytest.raises(PlanError, match=needle):
        parse_plan(reply)


def test_cycles_and_unmated_parts_are_errors():
    with pytest.raises(PlanError, match="cycle through"):
        plan([part("a", "b"), part("b", "a")])
    with pytest.raises(PlanError, match="part b: every part but the root needs a mate"):
        plan([part("a"), part("b")])


def test_review_keeps_everything_and_admits_additions_after_their_partner():
    original = plan(ROVER)
    rows = [dict(r) for r in ROVER]
    rows[0] = part("chassis", detail="silhouette", desc="600 x 400 x 120 mm box frame, the root")
    rows.insert(6, part("bracket", "rocker_l"))  # listed at the end by the reviewer
    rows.append(part("camera", "mast"))
    merged, repairs = enforce_review(original, plan(rows))
    assert merged.names == ["chassis", "rocker_l", "bracket", "rocker_r", "wheel_l", "wheel_r", "mast", "camera"]
    assert merged.part("chassis").description.startswith("600 x 400")
    assert repairs == []


@pytest.mark.parametrize("edit,names,repair", [
    # dropped
    (lambda r: [x for x in r if x["name"] != "mast"], None, "restored dropped part mast"),
    # renamed in place
    (lambda r: [part("left_rocker", "chassis") if x["name"] == "rocker_l" else
                part("wheel_l", "left_rocker") if x["name"] == "wheel_l" else x for x in r], None,
     "reverted the rename of rocker_l into left_rocker"),
    # merged (two dropped, one new in their gap)
    (lambda r: [r[0], part("rockers_lr", "chassis"), part("wheel_l", "rockers_lr"),
                part("wheel_r", "rockers_lr"), r[5]], None,
     "reverted the merge of rocker_l, rocker_r into rockers_lr"),
    # reordered
    (lambda r: [r[0], r[2], r[1], *r[3:]], None, "restored the original order"),
])
def test_review_that_takes_away_is_repaired_and_logged(edit, names, repair):
    original = plan(ROVER)
    merged, repairs = enforce_review(original, plan(edit([dict(r) for r in ROVER])))
    assert merged.names == original.names
    assert any(r.startswith(repair) for r in repairs), repairs
    for i, p in enumerate(merged.parts):  # still a topological order
        assert set(p.partners) <= set(merged.names[:i]) and (p.mates or i == 0)


def test_review_mates_that_point_forward_are_reverted():
    original = plan(ROVER)
    rows = [dict(r) for r in ROVER]
    rows[1] = part("rocker_l", "chassis", "mast", mtype="revolute")  # now also mates to a later part
    merged, repairs = enforce_review(original, plan(rows))
    assert merged.part("rocker_l").partners == ("chassis",)
    assert any("kept its original mates" in r for r in repairs)


def test_a_plan_mate_can_ask_for_no_features():
    """The plan says features=False for a rail and block that model their own contact; the build
    request passes it on, and the plan's JSON keeps it (the default stays unwritten)."""
    from procedura_brep.agent.context import part_slice
    plan = parse_plan({"parts": [
        {"name": "rail", "detail": "major", "description": "a 600 mm steel rail, 20 x 20 mm"},
        {"name": "block", "detail": "major", "description": "a 60 mm carriage block on the rail",
         "mates": [{"partner": "rail", "type": "prismatic", "nominal": "rail_w", "features": False}]},
        {"name": "cap", "detail": "sub", "description": "a 30 mm end cap on the block's side",
         "mates": [{"partner": "block", "type": "peg_socket", "nominal": "cap_d"}]}]})
    block = plan.part("block")
    assert block.mates[0].features is False and plan.part("cap").mates[0].features is True
    assert "- to rail: prismatic, nominal rail_w, features=False" in part_slice(plan, block)
    assert "features=False" not in part_slice(plan, plan.part("cap"))
    data = json.loads(plan.to_json())
    assert data["parts"][1]["mates"][0]["features"] is False
    assert "features" not in data["parts"][2]["mates"][0]
    assert parse_plan(data) == plan
    with pytest.raises(PlanError, match="features must be true or false"):
        parse_plan({"parts": [data["parts"][0], {**data["parts"][1], "mates": [
            {"partner": "rail", "type": "prismatic", "nominal": "rail_w", "features": "no"}]}]})


def test_a_plan_may_couple_a_driven_part_to_its_driver():
    """Issue 27.5: a driven part names its driver and the transmission; the build request of
    each says who writes the couple(...) and what to share."""
    from procedura_brep.agent.context import part_slice
    gears = [part("housing", detail="silhouette"), part("pinion", "housing", mtype="revolute"),
             {**part("wheel", "housing", mtype="revolute"), "couple": {"driver": "pinion", "type": "gear"}}]
    p = plan(gears)
    assert p.part("wheel").couple.as_dict() == {"driver": "pinion", "type": "gear"}
    assert p.as_dict()["parts"][2]["couple"] == {"driver": "pinion", "type": "gear"}
    wheel, pinion = part_slice(p, p.part("wheel")), part_slice(p, p.part("pinion"))
    assert "Its first joint follows pinion's (gear): after its mate, write couple(" in wheel
    assert "Later parts whose joints it drives: wheel (gear)" in pinion
    # every problem at once: a driver not in the plan, a type not in the vocabulary, a static joint
    bad = [gears[0], part("cover", "housing"),
           {**part("wheel", "housing", mtype="revolute"), "couple": {"driver": "pinon", "type": "gear"}},
           {**part("nut", "housing", mtype="prismatic"), "couple": {"driver": "wheel", "type": "worm"}},
           {**part("cap", "housing"), "couple": {"driver": "cover", "type": "belt"}}]
    with pytest.raises(PlanError) as exc:
        plan(bad)
    text = str(exc.value)
    assert "couple driver 'pinon' is not another part of the plan" in text
    assert "couple type 'worm' is not one of gear, rack_pinion, screw, belt" in text
    assert "needs the driven part cap's first mate to be a kinematic joint" in text
    assert "needs the driver part cover's first mate to be a kinematic joint" in text
    # a driver listed after the part it drives (and not reordered by the mates) is refused
    late = [gears[0], gears[2], gears[1]]
    with pytest.raises(PlanError, match="part wheel: its driver 'pinion' must come before it"):
        plan(late)
