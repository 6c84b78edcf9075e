"""The staged agent refuses an attempt that draws its part at its assembly position: the origin
finding (a warning in ``check`` and ``build``) blocks there, and the retry is told why and shown
the part's frames as axes."""

from __future__ import annotations

import json

from procedura_brep.agent.staged import RETRY_VIEWS, StagedOptions, generate_staged
from procedura_brep.agent.tools import AGENT_BLOCKING, Tools, attempt_blocks
from procedura_brep.gates import check_model
from procedura_brep.gates.origin import CODE, FIX
from procedura_brep.testing.placed import block_on_base
from procedura_brep.testing.tapes import part_replies, plan_from_program, write_tape


def test_gate_part_blocks_on_the_origin_finding_that_check_only_warns_about(worker):
    world, local = block_on_base(world=True), block_on_base(world=False)
    tools = Tools()
    verdict = tools.gate_part(world, "block", baseline=0)
    assert verdict.compiled and not verdict.ok
    assert [f.code for f in verdict.errors] == [CODE] and CODE in AGENT_BLOCKING
    assert all(attempt_blocks(f) for f in verdict.errors)
    assert check_model(verdict.model, world).passed  # the same finding is a warning there
    assert tools.gate_part(local, "block", baseline=0).ok


def test_a_staged_build_retries_a_part_drawn_in_world_coordinates(tmp_path):
    local = block_on_base(world=False)
    base, block = part_replies(local)
    _, world_block = part_replies(block_on_base(world=True))
    calls = [("plan", "```json\n" + json.dumps(plan_from_program(local)) + "\n```"),
             ("build", base), ("build", world_block), ("build", block)]
    rows = [{"v": 1, "role": role, "step": k, "model": "hand-written", "request": {},
             "reply": {"text": text, "usage": {}}} for k, (role, text) in enumerate(calls)]
    rows[0].update(note="HAND-WRITTEN TAPE (built by this test)", prompt="a block on a base plate")
    tape = tmp_path / "tape.jsonl"
    write_tape(tape, rows)
    lines: list[str] = []
    out = tmp_path / "run"
    result = generate_staged(None, out, model=f"replay:{tape}", progress=lambda s, t: lines.append(t),
                             options=StagedOptions(review=False, refine=False, simulate=False))
    assert result.status == "ok", result.message
    assert [c.name for c in result.state.committed] == ["base", "block"]
    assert all(not c.warning for c in result.state.committed)
    assert any("part 2/2 block: attempt 1 failed" in t for t in lines)
    assert any("part 2/2 block: committed (attempt 2)" in t for t in lines)
    feedback = (out / "history" / "002-block.attempt-1.txt").read_text()
    assert "block is drawn 300.0 mm away from its own origin" in feedback and FIX in feedback.lower()
    # the retry carries the finding and renders with the block's origin and frames as axes
    calls_made = [json.loads(x) for x in (out / "transcript.jsonl").read_text().splitlines()]
    retry = next(c for c in calls_made if c["role"] == "build" and c["step"] == 3)
    last = retry["request"]["messages"][-1]
    assert "300.0 mm away from its own origin" in last["text"] and "'block origin'" in last["text"]
    assert len(last["images"]) == len(RETRY_VIEWS)
    program = (out / "program.py").read_text()
    assert 'frames("block", foot=Location((0, 0, 0)))' in program and "Pos(0, block_y" not in program


def test_the_build_prompt_teaches_parts_around_their_own_origin_with_an_example_that_holds(worker):
    """The request says the rule (no more "world coordinates are simplest"), and the build
    prompt's two-part example compiles, passes every gate and has no origin finding, with the
    placements solved from the frames."""
    import ast
    import re

    import numpy as np

    from procedura_brep.agent.prompts import reference, template
    from procedura_brep.testing.models import compiled
    from procedura_brep.testing.programs import program_text
    ref = reference()
    assert "world coordinates are simplest" not in ref
    assert "model each part around its own origin" in ref and "part-origin" in ref
    system = template("build_system")
    assert "own origin" in system
    (example,) = re.findall(r"```python\n(.*?)```", system, flags=re.S)
    tree = ast.parse(example)
    lines = example.splitlines()
    parts = ["\n".join(lines[n.decorator_list[0].lineno - 1:n.end_lineno]) for n in tree.body
             if isinstance(n, ast.FunctionDef)]
    calls = [ast.get_source_segment(example, n) for n in tree.body if isinstance(n, ast.Expr)]
    source = program_text(
        doc="The build prompt's example on a base.",
        params=("base_t = 12.0  # mm", "spigot_d = 12.0  # mm", "post_d = 20.0  # mm",
                "post_h = 80.0  # mm", "pin_d = 8.0  # mm", "arm_l = 90.0  # mm"),
        parts=['@part(detail="silhouette", material="cast_iron", description="base")\n'
               "def base():\n    return Box(120, 120, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))\n",
               *(p + "\n" for p in parts)],
        frames=['frames("base", top=Location((0, 0, base_t)))'] + [c for c in calls if c.startswith("frames(")],
        mates=[c for c in calls if c.startswith("mate(")])
    model = compiled(source, worker=worker)
    report = check_model(model, source)
    assert report.passed, report.feedback
    assert not [f for f in report.findings if f.code == CODE]
    np.testing.assert_allclose(model.part("post").placement[:3, 3], [0, 0, 12])
    np.testing.assert_allclose(model.part("arm").placement[:3, 3], [0, 0, 92])
