"""The warm server (`procedura-brep serve`, issue 24.2): later commands compile through it, a
program that runs away leaves it alive, and a server of other code or a dead one is ignored."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from procedura_brep.config import SandboxLimits
from procedura_brep.errors import CompileError
from procedura_brep.program import server
from procedura_brep.program.sandbox import CompileOptions, RemoteWorker, connect_server

LAMP = (Path(__file__).parent / "lamp.py").read_text()
FAST = SandboxLimits(cpu_s=3, wall_s=8.0, address_space_bytes=3 * 1024**3, recursion=500)


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    path = tmp_path_factory.mktemp("srv") / "w.sock"
    env = {**os.environ, "PROCEDURA_BREP_SERVER": "off"}
    proc = subprocess.Popen([sys.executable, "-m", "procedura_brep.cli", "serve", "--socket", str(path)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not path.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    assert path.exists(), proc.stderr.read() if proc.poll() is not None else "no socket in 60 s"
    yield path, proc
    proc.terminate()
    proc.wait(10)


def _remote(path, monkeypatch):
    monkeypatch.delenv("PROCEDURA_BREP_SERVER", raising=False)
    w = connect_server(path)
    assert isinstance(w, RemoteWorker)
    return w


def test_a_program_compiles_through_the_server_as_it_does_locally(served, monkeypatch, worker):
    path, _ = served
    w = _remote(path, monkeypatch)
    try:
        remote = w.compile(LAMP, CompileOptions(name="lamp"))
    finally:
        w.close()
    local = worker.compile(LAMP, CompileOptions(name="lamp"))
    assert remote.ok and [p.name for p in remote.parts] == [p.name for p in local.parts]
    assert [p.digest for p in remote.parts] == [p.digest for p in local.parts]


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_a_runaway_program_ends_in_an_error_and_the_server_lives_on(served, monkeypatch):
    path, proc = served
    w = _remote(path, monkeypatch)
    runaway = LAMP.replace("    return Box(90, 14, 10", "    while True:\n        pass\n    return Box(90, 14, 10")
    with pytest.raises(CompileError, match="CPU time limit|wall-clock limit"):
        w.compile(runaway, CompileOptions(name="lamp", limits=FAST, cache=False))
    w.close()  # a client that leaves
    again = _remote(path, monkeypatch)
    try:
        assert again.compile(LAMP, CompileOptions(name="lamp")).ok and proc.poll() is None
    finally:
        again.close()


def test_a_server_of_other_code_is_ignored(served, monkeypatch):
    path, _ = served
    monkeypatch.delenv("PROCEDURA_BREP_SERVER", raising=False)
    monkeypatch.setattr(server, "code_digest", lambda: "an edited install")
    assert connect_server(path) is None


def test_no_server_or_switched_off_means_a_local_worker(tmp_path, served, monkeypatch):
    path, _ = served
    monkeypatch.delenv("PROCEDURA_BREP_SERVER", raising=False)
    assert connect_server(tmp_path / "nobody.sock") is None
    dead = tmp_path / "dead.sock"
    import socket
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.bind(str(dead))
    s.close()  # a socket file nobody listens on (a killed server)
    assert connect_server(dead) is None
    monkeypatch.setenv("PROCEDURA_BREP_SERVER", "off")
    assert connect_server(path) is None
