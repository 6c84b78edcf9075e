"""The sub-parts pass's colour blocks end to end: a hand-written tape replayed through the real
pipeline; a PAINT of the arm's tip is accepted (its colour read back from STEP and GLB), a PAINT
whose region misses the post is refused with the measured reason."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from procedura_brep.agent.paint import PaintError
from procedura_brep.agent.staged import StagedOptions, generate_staged
from procedura_brep.agent.subparts import parse_subparts, splice_paint
from procedura_brep.materials import MATERIALS

TAPE = Path(__file__).parents[1] / "tapes" / "lamp_paint.jsonl"
LAMP = (Path(__file__).parents[1] / "program" / "lamp.py").read_text()
PARTS = ["base", "post", "arm"]
LIB = set(MATERIALS)
RUBBER = MATERIALS["rubber"].rgb


def paint(part="arm", name="arm_tip", material="rubber", extra=""):
    return (f'PAINT {part}\n```python\n@paint("{part}", material="{material}"{extra})\n'
            f"def {name}():\n    return Box(1, 1, 1)\n```\n")


def test_the_tape_is_labelled_hand_written():
    first = json.loads(TAPE.read_text().split("\n", 1)[0])
    assert "HAND-WRITTEN" in first["note"] and first["model"] == "hand-written"


def test_paint_and_rewrite_replies_parse():
    assert parse_subparts("REWRITES: none", parts=PARTS, library=LIB) == []
    got = parse_subparts(paint() + "REWRITE post\n## body\nx\n", parts=PARTS, library=LIB)
    assert [(e.kind, e.part, e.blocks) for e in got] == [("paint", "arm", ("arm_tip",)), ("rewrite", "post", ())]
    assert got[0].text.startswith('@paint("arm", material="rubber")')


@pytest.mark.parametrize("text, message", [
    (paint(part="lid"), "PAINT lid: no such part"),
    (paint(material="unobtainium"), "'unobtainium' is not in the run's library"),
    (paint(name="post"), "the name 'post' is taken"),
    (paint() + paint(name="arm_band"), "part arm is edited twice"),
    (paint(extra=", pieces=2"), "material= and description= only"),
    ("PAINT arm\nno code here", "exactly one ```python block"),
    ('PAINT arm\n```python\nx = 1\n```', "only functions decorated with @paint"),
    ('PAINT arm\n```python\n@paint("post", material="rubber")\ndef t():\n    return Box(1, 1, 1)\n```',
     'decorated @paint\\("arm", material=...\\)'),
    ("I would paint the arm", "REWRITES: none"),
])
def test_malformed_paint_replies_are_refused_with_the_reason(text, message):
    with pytest.raises(PaintError, match=message):
        parse_subparts(text, parts=PARTS, library=LIB)


def test_the_splice_puts_the_blocks_after_the_part_and_its_earlier_blocks():
    a1 = '@paint("arm", material="rubber")\ndef a1():\n    return Box(1, 1, 1)'
    a2 = '@paint("arm", material="brass")\ndef a2():\n    return Box(2, 2, 2)'
    one = splice_paint(LAMP, "arm", a1 + "\n")
    two = splice_paint(one, "arm", a2 + "\n")
    assert two.index("def arm():") < two.index("def a1():") < two.index("def a2():") < two.index("# === frames ===")
    assert one.replace("\n\n" + a1, "", 1) == LAMP  # nothing else moved
    assert two.replace("\n\n" + a2, "", 1) == one


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paint") / "lamp"
    result = generate_staged(None, out, model=f"replay:{TAPE}", options=StagedOptions(simulate=False),
                             progress=lambda s, t: None)
    return result, out, json.loads((out / "report.json").read_text())


def test_an_accepted_paint_and_a_refused_one_are_in_the_report(run):
    result, out, report = run
    assert result.status == "ok", result.message
    sub = report["materials"]["steps"][2]
    arm, post = sub["rewrites"]
    assert arm["kind"] == "paint" and arm["accepted"] and arm["blocks"] == ["arm_tip"]
    assert arm["materials"] == {"arm_tip": "rubber"}
    assert arm["volume_after"] == pytest.approx(arm["volume_before"], rel=1e-9)
    assert post["kind"] == "paint" and not post["accepted"]
    assert "block post_band (painted on post): the region misses the part (common volume 0 mm^3" in post["reason"]
    program = (out / "program.py").read_text()
    assert "def arm_tip():" in program and "post_band" not in program
    (hist,) = (out / "history").glob("*-materials-subparts-paint-arm.py")
    assert hist.read_text() == program


def test_the_block_colour_reads_back_from_step_and_glb(run):
    _, out, _ = run
    from procedura_brep.export.glb import srgb_to_linear
    from procedura_brep.export.step import read_step_parts
    step = {p.name: p.rgb for p in read_step_parts((out / "model.step").read_bytes())}
    assert list(step) == ["base", "post", "arm", "arm_tip"]
    assert np.allclose(step["arm_tip"], RUBBER, atol=1 / 255)
    assert np.allclose(step["arm"], (0.78, 0.08, 0.06), atol=1 / 255)
    from procedura_brep.testing.exports import glb_json, glb_node_material
    mat = glb_node_material(glb_json(out / "model.glb"), "arm_tip")
    assert mat["name"] == "arm_tip_rubber"
    assert mat["pbrMetallicRoughness"]["baseColorFactor"] == pytest.approx(
        [*srgb_to_linear(np.array(RUBBER)), 1.0], abs=1e-9)


def test_the_request_lists_the_run_library(run):
    _, out, _ = run
    calls = [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines()]
    req = next(c for c in calls if c["role"] == "subparts")["request"]
    text = req["messages"][0]["text"]
    assert "The run's library" in text and "- chrome: metal" in text and "- rubber: elastomer" in text
    assert "PAINT wheel" in req["system"]


def _bench(tmp_path):
    from procedura_brep.agent import materials as stage
    from procedura_brep.agent.tools import Tools

    class Host:
        tools, name, prompt, out_dir = Tools(), "model", "lamp", tmp_path

    return stage, stage.MaterialsBench(Host(), LAMP)


TIP = ('PAINT arm\n```python\n@paint("arm", material="rubber")\ndef arm_tip():\n'
       '    return Pos(70, 0, 0) * Box(40, 30, 30, align=(Align.MIN, Align.CENTER, Align.CENTER))\n```\n')


def test_a_paint_that_does_not_conserve_the_volume_is_refused(tmp_path, monkeypatch):
    stage, bench = _bench(tmp_path)
    (edit,) = parse_subparts(TIP, parts=bench.parts, library=set(bench.model.materials))
    first = bench.model
    monkeypatch.setattr(stage, "_family_volume", lambda model, part: 1000.0 if model is first else 1001.0)
    row = stage._paint(bench, edit)
    assert not row["accepted"] and "hold 1001 mm^3, not the 1000 mm^3" in row["reason"]
    assert bench.source == LAMP and bench.model is first


def test_an_accepted_paint_updates_the_bench_and_a_critic_can_recolour_the_block(tmp_path):
    from procedura_brep.agent.paint import apply_materials
    stage, bench = _bench(tmp_path)
    (edit,) = parse_subparts(TIP, parts=bench.parts, library=set(bench.model.materials))
    row = stage._paint(bench, edit)
    assert row["accepted"], row
    assert bench.parts == ["base", "post", "arm", "arm_tip"] and "def arm_tip():" in bench.source
    recoloured = apply_materials(bench.source, (), {"arm_tip": "brass"})
    assert '@paint("arm", material="brass")' in recoloured and 'material="rubber"' not in recoloured


def test_the_build_reference_documents_paint():
    from procedura_brep.agent.prompts import reference
    ref = reference()
    assert "### paint(part_name: 'str', *, material: 'str'" in ref and "``part & region``" in ref
