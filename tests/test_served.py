"""Commands in a warm server's fork (`procedura-brep serve`, src/procedura_brep/served.py): the
same output, files and exit codes as a local run; Ctrl-C and a client that dies stop the
command as a local Ctrl-C does; a server of other code, an unserved command or the switch off
run here."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from procedura_brep import served as entry
from procedura_brep.program import server

ROOT = Path(__file__).resolve().parents[1]
LAMP = ROOT / "tests" / "program" / "lamp.py"
ROVER = ROOT / "golden" / "rover" / "program.py"
BAD = "from procedura_brep.program import *\n\n@part\ndef base():\n    return Box(10, 10, 1/0)\n"
#: Files a build writes whose bytes say when and how fast (not what): not compared.
TIMED = {"report.json", "summary.md"}


@pytest.fixture(scope="module")
def sock(tmp_path_factory):
    path = tmp_path_factory.mktemp("srv") / "w.sock"
    env = {**os.environ, "PROCEDURA_BREP_SOCKET": str(path)}
    proc = subprocess.Popen([sys.executable, "-m", "procedura_brep", "serve"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 90
    while not path.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.1)
    assert path.exists(), proc.stderr.read() if proc.poll() is not None else "no socket in 90 s"
    yield path
    proc.terminate()
    proc.wait(10)


def _cli(args: list[str], sock: Path, *, served: bool, cwd: Path, **kw):
    env = {**os.environ, "PROCEDURA_BREP_SOCKET": str(sock), "PROCEDURA_BREP_CACHE": "off"}
    env.pop("PROCEDURA_BREP_SERVER") if served else env.update(PROCEDURA_BREP_SERVER="off")
    return subprocess.Popen([sys.executable, "-m", "procedura_brep", *args], env=env, cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _pid(stderr: str) -> int:
    line = next(ln for ln in stderr.splitlines() if "running in a fork of the warm server" in ln)
    return int(line.rsplit("(pid ", 1)[1].rstrip(")"))


def _gone(pid: int, within_s: float = 10.0) -> bool:
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        try:
            with open(f"/proc/{pid}/stat") as fh:
                if fh.read().split(") ")[1].startswith("Z"):
                    return True  # a zombie: exited, its parent reaps it on its next poll
        except OSError:
            return True
        time.sleep(0.05)
    return False


@pytest.mark.slow  # a server start and two builds: over 3 s here
def test_a_served_build_writes_what_a_local_build_writes(sock, tmp_path):
    import re
    (tmp_path / "lamp.py").write_text(LAMP.read_text())
    runs = {}
    for served in (True, False):
        out = tmp_path / ("served" if served else "local")
        proc = _cli(["build", "lamp.py", "-o", out.name, *(["-v"] if served else [])], sock,
                    served=served, cwd=tmp_path)
        stdout, stderr = proc.communicate(timeout=180)
        runs[served] = (proc.returncode, stdout, stderr, out)
    code, stdout, stderr, out = runs[True]
    assert _gone(_pid(stderr))  # it ran in the server's fork (relative paths from the client's folder)
    lcode, lstdout, _, lout = runs[False]
    assert code == lcode == 0

    def same(text: str, name: str) -> str:
        return re.sub(r"\([0-9.]+ s,", "(T s,", text.replace(name, "DIR"))
    assert same(stdout, "served") == same(lstdout, "local") and "status ok" in stdout
    files = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(lout) for p in lout.rglob("*") if p.is_file())
    assert Path("sheet.png") in files and Path("model.step") in files
    for rel in files:
        if rel.name not in TIMED:
            assert (out / rel).read_bytes() == (lout / rel).read_bytes(), rel
    assert json.loads((out / "report.json").read_text())["status"] == "ok"


@pytest.mark.slow  # two builds at once and two checks: over 3 s here
def test_served_commands_run_side_by_side_and_check_reads_as_locally(sock, tmp_path):
    (tmp_path / "lamp.py").write_text(LAMP.read_text())
    both = [_cli(["build", "lamp.py", "-o", f"out{i}", "-q"], sock, served=True, cwd=tmp_path)
            for i in range(2)]
    for proc in both:
        proc.communicate(timeout=180)
        assert proc.returncode == 0
    for rel in ("model.step", "model.glb", "mates.json", "sheet.png"):
        assert (tmp_path / "out0" / rel).read_bytes() == (tmp_path / "out1" / rel).read_bytes()
    checks = []
    for served in (True, False):
        proc = _cli(["check", "lamp.py"], sock, served=served, cwd=tmp_path)
        stdout, _ = proc.communicate(timeout=180)
        checks.append((proc.returncode, stdout))
    assert checks[0] == checks[1] and checks[0][0] == 0 and "all gates pass" in checks[0][1]


@pytest.mark.slow  # a server start and two builds: over 3 s here
def test_a_failing_program_fails_as_it_does_locally(sock, tmp_path):
    (tmp_path / "bad.py").write_text(BAD)
    got = []
    for served in (True, False):
        proc = _cli(["build", "bad.py", "-o", "out"], sock, served=served, cwd=tmp_path)
        stdout, stderr = proc.communicate(timeout=120)
        got.append((proc.returncode, [ln for ln in stderr.splitlines() if ln.startswith("error:")]))
    assert got[0] == got[1] and got[0][0] == 2 and got[0][1]


@pytest.mark.slow  # the rover's build, interrupted: over 3 s here
@pytest.mark.parametrize("how", ["ctrl-c", "client-killed"])
def test_an_interrupted_served_build_stops_as_a_local_one(sock, tmp_path, how):
    proc = _cli(["build", str(ROVER), "-o", "out", "-v"], sock, served=True, cwd=tmp_path,
                start_new_session=True)
    assert proc.stderr is not None
    lines = []
    for line in proc.stderr:
        lines.append(line)
        if "running the gates" in line:
            break
    else:
        raise AssertionError("".join(lines))
    child = _pid("".join(lines))
    if how == "ctrl-c":
        os.killpg(proc.pid, signal.SIGINT)  # as a terminal sends it: the client forwards it
        _, rest = proc.communicate(timeout=60)
        assert proc.returncode == 130 and "error: interrupted" in rest
    else:
        proc.kill()  # the client dies: the server interrupts its fork
        proc.wait(10)
    assert _gone(child, 30.0), f"served command {child} still running"
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["status"] == "interrupted"


def test_the_switch_an_unserved_command_or_no_server_run_here(tmp_path, monkeypatch):
    monkeypatch.delenv("PROCEDURA_BREP_SERVER", raising=False)
    assert entry.served(["build", "p.py"], tmp_path / "nobody.sock") is None
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)  # a server that never answers
    listener.bind(str(tmp_path / "s.sock"))
    listener.listen(1)
    monkeypatch.setenv("PROCEDURA_BREP_SERVER", "off")
    t = time.monotonic()
    assert entry.served(["build", "p.py"], tmp_path / "s.sock") is None
    assert time.monotonic() - t < 1.0  # switched off: not even a connection
    monkeypatch.delenv("PROCEDURA_BREP_SERVER")
    for argv in (["serve"], ["view", "d"], ["--help"], ["build", "--help"], [], ["-v"]):
        assert entry.served(argv, tmp_path / "s.sock") is None, argv
    listener.close()


def test_a_server_of_other_code_is_not_used(tmp_path, monkeypatch):
    """The client compares the handshake's digest (a server of an edited install is ignored),
    and the server compares the request's (it never runs a command of other code)."""
    monkeypatch.delenv("PROCEDURA_BREP_SERVER", raising=False)
    path = tmp_path / "s.sock"
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(1)
    import threading

    def other() -> None:
        conn, _ = listener.accept()
        server._Lines(conn).read()
        server._send(conn, {"digest": "an edited install", "cache_dir": "/x", "pid": 1})
        conn.close()
    t = threading.Thread(target=other, daemon=True)
    t.start()
    assert entry.served(["build", "p.py"], path) is None
    t.join(5)
    listener.close()
    a, b = socket.socketpair()
    r, w = os.pipe()
    fds = [os.dup(r), os.dup(w), os.dup(w)]
    entry.run_served(a, {"op": "run", "argv": ["build", "p.py"], "cwd": str(tmp_path), "env": {},
                         "umask": 0o22, "digest": "an edited install"}, fds,
                     command=lambda: pytest.fail("a refused request ran"))
    reply = server._Lines(b).read() or {}
    assert "error" in reply and "pid" not in reply
    for fd in fds:  # the server closed what the refused request carried
        with pytest.raises(OSError):
            os.fstat(fd)
    for x in (a, b):
        x.close()
    os.close(r), os.close(w)


