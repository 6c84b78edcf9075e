"""The compile worker started first thing by a cold ``build`` (issue 24.2): the entry point
starts it before the command line's own imports, the default worker adopts that process
(no second one starts), and one nobody adopts is killed when the command ends."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

LAMP = Path(__file__).with_name("lamp.py")

ADOPT = r"""
import json, sys
from procedura_brep.program import sandbox, spawn
started = []
real = spawn.worker_process
def counted():
    started.append(real())
    return started[-1]
spawn.worker_process = counted
sandbox.worker_process = counted
spawn.start_early()
early = started[0].pid
worker = sandbox.default_worker()
model = sandbox.compile_source(open(sys.argv[1]).read(), name="lamp")
print(json.dumps({"early": early, "used": worker._proc.pid, "started": len(started),
                  "parts": sorted(p.name for p in model.parts),
                  "left": spawn.take_early() is None}))
"""

UNUSED = r"""
import sys
from procedura_brep.program import spawn
real, pid_file = spawn.worker_process, sys.argv[1]
def recorded():
    proc = real()
    open(pid_file, "w").write(str(proc.pid))
    return proc
spawn.worker_process = recorded
sys.argv = ["procedura-brep", "build", sys.argv[2], "-o", sys.argv[3]]
from procedura_brep.entry import main
main()
"""


def _env() -> dict[str, str]:
    return {**os.environ, "PROCEDURA_BREP_SERVER": "off", "PROCEDURA_BREP_CACHE": "off"}


def test_the_default_worker_adopts_the_early_process() -> None:
    out = subprocess.run([sys.executable, "-c", ADOPT, str(LAMP)], capture_output=True,
                         text=True, env=_env(), timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    got = json.loads(out.stdout.strip().splitlines()[-1])
    assert got["used"] == got["early"] and got["started"] == 1  # no second worker
    assert got["parts"] == ["arm", "base", "post"] and got["left"]


def test_an_early_worker_nobody_adopts_is_gone_when_the_command_ends(tmp_path) -> None:
    """``build`` of a program that does not exist: the early worker started, the command
    failed before compiling, and the worker does not outlive it (it would go on importing
    build123d for a second, then wait)."""
    pid_file = tmp_path / "pid"
    out = subprocess.run([sys.executable, "-c", UNUSED, str(pid_file), str(tmp_path / "nope.py"),
                          str(tmp_path / "out")], capture_output=True, text=True, env=_env(),
                         timeout=120)
    assert out.returncode == 2, out.stdout + out.stderr  # a user error, said as one
    assert "nope.py" in out.stdout + out.stderr and "Traceback" not in out.stderr
    pid = int(pid_file.read_text())
    assert not Path(f"/proc/{pid}").exists()  # killed and reaped before the command exited
