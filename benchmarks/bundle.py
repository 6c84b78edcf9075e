"""Seconds for the whole export bundle plus the MuJoCo battery on a golden program.

Usage: python benchmarks/bundle.py [golden/rover/program.py] [--repeat N]
Prints compile, bundle (per format) and battery (per check) times; cold caches each repeat.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("program", nargs="?", default="golden/rover/program.py")
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    from procedura_brep.export import meshes
    from procedura_brep.export.bundle import write_bundle
    from procedura_brep.program import compile_source
    from procedura_brep.sim import run_battery

    path = Path(args.program)
    t = time.perf_counter()
    model = compile_source(path.read_text(), name=path.parent.name)
    print(f"compile: {time.perf_counter() - t:.2f} s ({len(model.parts)} parts, {len(model.mates)} mates)")
    for k in range(args.repeat):
        meshes.clear_cache()
        with tempfile.TemporaryDirectory() as tmp:
            timings: dict[str, float] = {}
            t0 = time.perf_counter()
            write_bundle(model, tmp, timings=timings)
            t1 = time.perf_counter()
            (Path(tmp) / "program.py").write_text(path.read_text())
            report = run_battery(model, out_dir=tmp)
            t2 = time.perf_counter()
        print(f"run {k}: bundle {t1 - t0:.2f} s "
              f"({', '.join(f'{n} {v:.2f}' for n, v in timings.items())}); "
              f"battery {t2 - t1:.2f} s ({', '.join(f'{c.id} {c.seconds:.2f}' for c in report.checks)}); "
              f"total {t2 - t0:.2f} s; passed={report.passed}")


if __name__ == "__main__":
    main()
