"""The parent trusts nothing from the sandbox child: crafted replies injected at the parent
boundary (``sandbox._result``) end in a ``bad-result`` finding, never in a file written outside
its folder, an internal error or exit code 3."""

from __future__ import annotations

import copy
import json
import math
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app
from procedura_brep.config import SANDBOX
from procedura_brep.errors import CompileError
from procedura_brep.program import cache, sandbox
from procedura_brep.program.model import to_json

LAMP_PATH = Path(__file__).parent / "lamp.py"
LAMP = LAMP_PATH.read_text()


@pytest.fixture(scope="module")
def good(worker) -> dict:
    """A genuine child result for the lamp (JSON, as the child writes it)."""
    return json.loads(json.dumps(to_json(worker.compile(LAMP))))


def _set(payload: dict, path: tuple, value) -> dict:
    d = copy.deepcopy(payload)
    node = d
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return d


NAN_M = [[math.nan] * 4] * 4
CRAFTED = [
    ("cache_key_traversal", ("parts", 0, "cache_key"), "../x", "cache_key"),
    ("part_name_traversal", ("parts", 0, "name"), "../../../x", "is not a name"),
    ("part_name_newline", ("parts", 0, "name"), "base\n", "is not a name"),
    ("part_name_usd", ("parts", 0, "name"), "Base Plate", "is not a name"),
    ("part_name_digit", ("parts", 0, "name"), "0base", "is not a name"),
    ("frame_name_traversal", ("parts", 0, "frames"), {"../top": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}, "is not a name"),
    ("nan_frame", ("parts", 0, "frames", "top"), NAN_M, "not a finite 4x4 matrix"),
    ("inf_placement", ("parts", 1, "placement"), [[1, 0, 0, math.inf], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not a finite 4x4 matrix"),
    ("scaled_placement", ("parts", 1, "placement"), [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not a rigid transform"),
    # every rigidity condition on its own, each naming its field (the matrices of a result are
    # checked together, after the parts and mates are read)
    ("mirrored_placement", ("parts", 2, "placement"), [[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "part arm.placement is not a rigid transform"),
    ("projective_frame", ("parts", 0, "frames", "top"), [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0.5, 1]], "part base.frames[top] is not a rigid transform"),
    ("far_world_frame", ("mates", 1, "world_frame"), [[1, 0, 0, 2e9], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "world_frame is not a rigid transform"),
    ("ragged_placement", ("parts", 0, "placement"), [[1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "not a 4x4 matrix of numbers"),
    ("short_placement", ("parts", 0, "placement"), [[1, 0, 0, 0]], "not a finite 4x4 matrix"),
    ("unknown_material", ("parts", 0, "material"), "unobtanium", "not a library material"),
    ("non_string_material", ("parts", 0, "material"), {"x": 1}, "not a library material"),
    ("bad_detail", ("parts", 0, "detail"), "huge", "detail"),
    ("bad_brep", ("parts", 0, "brep"), "!!not base64!!", "base64"),
    ("mate_name_traversal", ("mates", 0, "name"), "../m", "is not a name"),
    ("mate_unknown_type", ("mates", 0, "type"), "teleport", "not a mate type"),
    ("mate_nan_nominal", ("mates", 0, "nominal"), math.nan, "not a finite number"),
    ("mate_nan_world", ("mates", 0, "world_frame"), NAN_M, "not a finite 4x4 matrix"),
    ("param_inf", ("params", "pin_d"), math.inf, "not a finite number"),
    ("param_object", ("params", "pin_d"), {"a": 1}, "not a finite number"),
    ("timing_nan", ("timings", "exec_s"), math.nan, "not a finite number"),
    ("finding_bad_severity", ("findings",), [{"code": "x", "message": "m", "severity": "boom"}], "severity"),
    ("finding_unknown_field", ("findings",), [{"code": "x", "message": "m", "evil": 1}], "unknown fields"),
    ("parts_not_a_list", ("parts",), {"a": 1}, "is not a list"),
    ("too_many_parts", ("parts",), [{}] * (SANDBOX.max_parts + 1), "is not a list of at most"),
]


@pytest.mark.parametrize("pid, path, value, needle", CRAFTED, ids=[c[0] for c in CRAFTED])
def test_crafted_result_is_a_finding(tmp_path, good, pid, path, value, needle):
    (tmp_path / "result.json").write_text(json.dumps(_set(good, path, value)))
    with pytest.raises(CompileError) as exc:
        sandbox._result({"status": "exit", "detail": "0"}, str(tmp_path), SANDBOX)
    f = exc.value.findings[0]
    assert f.code == "bad-result" and needle in f.message, f.message
    assert "\n" not in f.message and len(f.message) <= 400


def test_a_part_claimed_cached_is_read_from_the_parents_cache_or_refused(tmp_path, good):
    """A part marked ``"cached"`` takes its BRep from the parent's own cache, by its key; a
    key the cache lacks, or no cache at all, is a ``bad-result`` naming the field."""
    claimed = copy.deepcopy(good)
    part = claimed["parts"][0]
    brep = part.pop("brep")
    part["cached"] = True
    (tmp_path / "result.json").write_text(json.dumps(claimed))
    for folder in (None, str(tmp_path / "empty")):
        with pytest.raises(CompileError) as exc:
            sandbox._result({"status": "exit"}, str(tmp_path), SANDBOX, cache_dir=folder)
        assert exc.value.findings[0].code == "bad-result" and "parts[0]" not in exc.value.findings[0].message
        assert "part base.cached" in exc.value.findings[0].message, exc.value.findings[0].message
    import base64
    store = tmp_path / "store"
    cache.store(store, part["cache_key"], base64.b64decode(brep))
    m = sandbox._result({"status": "exit"}, str(tmp_path), SANDBOX, cache_dir=str(store))
    assert m.parts[0].brep == base64.b64decode(brep) and m.parts[0].from_cache


def test_genuine_result_passes(tmp_path, good):
    (tmp_path / "result.json").write_text(json.dumps(good))
    m = sandbox._result({"status": "exit"}, str(tmp_path), SANDBOX, name="lamp")
    assert m.name == "lamp" and [p.name for p in m.parts] == ["base", "post", "arm"]


@pytest.mark.parametrize("raw, needle", [
    (b"{not json", "not valid JSON"),
    (b"[" * 100_000 + b"]" * 100_000, "not valid JSON"),
    (json.dumps({"fatal": {"code": "x", "message": "A" * 10_000_000}}).encode(), ""),
])
def test_broken_files(tmp_path, raw, needle):
    (tmp_path / "result.json").write_bytes(raw)
    with pytest.raises(CompileError) as exc:
        sandbox._result({"status": "exit"}, str(tmp_path), SANDBOX)
    assert needle in str(exc.value) and len(str(exc.value)) <= SANDBOX.message_chars + 64


def test_symlinked_result_is_refused(tmp_path):
    target = tmp_path / "elsewhere.json"
    target.write_text("{}")
    os.symlink(target, tmp_path / "result.json")
    with pytest.raises(CompileError, match="bad-result|invalid result|No such|Too many|loop|symbolic"):
        sandbox._result({"status": "exit"}, str(tmp_path), SANDBOX)


def test_cache_never_writes_outside_its_folder(tmp_path):
    folder = tmp_path / "cache"
    with pytest.raises(ValueError, match="not a sha256 hex digest"):
        cache.store(folder, "../x", b"data")
    assert not (tmp_path / "x.brep").exists()
    assert cache.load(folder, "../x") is None


@pytest.mark.parametrize("pid, path, value", [
    ("part_name", ("parts", 0, "name"), "../../../x"),
    ("cache_key", ("parts", 0, "cache_key"), "../x"),
    ("nan_frame", ("parts", 0, "frames", "top"), NAN_M),
    ("material", ("parts", 0, "material"), 7),
])
def test_cli_build_with_a_crafted_child_is_exit_2_with_a_report(tmp_path, good, monkeypatch, pid, path, value):
    crafted = _set(good, path, value)
    monkeypatch.setattr(sandbox, "_read_result", lambda p, limits: crafted)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["build", str(LAMP_PATH), "-o", str(out), "--formats", "step"])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and "internal error" not in res.output
    report = json.loads((out / "report.json").read_text())
    assert report["findings"][0]["code"] == "bad-result"
    assert sorted(p.name for p in out.iterdir()) == ["program.py", "report.json", "summary.md"]
    assert not (tmp_path / "x").exists() and not list(tmp_path.glob("**/x.*"))