def test_a_ctrl_c_before_the_command_started_is_forwarded_once_it_has():
    """The window between the request and the server's answer: the client holds the signal
    (no KeyboardInterrupt, no traceback) and hands it to the command once its pid is known."""
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    relay = entry._Relay()
    try:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.05)  # delivered to the handler, which only holds it
        assert relay.pending == [signal.SIGINT] and sleeper.poll() is None
        relay.start(sleeper.pid)
        assert sleeper.wait(10) == -signal.SIGINT
    finally:
        relay.pending.clear()
        relay.restore()
        if sleeper.poll() is None:
            sleeper.kill()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_a_working_folder_gone_before_the_fork_took_it_is_one_error_line(tmp_path, monkeypatch):
    """The client's folder vanished between its request and its fork's chdir: the command ends
    with exit 2 and one line on the client's stderr (no traceback), and the command line's main
    never runs."""
    a, b = socket.socketpair()
    r, w = os.pipe()
    fds = [os.open(os.devnull, os.O_RDONLY), os.dup(w), os.dup(w)]
    os.close(w)
    entry.run_served(a, {"op": "run", "argv": ["build", "p.py"], "cwd": str(tmp_path / "gone"),
                         "env": {}, "umask": 0o22, "digest": server.code_digest()}, fds,
                     command=lambda: os._exit(99))
    lines = server._Lines(b)
    assert isinstance((lines.read() or {}).get("pid"), int)
    assert lines.read() == {"exit": 2}
    with os.fdopen(r) as err:
        text = err.read()
    assert text.startswith("error: cannot enter the working folder") and "Traceback" not in text
    a.close(), b.close()


