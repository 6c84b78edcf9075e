from __future__ import annotations

from procedura_brep.gates.feedback import context, format_feedback, locate
from procedura_brep.gates.finish import finish_gate
from procedura_brep.gates.policy import decide
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledModel, Finding
from procedura_brep.testing.models import cpart

SRC = """from procedura_brep.program import *
wheel_d = 120.0  # mm

@part(detail="major", material="rubber", description="wheel")
def wheel():
    return Cylinder(wheel_d / 2, 1 / 0)

mate("wheel.hub", "axle.end", "revolute", nominal="axle_d", fit="clearance")
"""


def test_compile_feedback_names_part_line_exception_and_context():
    f = Finding("part-exception", "ZeroDivisionError: division by zero", part="wheel", line=6)
    text = format_feedback(SRC, [f])
    head, *ctx = text.splitlines()
    assert head == "[error] part-exception: part wheel, line 6: ZeroDivisionError: division by zero"
    assert len(ctx) == 3 and ctx[1].strip().startswith("> 6 |")
    assert "1 / 0" in ctx[1] and "def wheel" in ctx[0]


def test_feedback_finds_lines_without_a_line_number():
    assert locate(SRC, Finding("x", "m", part="wheel")) == 5
    assert locate(SRC, Finding("x", "m", mate="wheel.hub")) == 8
    text = format_feedback(SRC, [Finding("mate-registration", "hovers", mate="wheel.hub",
                                         value=0.0, limit=5.0)], around=0)
    assert "(measured 0, limit 5)" in text and text.count("|") == 1


def test_feedback_orders_errors_first_and_truncates():
    fs = [Finding("w", "warn", severity="warning")] + [Finding("e", f"err {i}") for i in range(5)]
    text = format_feedback(None, fs, limit=3)
    assert text.splitlines()[0].startswith("[error]") and "3 more finding(s)" in text
    assert format_feedback(SRC, []) == ""
    assert context(SRC, 1, around=1)[0].startswith("> 1 |")


def test_policy():
    assert decide([Finding("w", "m", severity="warning")])
    assert not decide([Finding("e", "m")])


def test_finish_gate_refuses_with_floaters_and_names_worst():
    from build123d import Align, Box
    body = cpart("body", Box(100, 50, 50, align=(Align.MIN,) * 3))
    panel = cpart("panel", Box(70, 50, 1, align=(Align.MIN,) * 3), trans(0, 0, 60))
    crumb = cpart("crumb", Box(5, 5, 5, align=(Align.MIN,) * 3), trans(0, 0, -20))
    model = CompiledModel(name="m", params={}, parts=[body, panel, crumb], mates=[])
    findings, res = finish_gate(model, top=1)
    assert not res.passed and res.measured["n_vis"] == 2
    assert findings[0].code == "finish-refused" and "panel" in findings[0].message
    assert [f.part for f in findings[1:]] == ["panel"]  # worst only
    assert "bbox (0.0, 0.0, 60.0)..(70.0, 50.0, 61.0)" in findings[1].message
    ok_findings, ok = finish_gate(CompiledModel(name="m", params={}, parts=[body], mates=[]))
    assert ok.passed and ok_findings == [] and ok.measured["n_vis"] == 0
