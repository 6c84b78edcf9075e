"""A run directory is always consistent: a failed, broken or interrupted rebuild never leaves a
new program beside old models, nor an old report that says ok (policy in procedura_brep.run.directory)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from procedura_brep.run import steps
from procedura_brep.run.build import build

LAMP = Path(__file__).parent / "program" / "lamp.py"
BROKEN = LAMP.read_text().replace("return Box(90, 14, 10", "return Box(90, 14, -10")


def _files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def _report(out: Path) -> dict:
    return json.loads((out / "report.json").read_text())


@pytest.fixture()
def good(tmp_path, worker):
    """A complete lamp build (step, obj, glb) plus a file the build does not own."""
    out = tmp_path / "run"
    res = build(LAMP, out, formats=("step", "obj", "glb"))
    assert res.ok, res.reason
    (out / "transcript.jsonl").write_text("{}\n")
    return out


def test_failed_rebuild_keeps_the_last_good_build(good):
    before = _files(good)
    res = build(LAMP, good, source=BROKEN, formats=("step", "obj", "glb"))
    assert res.status == "failed" and "part arm" in res.reason
    after = _files(good)
    assert set(after) == set(before)  # no staging folder, nothing added or removed
    assert [k for k in before if before[k] != after[k]] == ["report.json", "summary.md"]
    assert (good / "program.py").read_text() == LAMP.read_text()  # matches the models
    rep = _report(good)
    assert rep["status"] == "failed" and rep["kept_previous"] is True
    assert rep["findings"][0]["part"] == "arm" and "line" in rep["findings"][0]
    assert rep["previous"]["status"] == "ok" and rep["previous"]["complete"] is True
    # a second failure still knows which build the files belong to
    build(LAMP, good, source=BROKEN, formats=("step",))
    assert _report(good)["previous"]["status"] == "ok"
    assert _files(good)["model.glb"] == before["model.glb"]


def test_failed_first_build_leaves_the_program_and_no_stale_models(tmp_path, worker):
    out = tmp_path / "run"
    out.mkdir()
    for stale in ("model.step", "model.glb", "mates.json"):  # an old, incomplete build's files
        (out / stale).write_text("stale")
    (out / "report.json").write_text(json.dumps({"status": "failed"}))
    res = build(LAMP, out, source=BROKEN)
    assert res.status == "failed"
    assert sorted(_files(out)) == ["program.py", "report.json", "summary.md"]
    assert (out / "program.py").read_text() == BROKEN
    assert _report(out)["status"] == "failed" and "kept_previous" not in _report(out)


def test_rebuild_with_fewer_formats_removes_stale_exports(good):
    res = build(LAMP, good, formats=("step",))
    assert res.ok
    names = set(_files(good))
    assert "model.glb" not in names and "model.obj" not in names and "model.step" in names
    assert "transcript.jsonl" in names  # not the build's: kept
    assert not [n for n in names if n.startswith(".")]


LIFTED = LAMP.read_text().replace("foot=Location((0, 0, 0))", "foot=Location((0, 0, -0.5))")


def test_gates_failed_build_exports_nothing_and_keeps_the_old_one(good):
    before = _files(good)
    res = build(LAMP, good, source=LIFTED, formats=("step",))
    assert res.status == "gates_failed" and res.exit_code == 1
    assert "post is not seated on base" in res.reason  # the failing gate, not "gates_failed"
    assert (good / "program.py").read_text() == LAMP.read_text()  # the kept build's program
    assert {k: v for k, v in _files(good).items() if k not in ("report.json", "summary.md")} == \
        {k: v for k, v in before.items() if k not in ("report.json", "summary.md")}
    rep = _report(good)
    assert rep["status"] == "gates_failed" and rep["kept_previous"] is True
    assert rep["findings"][0]["mate"] == "post_foot" and not rep["gates"]["passed"]
    assert not any(k.startswith("export_") for k in rep["timings"])  # gates ran, no export


def test_gates_failed_first_build_writes_only_program_and_report(tmp_path, worker):
    out = tmp_path / "run"
    res = build(LAMP, out, source=LIFTED, formats=("step",))
    assert res.status == "gates_failed"
    assert sorted(_files(out)) == ["program.py", "report.json", "summary.md"]
    assert (out / "program.py").read_text() == LIFTED


def test_a_failed_build_after_a_gates_failed_one_keeps_nothing_stale(tmp_path, worker):
    """A gates_failed build that exported nothing is no complete build to keep: the next failed
    build writes its own program and report instead of claiming the old one was kept."""
    out = tmp_path / "run"
    build(LAMP, out, source=LIFTED, formats=("step",))
    broken = LAMP.read_text().replace("# === assembly ===", "# === assembly ===\n(")
    res = build(LAMP, out, source=broken, formats=("step",))
    assert res.status == "failed"
    rep = _report(out)
    assert "kept_previous" not in rep and rep["status"] == "failed"
    assert (out / "program.py").read_text() == broken


def test_gates_failed_build_with_export_failed_is_complete_and_replaces_the_old_one(good):
    res = build(LAMP, good, source=LIFTED, formats=("step",), export_failed=True)
    assert res.status == "gates_failed"
    assert (good / "program.py").read_text() == LIFTED and "model.glb" not in _files(good)
    assert {"model.step", "mates.json"} <= set(_files(good))
    rep = _report(good)
    assert rep["complete"] is True and "kept_previous" not in rep
    assert rep["findings"][0]["mate"] == "post_foot"


def test_our_bug_writes_a_report_and_keeps_the_good_build(good, monkeypatch):
    before = _files(good)

    def boom(*a, **k):
        raise RuntimeError("exporter bug")

    monkeypatch.setattr("procedura_brep.export.bundle.write_bundle", boom)
    with pytest.raises(RuntimeError):
        build(LAMP, good, formats=("step",))
    rep = _report(good)
    assert rep["status"] == "failed" and rep["kept_previous"] is True
    assert "exporter bug" in rep["findings"][-1]["message"] and rep["findings"][-1]["code"] == "internal"
    assert {k: v for k, v in _files(good).items() if k not in ("report.json", "summary.md")} == \
        {k: v for k, v in before.items() if k not in ("report.json", "summary.md")}


def test_keyboard_interrupt_in_process_writes_interrupted(good, monkeypatch):
    before = _files(good)

    def ctrl_c(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(steps, "gate", ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        build(LAMP, good, formats=("step",))
    rep = _report(good)
    assert rep["status"] == "interrupted" and rep["findings"][-1]["message"].endswith("gates")
    assert set(_files(good)) == set(before)


# --- the parent's meshing, exports, gates and battery run in a limited child ---

def _vm_size() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmSize:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmSize")


@pytest.mark.parametrize("plant, kind", [("memory", "parent-memory"), ("time", "parent-timeout")])
def test_a_blow_up_after_the_compile_is_one_line_and_a_report(tmp_path, worker, monkeypatch,
                                                              plant, kind):
    from typer.testing import CliRunner

    from procedura_brep.cli import app
    from procedura_brep.config import ParentLimits
    # the plant: gates that want 4 GiB under a limit of 512 MiB more than this process maps,
    # or a wall-clock limit of 0.2 s
    if plant == "memory":
        steps.compile_model(LAMP.read_text(), name="lamp", warm=True)  # this process's imports
        limits = ParentLimits(address_space_bytes=_vm_size() + 512 * 2**20)

        def greedy(model, source):
            return {"hoard": bytearray(4 * 2**30)}

        monkeypatch.setattr(steps, "gate", greedy)
    else:
        limits = ParentLimits(wall_s=0.2)

        def slow(model, source):  # warm caches can make a real lamp build finish inside 0.2 s
            import time
            time.sleep(5)
            return {}

        monkeypatch.setattr(steps, "gate", slow)
    monkeypatch.setattr("procedura_brep.limited.PARENT", limits)
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["build", str(LAMP), "-o", str(out)])
    assert res.exit_code == 1, res.output
    errors = [l for l in res.stderr.splitlines() if l.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in res.output, res.output
    assert ("the gates stage ran out of memory (address-space limit" in errors[0]
            if plant == "memory" else "wall-clock limit (0.2 s" in errors[0]), errors[0]
    rep = _report(out)
    assert rep["status"] == "failed" and rep["findings"][-1]["code"] == kind
    assert sorted(_files(out)) == ["program.py", "report.json", "summary.md"]
