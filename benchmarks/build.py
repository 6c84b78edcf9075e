"""Build benchmark (issue 2 item 9).

For each golden program: the cold ``procedura-brep build`` time, measured from process start to
exit (imports and worker start included, every export written), and the per-part compile time
in a warm worker (median over runs; each run compiles the whole program with the part cache
off, and a part's time is its function plus its features). Targets: the whole build of
golden/rover under 10 s wall on a 2-core machine; a part's compile well under a second.

Run: ``python benchmarks/build.py [--runs 3] [--formats step]``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ("rover", "arm", "vise")


def cold_build(name: str, formats: str | None) -> float:
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "procedura_brep.cli", "build", str(ROOT / "golden" / name / "program.py"),
               "-o", out]
        if formats:
            cmd += ["--formats", formats]
        t = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        dt = time.perf_counter() - t
        if proc.returncode != 0:
            raise SystemExit(f"build of {name} failed: {proc.stderr.strip() or proc.stdout.strip()}")
        return dt


def part_times(name: str, runs: int) -> dict[str, float]:
    from procedura_brep.program.sandbox import CompileOptions, default_worker
    src = (ROOT / "golden" / name / "program.py").read_text()
    w = default_worker()
    per: dict[str, list[float]] = {}
    for _ in range(runs):
        m = w.compile(src, CompileOptions(name=name, cache=False))
        mates = {mm.name: (mm.child, mm.parent) for mm in m.mates}
        for p in m.parts:
            t = m.timings.get(f"part:{p.name}", 0.0)
            t += sum(v for k, v in m.timings.items() if k.startswith("mate:")
                     and p.name in mates.get(k[5:], ()))
            per.setdefault(p.name, []).append(t)
    return {k: statistics.median(v) for k, v in per.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description="cold build and warm per-part compile times")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--formats", default=None, help="exports for the cold build (default: all)")
    args = ap.parse_args()
    for name in GOLDEN:
        if not (ROOT / "golden" / name / "program.py").exists():
            print(f"{name}: missing")
            continue
        colds = [cold_build(name, args.formats) for _ in range(args.runs)]
        per = part_times(name, args.runs)
        worst = max(per, key=per.get)
        print(f"{name}: cold build median {statistics.median(colds):.2f} s (min {min(colds):.2f}, "
              f"{args.runs} runs, formats {args.formats or 'all'}); {len(per)} parts, warm per-part "
              f"compile median {statistics.median(per.values()) * 1000:.0f} ms, max "
              f"{per[worst] * 1000:.0f} ms ({worst})", flush=True)


if __name__ == "__main__":
    main()
