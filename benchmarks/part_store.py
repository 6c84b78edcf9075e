"""The persistent part store (issue 26.4): `check`, `render` and `edit --build` of a program right
after a `build` of it, each a fresh CLI process with no warm server, with the store on (the
build's parts loaded) and off (every part built again), in one run, taking turns.

Prints per command: wall seconds (median), the compile's seconds and how many parts it built
(from a compile in the same configuration), and the on/off ratio.

Run: ``python benchmarks/part_store.py [--program golden/rover/program.py] [--runs 3]``
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

COMPILE = """
import json, sys, time
from procedura_brep.run import steps
t = time.perf_counter()
m = steps.compile_model(open(sys.argv[1]).read(), name="m", warm=True)
print(json.dumps({"s": time.perf_counter() - t, "built": m.timings["parts_built"]}))
"""


def _run(args: list[str], env: dict[str, str]) -> float:
    t = time.perf_counter()
    out = subprocess.run([sys.executable, "-m", "procedura_brep", *args, "-q"], env=env,
                         capture_output=True, text=True)
    if out.returncode not in (0, 1):
        raise SystemExit(f"{args[0]} failed: {out.stderr.strip()}")
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--program", type=Path, default=ROOT / "golden" / "rover" / "program.py")
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="part-store-bench-"))
    store = tmp / "store"
    base = {**os.environ, "PROCEDURA_BREP_SERVER": "off"}
    envs = {"on": {**base, "PROCEDURA_BREP_CACHE": str(store)},
            "off": {**base, "PROCEDURA_BREP_CACHE": "off"}}
    prog = tmp / "program.py"
    shutil.copy(a.program, prog)
    from procedura_brep.program.sections import parse_sections
    last = list(parse_sections(prog.read_text()).params)[-1]
    value = parse_sections(prog.read_text()).params[last].expr
    commands = {
        "check": ["check", str(prog)],
        "render": ["render", str(prog), "-o", str(tmp / "r"), "--views", "iso_se"],
        "edit --build (same value)": ["edit", str(prog), "--set", f"{last}={value}",
                                      "--build", str(tmp / "e")],
    }
    times: dict[tuple[str, str], list[float]] = {}
    _run(["build", str(prog), "-o", str(tmp / "b")], envs["on"])  # the build that fills the store
    for _ in range(a.runs):
        for mode in ("on", "off"):
            for name, args in commands.items():
                times.setdefault((name, mode), []).append(_run(args, envs[mode]))
    comp = {}
    for mode in ("on", "off"):
        out = subprocess.run([sys.executable, "-c", COMPILE, str(prog)], env=envs[mode],
                             capture_output=True, text=True, check=True)
        comp[mode] = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"program {a.program.relative_to(ROOT) if a.program.is_relative_to(ROOT) else a.program}, "
          f"{a.runs} runs, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
          f"load {os.getloadavg()[0]:.2f}")
    for mode in ("on", "off"):
        print(f"compile, store {mode}: {comp[mode]['s']:.2f} s, {int(comp[mode]['built'])} parts built")
    print(f"{'command':28s} {'store on':>9s} {'store off':>9s} {'ratio':>6s}")
    for name in commands:
        on, off = statistics.median(times[(name, "on")]), statistics.median(times[(name, "off")])
        print(f"{name:28s} {on:8.2f}s {off:8.2f}s {on / off:6.2f}")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
