"""check, render, export and simulate do their tessellating work in the limited child
(:mod:`procedura_brep.run.commands`): a blow-up there is one error line and exit 1, never a dead CLI.

The plants run the real CLI in a fresh process (no GL context, nothing meshed before the fork,
as for a user) with the stage's work replaced by a memory hog or a sleeper.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.cli import app

LAMP = Path(__file__).parent / "program" / "lamp.py"
#: command -> (module, attribute) of the work the child does
WORK = {
    "check": ("procedura_brep.gates", "check_model"),
    "export": ("procedura_brep.export.bundle", "write_bundle"),
    "render": ("procedura_brep.render", "render_to_dir"),
    "simulate": ("procedura_brep.sim.battery", "run_battery"),
}
HARNESS = """
import importlib, sys, time
from procedura_brep import limited as isolate
from procedura_brep.config import ParentLimits
mod, attr, plant, wall = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
def hog(*a, **k):
    return bytearray(64 * 2**30)  # over config.PARENT's address-space limit
def sleeper(*a, **k):
    time.sleep(60)
setattr(importlib.import_module(mod), attr, hog if plant == "memory" else sleeper)
isolate.PARENT = ParentLimits(wall_s=wall)
sys.argv = ["procedura-brep", *sys.argv[5:]]
from procedura_brep.cli import main
main()
"""


def _args(cmd: str, out: Path) -> list[str]:
    return {"check": ["check", str(LAMP)], "export": ["export", str(LAMP), "-o", str(out)],
            "render": ["render", str(LAMP), "-o", str(out), "--views", "iso_ne", "--size", "64"],
            "simulate": ["simulate", str(LAMP)]}[cmd]


def _planted(cmd: str, plant: str, tmp_path: Path, *extra: str, wall: float = 600.0):
    mod, attr = WORK[cmd]
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", HARNESS, mod, attr, plant, str(wall),
                           *_args(cmd, tmp_path / "out"), "-q", *extra],
                          capture_output=True, text=True, timeout=300)
    return proc, time.perf_counter() - t


def _errors(proc) -> list[str]:
    assert "Traceback" not in proc.stderr, proc.stderr
    return [ln for ln in proc.stderr.splitlines() if not ln.startswith("Fontconfig")]


@pytest.mark.parametrize("cmd", sorted(WORK))
def test_a_memory_blow_up_in_the_child_is_one_line_and_exit_1(cmd, tmp_path):
    proc, _ = _planted(cmd, "memory", tmp_path)
    errors = _errors(proc)
    assert proc.returncode == 1, (proc.returncode, proc.stderr)
    assert len(errors) == 1 and errors[0].startswith("error:"), errors
    assert "stage ran out of memory (address-space limit" in errors[0], errors[0]


@pytest.mark.slow  # over 3 s here: not in the fast lane (pytest -m "not slow")
def test_a_check_over_the_wall_clock_is_exit_1_also_as_json(tmp_path):
    proc, seconds = _planted("check", "sleep", tmp_path, "--json", wall=2.0)
    assert proc.returncode == 1, proc.stderr
    data = json.loads(proc.stdout)
    assert data["passed"] is False and data["compiled"] is True
    assert "gates stage did not finish within the wall-clock limit (2 s" in data["error"]
    assert seconds < 60  # the sleeper (60 s) was killed, not waited for


runner = CliRunner()
#: hostile programs through each command: (id, arm body, text of the one error line)
HOSTILE = [
    ("sphere_1e5", "return Sphere(1e5)", "exceeds the extent cap"),
    ("message_50mb", "raise ValueError('A' * 50_000_000)", "ValueError"),
]


def _in_arm(body: str) -> str:
    text = LAMP.read_text()
    return text.replace("def arm():\n", f"def arm():\n    {body}\n")


@pytest.mark.parametrize("cmd", sorted(WORK))
@pytest.mark.parametrize("case", HOSTILE, ids=[c[0] for c in HOSTILE])
def test_hostile_programs_end_clean_in_every_command(cmd, case, tmp_path):
    cid, body, needle = case
    prog = tmp_path / "hostile.py"
    prog.write_text(_in_arm(body))
    args = _args(cmd, tmp_path / "out")
    args[1] = str(prog)
    t = time.perf_counter()
    res = runner.invoke(app, [*args, "-q"])
    seconds = time.perf_counter() - t
    assert "Traceback" not in res.output
    errors = [ln for ln in res.stderr.splitlines() if not ln.startswith("Fontconfig")]
    assert res.exit_code == 2 and len(errors) == 1, (res.exit_code, errors)
    assert "does not compile" in errors[0] and needle in errors[0], errors[0][:300]
    assert len(errors[0]) <= 4000
    assert seconds < 60, seconds


def test_an_error_the_child_raises_on_purpose_keeps_its_exit_code(tmp_path):
    """An unknown close-up name is found in the render child: still a usage error (exit 2)."""
    res = runner.invoke(app, ["render", str(LAMP), "-o", str(tmp_path / "r"), "--views", "iso_ne",
                              "--size", "64", "--close-up", "nosuch", "-q"])
    assert "Traceback" not in res.output
    errors = [ln for ln in res.stderr.splitlines() if not ln.startswith("Fontconfig")]
    assert res.exit_code == 2 and len(errors) == 1 and "nosuch" in errors[0], (res.exit_code, errors)


def test_simulate_of_a_6m_sphere_arm_ends_with_the_battery_verdict(tmp_path):
    """Issue 10's last hostile case: ``Sphere(3000)`` as the lamp's arm. ``simulate`` ran past
    300 s (the B2 sweep's surface cover had 5e7 cells at the fixed 1.5 mm); now the cover is
    sized to the part and each joint's exact booleans are budgeted, so it ends with the
    battery's findings (the arm swallows the base: B3), exit 1, within the bound."""
    prog = tmp_path / "hostile.py"
    prog.write_text(_in_arm("return Sphere(3000)"))
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", "from procedura_brep.cli import main; main()",
                           "simulate", str(prog), "--json", "-q"],
                          capture_output=True, text=True, timeout=120)
    seconds = time.perf_counter() - t
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert proc.returncode == 1, (proc.returncode, proc.stderr[-2000:])
    checks = {c["id"]: c for c in json.loads(proc.stdout)["checks"]}
    assert not checks["B3"]["passed"] and "'arm'" in checks["B3"]["message"]
    assert seconds < 120


def test_the_cli_leaves_with_its_exit_code_after_the_atexit_handlers(tmp_path):
    """``main`` skips the interpreter teardown (1.2 s of OCCT/MuJoCo/USD destructors a cold
    build) but keeps the exit code and runs the atexit handlers (compile worker, temp folders)."""
    bad = tmp_path / "bad.py"
    bad.write_text(_in_arm("return [][3]"))
    marker = tmp_path / "atexit.txt"
    code = ("import atexit, sys; atexit.register(lambda p=sys.argv[1]: open(p, 'w').write('ran')); "
            "sys.argv = ['procedura-brep', 'check', sys.argv[2], '-q']; "
            "from procedura_brep.cli import main; main()")
    proc = subprocess.run([sys.executable, "-c", code, str(marker), str(bad)], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 2 and "IndexError" in proc.stderr, (proc.returncode, proc.stderr[-500:])
    assert marker.read_text() == "ran"
