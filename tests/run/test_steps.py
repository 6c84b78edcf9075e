"""The run layer's steps, each called alone: compile and gate write nothing; a model that
fails its gates is exported only when asked; the battery checks the bundle just written from
the compiled model and never reads program.py."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from procedura_brep.findings import failed
from procedura_brep.run import steps
from procedura_brep.run.build import build, verify_and_export
from procedura_brep.sim.battery import ALL_CHECKS

LAMP = Path(__file__).parents[1] / "program" / "lamp.py"
LIFTED = LAMP.read_text().replace("foot=Location((0, 0, 0))", "foot=Location((0, 0, -0.5))")


def _tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def _quiet(msg: dict) -> None:
    pass


def test_compile_then_gate_writes_no_files(tmp_path, worker, monkeypatch):
    monkeypatch.chdir(tmp_path)
    model = steps.compile_model(LAMP.read_text(), name="lamp")
    verdict = steps.gate(model, LAMP.read_text())
    assert model.ok and [p.name for p in model.parts] == ["base", "post", "arm"]
    assert verdict.passed and verdict.errors == [] and verdict.report["passed"] is True
    assert _tree(tmp_path) == []


def test_gate_verdict_follows_the_policy(worker):
    model = steps.compile_model(LIFTED, name="lamp")
    verdict = steps.gate(model, LIFTED)
    assert not verdict.passed and failed(verdict.findings)
    assert verdict.errors and all(f.severity == "error" for f in verdict.errors)
    assert verdict.errors[0].mate == "post_foot" and verdict.report["passed"] is False


@pytest.mark.parametrize("export_failed", [False, True])
def test_a_gate_failure_exports_nothing_unless_asked(tmp_path, worker, export_failed):
    model = steps.compile_model(LIFTED, name="lamp")
    out = verify_and_export(model, LIFTED, tmp_path, ("step",), gates=True, simulate=False,
                            export_failed=export_failed, step_schema="AP214", send=_quiet)
    assert out["gate_errors"] and out["sections"]["gates"]["passed"] is False
    assert out["exported"] is export_failed
    if export_failed:
        # the sheet is drawn here unless this process holds GL (an earlier test rendered): then
        # the build's parent draws it (tests/run/test_sheet.py)
        sheet = [] if steps.gl_in_use() else ["sheet.png"]
        assert sorted(out["files"]) == ["mates.json", "model.step", *sheet]
        assert _tree(tmp_path) == ["mates.json", "model.step", *sheet]
    else:
        assert out["files"] == [] and _tree(tmp_path) == []
        assert not any(k.startswith("export") for k in out["timings"])


def test_export_writes_the_bundle_and_mates_json(tmp_path, worker):
    model = steps.compile_model(LAMP.read_text(), name="lamp")
    bundle = steps.export(model, tmp_path, formats=("step", "obj"))
    assert set(bundle.files) == {"model.step", "model.obj", "model.mtl", "mates.json"}
    assert all(p.is_file() and p.parent == tmp_path for p in bundle.files.values())
    assert "export_step_s" in bundle.timings and "evidence_s" in bundle.timings


def test_battery_runs_on_the_compiled_model_without_program_py(tmp_path, worker):
    """No program.py anywhere near the bundle: the battery takes the model, and checks the
    files export just wrote (it does not write them again)."""
    model = steps.compile_model(LAMP.read_text(), name="lamp")
    bundle = steps.export(model, tmp_path, formats=("urdf", "usd", "mjcf"))
    assert not (tmp_path / "program.py").exists()
    stamps = {rel: os.stat(p).st_mtime_ns for rel, p in bundle.files.items()}
    verdict = steps.simulate(model, bundle)
    assert verdict.passed and verdict.findings == [], verdict.report
    assert [c["id"] for c in verdict.report["checks"]][:2] == ["B0", "B1"]
    assert {rel: os.stat(p).st_mtime_ns for rel, p in bundle.files.items()} == stamps


def test_build_simulates_without_reading_program_py(tmp_path, worker, monkeypatch):
    """The plant: program.py is deleted from the staging folder right after the export, before
    the battery; the build must still simulate the model it compiled."""
    real = steps.export

    def export_then_delete(model, root, **kw):
        bundle = real(model, root, **kw)
        (root / "program.py").unlink()
        return bundle

    monkeypatch.setattr(steps, "export", export_then_delete)
    res = build(LAMP, tmp_path / "run", formats=("urdf", "usd", "mjcf"), simulate=True)
    assert res.ok, res.reason
    assert res.report["battery"]["passed"] is True and [c["id"] for c in res.report["battery"]["checks"]] == list(ALL_CHECKS)


def test_battery_findings_name_each_failed_check():
    from procedura_brep.sim.battery import failures
    report = {"checks": [{"id": "B0", "name": "model fidelity", "passed": True},
                         {"id": "B2", "name": "joint sweeps", "passed": False, "message": "joint j"},
                         {"id": "B4", "name": "wheeled mobility", "passed": True, "skipped": True},
                         {"id": "B7", "name": "", "passed": False}]}
    fs = failures(report)
    assert [f.code for f in fs] == ["battery-B2", "battery-B7"] and failed(fs)
    assert fs[0].message == "battery B2 (joint sweeps) failed: joint j"
    assert fs[1].message == "battery B7 failed: no message"
    assert failures({"checks": report["checks"][:1]}) == []


def test_build_gates_before_it_exports(tmp_path, worker):
    lines: list[str] = []
    res = build(LAMP, tmp_path / "run", formats=("step",), progress=lines.append)
    assert res.ok and res.exit_code == 0
    sheet = ["drawing sheet.png"] if steps.gl_in_use() else []  # see above
    assert lines == ["compiling lamp", "running the gates", "writing 3 parts as step, viewer",
                     *sheet, f"saving {tmp_path / 'run'}"]
    assert list(res.report["timings"]).index("gates_s") < list(res.report["timings"]).index("export_s")


@pytest.mark.skipif(not Path("/proc/self").exists(), reason="Linux isolation layers")
def test_the_report_says_which_isolation_layers_the_compile_ran_under(tmp_path, worker):
    """report.json carries the compile child's OS layers (issue 10: they were only in
    ``doctor`` and the debug log), as the child logged them before any program code ran."""
    import json

    from procedura_brep.program.isolation import probe
    res = build(LAMP, tmp_path / "run", formats=("step",), progress=_quiet)
    line = json.loads((tmp_path / "run" / "report.json").read_text())["isolation"]
    assert line == res.model.isolation and line.startswith("applied: ")
    expected = probe()
    for layer in expected.applied:
        if layer != "own_uid":  # the worker's uid is not in the child's log
            assert layer in line.split(";")[0], (layer, line)


def test_report_is_laid_out_once():
    from procedura_brep.findings import Finding
    from procedura_brep.run.report import run_report
    from procedura_brep.run.status import Status
    rep = run_report(Status.FAILED, None, [Finding("compile", "no parts")], {"total_s": 1.0})
    assert list(rep) == ["status", "program", "findings", "timings"]
    assert rep["status"] == "failed" and type(rep["status"]) is str and rep["program"] is None
    rep = run_report(Status.OK, None, [], {}, sections={"gates": {"passed": True}}, complete=True)
    assert list(rep) == ["status", "program", "findings", "timings", "gates", "complete"]


def test_cli_keep_failed_exports_a_model_that_fails_its_gates(tmp_path, worker):
    from typer.testing import CliRunner

    from procedura_brep.cli import app
    lifted = tmp_path / "lifted.py"
    lifted.write_text(LIFTED)
    for flag, files in (([], ["program.py", "report.json", "summary.md"]),
                        (["--keep-failed"], ["mates.json", "model.step", "program.py", "report.json", "sheet.png",
                                           "summary.md", "viewer", "viewer.html", *(f"viewer/{f}" for f in (
                                               "LICENSE-three", "app.js", "data.js", "findings.js",
                                               "three.min.js"))])):
        out = tmp_path / f"o{len(flag)}"
        res = CliRunner().invoke(app, ["build", str(lifted), "-o", str(out), "--formats", "step", "-q", *flag])
        assert res.exit_code == 1 and "post is not seated on base" in res.stderr, res.output
        assert _tree(out) == files