def _fake_server(path: Path, then):
    """A server of this code that takes one run request and then does ``then(conn)``."""
    import threading
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(1)

    def serve_one() -> None:
        conn, _ = listener.accept()
        lines = server._Lines(conn)
        lines.read()
        server._send(conn, {"digest": server.code_digest(), "cache_dir": "/x", "pid": 1})
        assert (lines.read() or {}).get("op") == "run"
        for fd in lines.fds:
            os.close(fd)
        then(conn)
        listener.close()
    t = threading.Thread(target=serve_one, daemon=True)
    t.start()
    return t


@pytest.mark.parametrize("then,expect", [
    ("refuse", None),         # refused before it forked: the command runs here
    ("vanish", 1),            # gone without an answer: it may have forked, so never run here too
    ("ctrl-c", 130),          # a Ctrl-C while waiting: stop, and the dropped connection stops it there
])
def test_what_a_client_does_once_it_has_asked(tmp_path, monkeypatch, capfd, then, expect):
    monkeypatch.delenv("PROCEDURA_BREP_SERVER", raising=False)
    path = tmp_path / "s.sock"
    actions = {"refuse": lambda c: (server._send(c, {"error": "refused"}), c.close()),
               "vanish": lambda c: c.close(),
               "ctrl-c": lambda c: (os.kill(os.getpid(), signal.SIGINT), time.sleep(1.0), c.close())}
    t = _fake_server(path, actions[then])
    saved = {sig: signal.getsignal(sig) for sig in entry.FORWARDED}
    try:
        assert entry.served(["build", "p.py"], path) == expect
        # a command run here finds the handlers as they were; a served one's client exits now
        assert (signal.getsignal(signal.SIGINT) is saved[signal.SIGINT]) == (expect is None)
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)
    t.join(5)
    err = capfd.readouterr().err
    assert ("went away" in err) == (then == "vanish")


def test_a_usage_error_names_the_program_as_the_client_was_called(sock, tmp_path):
    """The server runs as ``python -m procedura_brep``; a client called as the console script
    (``procedura-brep``) gets the same usage line served as local, with its own name."""
    script = ("import sys\n"
              "sys.argv[0] = '/usr/local/bin/procedura-brep'\n"
              "from procedura_brep.entry import main\n"
              "main()\n")
    errs = {}
    for served in (True, False):
        env = {**os.environ, "PROCEDURA_BREP_SOCKET": str(sock)}
        env.pop("PROCEDURA_BREP_SERVER", None) if served else env.update(PROCEDURA_BREP_SERVER="off")
        proc = subprocess.run([sys.executable, "-c", script, "-v", "build", "--nope"], env=env,
                              cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stderr
        errs[served] = proc.stderr
    assert "running in a fork of the warm server" in errs[True]  # it was served
    usage = [ln for ln in errs[True].splitlines() if "Usage:" in ln]
    assert usage and usage == [ln for ln in errs[False].splitlines() if "Usage:" in ln]
    assert "procedura-brep build" in usage[0] and "python -m" not in usage[0]
