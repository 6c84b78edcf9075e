"""The export overlapped with the gates (:mod:`procedura_brep.run.overlap`): the same files as
the serial export, nothing shipped for a model that fails its gates, and every way the export's
child can fail reported as the serial export's failure is."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest

from procedura_brep.errors import ProceduraError
from procedura_brep.run import build as pipeline
from procedura_brep.run import overlap
from procedura_brep.run.build import build

LAMP = Path(__file__).resolve().parents[1] / "program" / "lamp.py"
LIFTED = LAMP.read_text().replace("foot=Location((0, 0, 0))", "foot=Location((0, 0, -0.5))")


def _files(out: Path) -> dict[str, bytes]:
    return {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}


def _report(out: Path) -> dict:
    return json.loads((out / "report.json").read_text())


@pytest.fixture(params=[True, False], ids=["overlapped", "serial"])
def mode(request, monkeypatch) -> bool:
    monkeypatch.setattr(pipeline, "OVERLAP_EXPORT", request.param)
    return request.param


def test_the_overlapped_export_writes_the_serial_files_byte_for_byte(tmp_path, worker, monkeypatch):
    runs = {}
    for on in (True, False):
        monkeypatch.setattr(pipeline, "OVERLAP_EXPORT", on)
        out = tmp_path / ("overlapped" if on else "serial")
        res = build(LAMP, out)
        assert res.ok, res.reason
        runs[on] = out
    a, b = _files(runs[True]), _files(runs[False])
    assert set(a) == set(b) and len(a) > 8, sorted(a)
    # only the files that carry timings may differ (summary.md rounds them to 0.01 s: two fast
    # builds can give the same text)
    assert {k for k in a if a[k] != b[k]} <= {"report.json", "summary.md"}
    assert not [p for p in runs[True].rglob("*") if p.name.startswith(".")]
    timings = _report(runs[True])["timings"]
    assert {"tessellate_s", "export_wait_s", "export_step_s", "gates_s"} <= set(timings)
    assert "export_wait_s" not in _report(runs[False])["timings"]  # planted: serial is serial


def test_a_model_that_fails_its_gates_ships_nothing_the_export_wrote_ahead(tmp_path, worker,
                                                                            monkeypatch):
    """The export ran to its end (it leaves a mark outside the run directory; the gates wait
    for it) and was thrown away."""
    import time

    from procedura_brep.run import steps
    mark = tmp_path / "export-ran"
    real_formats, real_gate = overlap.Overlapped._formats, steps.gate

    def formats(self, send):
        out = real_formats(self, send)
        mark.write_text(str(self.folder))
        return out

    def gate(*a, **kw):
        deadline = time.monotonic() + 60
        while not mark.exists() and time.monotonic() < deadline:
            time.sleep(0.01)
        return real_gate(*a, **kw)

    monkeypatch.setattr(overlap.Overlapped, "_formats", formats)
    monkeypatch.setattr(steps, "gate", gate)
    monkeypatch.setattr(pipeline, "OVERLAP_EXPORT", True)
    out = tmp_path / "run"
    res = build(LAMP, out, source=LIFTED)
    assert res.status == "gates_failed"
    assert sorted(_files(out)) == ["program.py", "report.json", "summary.md"]
    assert not any(out.rglob(".export-overlap")) and not any(tmp_path.rglob(".export-overlap"))
    assert mark.exists() and mark.read_text().endswith(overlap.FOLDER)
    assert not any(k.startswith("export_") for k in _report(out)["timings"])


class TreeError(ProceduraError):
    """Stands in for ``ArticulationError`` (the mate graph is not a tree)."""


def test_an_error_of_ours_in_the_export_is_a_finding_either_way(tmp_path, worker, monkeypatch, mode):
    def loop(*a, **k):
        raise TreeError("the mates form a loop: post -> arm -> post")

    monkeypatch.setattr("procedura_brep.export.bundle.write_bundle", loop)
    out = tmp_path / "run"
    res = build(LAMP, out)
    assert res.status == "failed" and res.exit_code == 1, res.reason
    rep = _report(out)
    assert rep["findings"][-1]["message"] == "the mates form a loop: post -> arm -> post"
    assert rep["findings"][-1]["code"] == "export"
    assert sorted(_files(out)) == ["program.py", "report.json", "summary.md"]


def test_our_bug_in_the_export_is_an_internal_error_either_way(tmp_path, worker, monkeypatch, mode):
    def boom(*a, **k):
        raise RuntimeError("exporter bug")

    monkeypatch.setattr("procedura_brep.export.bundle.write_bundle", boom)
    with pytest.raises(RuntimeError, match="RuntimeError in the export stage: exporter bug"):
        build(LAMP, tmp_path / "run")
    rep = _report(tmp_path / "run")
    assert rep["status"] == "failed" and rep["findings"][-1]["code"] == "internal"


def test_a_killed_export_child_is_a_finding_not_an_internal_error(tmp_path, worker, monkeypatch, mode):
    """Overlapped, the export's own child dies: its parent relays the death as its own."""
    def die(*a, **k):
        os.kill(os.getpid(), signal.SIGKILL)

    monkeypatch.setattr("procedura_brep.export.bundle.write_bundle", die)
    out = tmp_path / "run"
    res = build(LAMP, out)
    assert res.status == "failed" and res.exit_code == 1
    rep = _report(out)
    assert rep["findings"][-1]["code"] == "parent-killed", rep["findings"][-1]
    assert "the export stage was killed by SIGKILL" in rep["findings"][-1]["message"]
    assert sorted(_files(out)) == ["program.py", "report.json", "summary.md"]



def test_the_export_child_adopts_the_gates_meshes_instead_of_meshing_again(tmp_path, worker,
                                                                           monkeypatch):
    """Every part is tessellated once, by the gates' process; the export child reads the
    handed-over meshes (planted: without them it tessellates every part itself, and the
    files are the same, so only the count tells)."""
    from procedura_brep import kernel
    from procedura_brep.program.model import clear_mesh_cache
    log = tmp_path / "tessellated"
    real = kernel.tessellate

    def counted(shape, **kw):
        with open(log, "a") as fh:
            fh.write(f"{os.getpid()} {kw.get('name', '?')}\n")
        return real(shape, **kw)

    monkeypatch.setattr(kernel, "tessellate", counted)
    monkeypatch.setattr(pipeline, "OVERLAP_EXPORT", True)
    clear_mesh_cache()  # this test process's meshes would be inherited by both
    res = build(LAMP, tmp_path / "run")
    assert res.ok, res.reason
    rows = [line.split() for line in log.read_text().splitlines()]
    pids = {pid for pid, _ in rows}
    assert len(pids) == 1 and sorted(name for _, name in rows) == ["arm", "base", "post"], rows
