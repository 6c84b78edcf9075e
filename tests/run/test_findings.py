"""Findings are the one currency, and one policy decides pass or fail."""

from __future__ import annotations

import re
from pathlib import Path

from procedura_brep import findings as fmod
from procedura_brep.findings import Finding, blocking, blocks, failed

SRC = Path(fmod.__file__).parent


def test_finding_lives_in_the_base_layer_and_is_re_exported():
    from procedura_brep.gates.policy import Severity
    from procedura_brep.program import model
    assert model.Finding is Finding and model.cap_text is fmod.cap_text
    assert Severity is fmod.Severity and fmod.SEVERITIES == ("error", "warning", "info")


def test_the_policy_on_findings_and_their_dicts():
    err, warn, info = Finding("a", "x"), Finding("b", "y", severity="warning"), Finding("c", "z", severity="info")
    assert err.severity == "error"  # the default
    assert failed([warn, err, info]) and not failed([warn, info]) and not failed([])
    assert blocking([warn, err, info]) == [err]
    assert blocks({"code": "d", "message": "no severity"})  # a dict without one is an error
    assert not blocks(warn.as_dict()) and blocking([warn.as_dict(), err.as_dict()]) == [err.as_dict()]
    assert Finding.from_dict({**err.as_dict(), "extra": 1}) == err


def test_gates_decide_with_the_same_policy():
    from procedura_brep.gates import decide
    assert decide([Finding("w", "m", severity="warning")]) and not decide([Finding("e", "m")])


# comparisons of a severity with a finding severity name, either way round, and `severity in`
_COMPARE = re.compile(r"""severity["']?\s*(?:,\s*["']\w+["']\s*)?\)?\s*(?:==|!=)\s*["'](?:error|warning|info)["']"""
                      r"""|["'](?:error|warning|info)["']\s*(?:==|!=)\s*[\w.]*(?:get\(\s*["'])?severity"""
                      r"""|\bseverity["']?\)?\s+(?:not\s+)?in\s""")


def test_no_copy_of_the_policy_outside_findings_py():
    hits = []
    for path in sorted(SRC.rglob("*.py")):
        if path == SRC / "findings.py":
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if _COMPARE.search(line):
                hits.append(f"{path.relative_to(SRC)}:{n}: {line.strip()}")
    assert not hits, "decide pass/fail with procedura_brep.findings (blocks/blocking/failed):\n" + "\n".join(hits)


def test_the_grep_catches_the_usual_spellings():
    for line in ('if f.severity == "error":', "x = f.get('severity') == 'error'",
                 'f.get("severity", "error") == "error"', '"error" == f.severity',
                 "any(f.severity in fail_on for f in fs)", 'key=lambda f: f.severity != "error"'):
        assert _COMPARE.search(line), line
    for line in ('severity="error" if worse else "warning"', 'Finding("x", "y", severity="warning")',
                 'i.severity == "HIGH"'):
        assert not _COMPARE.search(line), line
