"""The persistent part store (issue 26.4): `check`, `render` and `edit` right after a `build` of
the same program recompile nothing, with or without a warm server."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from procedura_brep.program import cache

LAMP = Path(__file__).parent / "lamp.py"

COMPILE = """
import json, sys
from procedura_brep.run import steps
m = steps.compile_model(open(sys.argv[1]).read(), name="lamp")
print(json.dumps({"built": m.timings["parts_built"], "parts": len(m.parts), "ok": m.ok}))
"""


def _env(store: Path | str) -> dict[str, str]:
    return {**os.environ, "PROCEDURA_BREP_CACHE": str(store), "PROCEDURA_BREP_SERVER": "off"}


def _compile(program: Path, store: Path | str) -> dict:
    out = subprocess.run([sys.executable, "-c", COMPILE, str(program)], env=_env(store),
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_a_check_after_a_build_in_another_process_builds_no_part(tmp_path):
    store = tmp_path / "store"
    run = subprocess.run([sys.executable, "-m", "procedura_brep", "build", str(LAMP), "-o",
                          str(tmp_path / "run"), "--formats", "step", "-q"],
                         env=_env(store), capture_output=True, text=True, timeout=180)
    assert run.returncode == 0, run.stderr
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    assert report["timings"]["parts_built"] == 3  # a cold store: every part built once
    assert _compile(LAMP, store) == {"built": 0, "parts": 3, "ok": True}
    # an edit rebuilds what it changed and nothing else: post_h is read by the post alone
    edited = tmp_path / "edited.py"
    edited.write_text(LAMP.read_text().replace("post_h = 80.0", "post_h = 90.0"))
    assert "post_h = 90.0" in edited.read_text()
    assert _compile(edited, store)["built"] == 1
    # off: a private store per process, so every part is built again
    assert _compile(LAMP, "off")["built"] == 3


def test_the_store_folder_follows_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENV_CACHE, "off")
    assert cache.persistent_root() is None and cache.persistent_dir() is None
    monkeypatch.setenv(cache.ENV_CACHE, str(tmp_path / "mine"))
    folder = Path(cache.persistent_dir())
    assert folder.parent == tmp_path / "mine" and folder.is_dir()
    assert (tmp_path / "mine").stat().st_mode & 0o777 == 0o700  # only its user enters
    monkeypatch.delenv(cache.ENV_CACHE)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.persistent_root() == tmp_path / "xdg" / "procedura-brep" / "parts"
    # a store that cannot be made: None (the worker keeps a private one), not an error
    (tmp_path / "file").write_text("x")
    monkeypatch.setenv(cache.ENV_CACHE, str(tmp_path / "file" / "store"))
    assert cache.persistent_dir() is None


def test_prune_drops_stale_versions_and_trims_the_current_one(tmp_path):
    keep, stale, fresh = tmp_path / "keep", tmp_path / "stale", tmp_path / "fresh"
    for d in (keep, stale, fresh):
        d.mkdir()
    (stale / "a.brep").write_bytes(b"x")
    old = time.time() - cache.STALE_AFTER_S - 10
    os.utime(stale, (old, old))
    (fresh / "b.brep").write_bytes(b"x")
    for i in range(4):
        f = keep / f"{i}.brep"
        f.write_bytes(b"y" * 100)
        os.utime(f, (1000 + i, 1000 + i))
    gone = cache.prune(tmp_path, keep=keep, max_bytes=250)
    assert not stale.exists() and fresh.exists()
    assert sorted(p.name for p in keep.iterdir()) == ["2.brep", "3.brep"]  # oldest went first
    assert gone == 1 + 2
