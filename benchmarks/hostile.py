"""Hostile-program benchmark (issue 10.1): the time each case takes to a clean end through the
real CLI, and whether it ended clean.

Each case runs ``procedura-brep build`` (or ``edit``) in a subprocess with a timeout, and then
``check``, ``render``, ``export`` and ``simulate`` of the same program (one row each; their
meshing, gates, exports, renders and battery run in the limited child too). "Clean"
means: the process exited by itself with 0, 1 or 2 (never 3, a signal or the timeout), stderr
is one line without a traceback, and no output line is longer than 4000 characters. The
target is a clean error well under 30 s for every case the size caps refuse; cases the caps
accept (``Sphere(3000)``, the crossed plates) are timed and shown with their exit code.

A second figure ("warm s") is the compile alone in an already warm worker (the sandbox child's
share, without the CLI's start-up, meshing and gates).

Run: ``python benchmarks/hostile.py [--timeout 120] [--only sphere_1e5,edit_4mb_comment]
[--commands build,check,render,export,simulate] [--no-warm]``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LAMP = (ROOT / "tests" / "program" / "lamp.py").read_text()


def in_arm(body: str) -> str:
    """The lamp whose ``arm`` part runs ``body`` first."""
    return LAMP.replace("def arm():\n", "def arm():\n" + "".join(f"    {ln}\n" for ln in body.splitlines()))


def crossed_plates(n: int) -> str:
    """Two parts of ``n`` thin plates each, crossing at 90 deg, seated on one another with
    ``features=False`` (n^2 plate crossings for the interference and connectivity gates)."""
    return f'''"""Two grids of {n} thin plates crossing each other. procedura-brep program."""
from procedura_brep.program import *

# === params ===
n_plates = {n}  # count, plates per grid
pitch = 4.0  # mm, plate spacing
plate_t = 0.5  # mm, plate thickness
seat_d = 10.0  # mm, nominal of the seat
# === helpers ===
def grid():
    return Compound([Pos(0, (i - n_plates / 2) * pitch, 0) * Box(n_plates * pitch, plate_t, 10)
                     for i in range(n_plates)])
# === parts ===
@part(detail="major", material="steel", description="plates along X")
def grid_a():
    return grid()

@part(detail="major", material="steel", description="plates along Y, through grid_a")
def grid_b():
    return Rot(0, 0, 90) * grid()

# === frames ===
frames("grid_a", seat=Location((0, 0, 0)))
frames("grid_b", seat=Location((0, 0, 0)))
# === assembly ===
mate("grid_b.seat", "grid_a.seat", "seat_face", nominal="seat_d", features=False)
'''


def cases() -> list[tuple[str, str, str, list[str]]]:
    """(id, kind 'build' | 'edit', program text, extra CLI args)."""
    big_comment = LAMP.replace('"""Desk', "#" + "x" * (4 * 1024**2) + '\n"""Desk', 1)
    big_literal = LAMP.replace("# === helpers ===", "# === helpers ===\nBIG = ["
                               + "1, " * (10 * 1024**2 // 3) + "]")
    return [
        ("sphere_1e5", "build", in_arm("return Sphere(1e5)"), []),
        ("sphere_1e4", "build", in_arm("return Sphere(1e4)"), []),
        ("sphere_3000", "build", in_arm("return Sphere(3000)"), []),
        ("cylinder_1e6_1", "build", in_arm("return Cylinder(1e6, 1)"), []),
        ("compound_10000_boxes", "build",
         in_arm("return Compound([Pos(0, 2 * i, 0) * Box(1, 1, 1) for i in range(10000)])"), []),
        ("compound_3000_boxes", "build",
         in_arm("return Compound([Pos(0, 2 * i, 0) * Box(1, 1, 1) for i in range(3000)])"), []),
        ("crossed_plates_25", "build", crossed_plates(25), []),
        ("crossed_plates_50", "build", crossed_plates(50), []),
        ("crossed_plates_100", "build", crossed_plates(100), []),
        ("edit_4mb_comment", "edit", big_comment, ["--set", "pin_d=6"]),
        ("list_literal_10mb", "build", big_literal, []),
        ("message_50mb", "build", in_arm("raise ValueError('A' * 50_000_000)"), []),
    ]


#: The commands a program-kind case runs, with their extra arguments (OUT: the output folder).
COMMANDS = {
    "build": ["-o", "OUT", "--formats", "step"],
    "check": [],
    "render": ["-o", "OUT", "--views", "iso_ne", "--size", "128"],
    "export": ["-o", "OUT", "--formats", "step"],
    "simulate": [],
}


def run(kind: str, source: str, extra: list[str], timeout: float) -> tuple[float, int | None, str, bool]:
    """(seconds, exit code or None on timeout, first stderr line, clean?)."""
    with tempfile.TemporaryDirectory() as tmp:
        prog = Path(tmp) / "hostile.py"
        prog.write_text(source)
        cmd = [sys.executable, "-m", "procedura_brep.cli", kind, str(prog), "-q"]  # no progress lines
        cmd += [str(Path(tmp) / "out") if a == "OUT" else a for a in COMMANDS.get(kind, extra)]
        t = time.perf_counter()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return time.perf_counter() - t, None, f"timed out after {timeout:g} s", False
        dt = time.perf_counter() - t
        err = proc.stderr.strip().splitlines()
        err = [ln for ln in err if not ln.startswith("Fontconfig")]
        first = err[0] if err else (proc.stdout.strip().splitlines() or [""])[0][:200]
        clean = (proc.returncode in (0, 1, 2) and len(err) <= 1 and "Traceback" not in proc.stderr
                 and all(len(ln) <= 4000 for ln in (proc.stdout + proc.stderr).splitlines()))
        return dt, proc.returncode, first, clean


def warm_compile(source: str) -> tuple[float, str]:
    """Seconds to the end of a compile in an already warm worker, and the first error."""
    from procedura_brep.errors import CompileError
    from procedura_brep.program.sandbox import CompileOptions, default_worker
    w = default_worker()
    t = time.perf_counter()
    try:
        m = w.compile(source, CompileOptions(cache=False))
        errs = [f.message for f in m.findings if f.severity == "error"]
    except CompileError as exc:
        errs = [str(exc)]
    return time.perf_counter() - t, (errs[0] if errs else "compiled")


def main() -> None:
    ap = argparse.ArgumentParser(description="time hostile programs to a clean error via the CLI")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--only", default="", help="comma list of case ids")
    ap.add_argument("--no-warm", dest="warm", action="store_false",
                    help="skip the second figure: the compile alone in a warm worker")
    ap.add_argument("--commands", default=",".join(COMMANDS),
                    help="comma list of the commands each program case runs")
    args = ap.parse_args()
    only = {s for s in args.only.split(",") if s}
    commands = [c for c in args.commands.split(",") if c in COMMANDS]
    print(f"{'case':24} {'command':8} {'CLI s':>7} {'exit':>5} clean {'warm s':>7}  "
          f"first line of the error")
    for cid, kind, src, extra in cases():
        if only and cid not in only:
            continue
        for cmd in commands if kind == "build" else [kind]:
            dt, code, first, clean = run(cmd, src, extra, args.timeout)
            warm = (f"{warm_compile(src)[0]:7.2f}" if cmd == "build" and args.warm
                    else "      -")
            print(f"{cid:24} {cmd:8} {dt:7.1f} {str(code):>5} {'yes' if clean else 'NO ':5} "
                  f"{warm}  {first[:150]}", flush=True)


if __name__ == "__main__":
    main()
