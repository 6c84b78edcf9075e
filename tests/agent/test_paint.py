"""The materials stage's reply formats (strict) and its deterministic splice into a program."""

from __future__ import annotations

import difflib
import json
from pathlib import Path

import pytest

from procedura_brep.agent.paint import (
    Entry,
    PaintError,
    apply_materials,
    declared_entries,
    parse_assignment,
)

LAMP = (Path(__file__).parents[1] / "program" / "lamp.py").read_text()
PARTS = ["base", "post", "arm"]
RED = {"name": "lamp_red", "base": "painted_aluminium", "rgb": [0.8, 0.1, 0.1], "roughness": 0.4}


def reply(**obj) -> str:
    return "Here you are.\n```json\n" + json.dumps(obj) + "\n```\n"


def test_a_complete_reply_parses():
    a = parse_assignment(reply(summary="s", library=[RED], assign={"base": "cast_iron", "post": "lamp_red",
                                                                    "arm": "rubber"}), parts=PARTS)
    assert a.summary == "s" and a.library[0].name == "lamp_red" and a.assign["post"] == "lamp_red"
    assert a.library[0].material().rgb == (0.8, 0.1, 0.1)


@pytest.mark.parametrize("obj, message", [
    ({"assign": {"base": "steel", "post": "steel"}}, "assign one material to every part; missing: arm"),
    ({"assign": {"base": "steel", "post": "steel", "arm": "steel", "lid": "steel"}},
     "assign names part\\(s\\) not in the program: lid; parts: base, post, arm"),
    ({"assign": {"base": "steel", "post": "steel", "arm": "lamp_rd"}}, "unknown material\\(s\\) in assign \\(arm: 'lamp_rd'\\)"),
    ({"library": [dict(RED, roughness=2)], "assign": {}}, "library\\[0\\]: material 'lamp_red': roughness = 2 is outside"),
    ({"library": [dict(RED, shiny=True)], "assign": {}}, "unknown field\\(s\\) shiny"),
    ({"library": [dict(RED, name="steel")], "assign": {}}, "material 'steel' is a built-in material"),
    ({"library": [RED, RED], "assign": {}}, "named twice: lamp_red"),
    ({"library": [dict(RED, base="lamp_red")], "assign": {}}, "base 'lamp_red' is not a built-in"),
    ({"assign": {}, "colours": {}}, "unknown key\\(s\\) colours"),
])
def test_malformed_replies_are_refused_with_the_reason(obj, message):
    with pytest.raises(PaintError, match=message):
        parse_assignment(reply(**obj), parts=PARTS)


def test_bad_json_is_refused():
    with pytest.raises(PaintError, match="does not parse"):
        parse_assignment("```json\n{\"assign\": \n```", parts=PARTS)
    with pytest.raises(PaintError, match="no JSON object"):
        parse_assignment("I think the base should be red.", parts=PARTS)


def test_a_critic_reply_names_only_changes_and_may_use_the_program_entries():
    current = (Entry("lamp_red", {"base": "steel"}),)
    a = parse_assignment(reply(summary="post to red", assign={"post": "lamp_red"}), parts=PARTS,
                         current=current, complete=False)
    assert a.assign == {"post": "lamp_red"}
    with pytest.raises(PaintError, match="unknown material"):
        parse_assignment(reply(assign={"post": "lamp_red"}), parts=PARTS, complete=False)


def test_rewrites_format():
    from procedura_brep.agent.subparts import parse_subparts
    lib = {"steel"}
    assert parse_subparts("REWRITES: none", parts=PARTS, library=lib) == []
    got = parse_subparts("REWRITE arm\n## params\nnone\nREWRITE post\n## body\nx", parts=PARTS, library=lib)
    assert [(e.kind, e.part) for e in got] == [("rewrite", "arm"), ("rewrite", "post")]
    assert "## params" in got[0].text
    with pytest.raises(PaintError, match="REWRITE lid: no such part"):
        parse_subparts("REWRITE lid\n", parts=PARTS, library=lib)
    with pytest.raises(PaintError, match="REWRITES: none"):
        parse_subparts("nothing to do", parts=PARTS, library=lib)


def test_the_splice_changes_only_declarations_and_material_options():
    entries = (Entry("lamp_red", {"base": "painted_aluminium", "rgb": (0.8, 0.1, 0.1)}),)
    out = apply_materials(LAMP, entries, {"post": "lamp_red", "arm": "rubber"})
    diff = [d for d in difflib.unified_diff(LAMP.split("\n"), out.split("\n"), lineterm="", n=0)
            if d[:1] in "+-" and not d.startswith(("+++", "---"))]
    assert diff == [
        '+material("lamp_red", base="painted_aluminium", rgb=(0.8, 0.1, 0.1))', "+",
        '-@part(detail="major", material="brushed_steel", description="vertical post at the base centre")',
        '+@part(detail="major", material="lamp_red", description="vertical post at the base centre")',
        '-@part(detail="major", material="painted_aluminium", description="arm swinging about a pin at the post top")',
        '+@part(detail="major", material="rubber", description="arm swinging about a pin at the post top")']
    assert declared_entries(out) == entries
    # a second splice replaces the declarations instead of adding to them
    again = apply_materials(out, (Entry("blue", {"base": "steel", "rgb": (0.0, 0.0, 1.0)}),), {"post": "blue"})
    assert [e.name for e in declared_entries(again)] == ["blue"] and again.count("material(") == 1


def test_the_splice_adds_a_material_option_where_there_is_none():
    src = LAMP.replace('@part(detail="major", material="brushed_steel", ', "@part(").replace(
        '@part(detail="major", material="painted_aluminium", description="arm swinging about a pin at the post top")',
        "@part")
    out = apply_materials(src, (), {"post": "nylon", "arm": "rubber"})
    assert '@part(material="nylon", description="vertical post at the base centre")' in out
    assert '@part(material="rubber")\ndef arm():' in out
    with pytest.raises(PaintError, match="part lid has no @part"):
        apply_materials(LAMP, (), {"lid": "steel"})
