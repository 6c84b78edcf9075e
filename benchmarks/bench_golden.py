"""Benchmark: warm-worker compile time of each golden program, per-part cache off.

Run: python benchmarks/bench_golden.py   (prints one line per program; no assertions)
"""

from __future__ import annotations

import time
from pathlib import Path

from procedura_brep.program.sandbox import CompileOptions, default_worker

ROOT = Path(__file__).resolve().parents[1] / "golden"


def main() -> None:
    worker = default_worker()
    for name in ("rover", "arm", "vise"):
        source = (ROOT / name / "program.py").read_text(encoding="utf-8")
        best = float("inf")
        for _ in range(3):
            t = time.perf_counter()
            model = worker.compile(source, CompileOptions(name=name, cache=False))
            best = min(best, time.perf_counter() - t)
        kinds = {}
        for m in model.mates:
            kinds[m.type] = kinds.get(m.type, 0) + 1
        print(f"{name}: {len(model.parts)} parts, {len(model.mates)} mates {kinds}, "
              f"warm compile (cache off) best of 3 = {best:.2f} s, findings = {len(model.findings)}")


if __name__ == "__main__":
    main()
