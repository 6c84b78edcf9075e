"""Incremental build benchmark (DESIGN.md section 10; issue 3 item 7).

Generates synthetic programs of 10, 40 and 160 parts (a tower of filleted, bored blocks, each
seated on the one below by a peg_socket and turned 15 deg, so no two parts overlap), and
measures in one warm worker:

  cold: compile + gates of the whole program with an empty part cache and empty gate caches;
  add:  compile + gates after appending one more part to the already-built program.

Prints both, their ratio per size, and t160/t40 for the cold builds. Targets: add/cold <= 0.15
at 40 parts; t160/t40 <= 4.5. Run: ``python benchmarks/incremental.py [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time

HEAD = '''"""Synthetic benchmark program with {n} parts (generated)."""
from procedura_brep.program import *

# === params ===
block_w = 40.0  # mm
block_h = 12.0  # mm
peg_d = 8.0  # mm
bore_d = 10.0  # mm

# === helpers ===
def block(k):
    b = Box(block_w, block_w, block_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    b = fillet(b.edges().filter_by(Axis.Z), radius=3)
    return b - Pos(block_w / 4, 0, 0) * Cylinder(bore_d / 2 + 0.01 * (k % 5), block_h * 3)

# === parts ===
'''


def program(n: int) -> str:
    parts, frames, mates = [], [], []
    for i in range(n):
        parts.append(f'@part(detail="major", material="aluminium", description="block {i}")\n'
                     f"def p{i}():\n    return block({i})\n")
        # each block sits on the top face of the one before, turned 15 deg about Z
        frames.append(f'frames("p{i}", foot=Location((0, 0, 0)), '
                      f'top=Location((-8, 8, block_h), (0, 0, 15)))')
        if i:
            mates.append(f'mate("p{i}.foot", "p{i - 1}.top", "peg_socket", nominal="peg_d", '
                         f'fit="clearance", depth=5)')
    return (HEAD.format(n=n) + "\n".join(parts) + "\n# === frames ===\n" + "\n".join(frames)
            + "\n\n# === assembly ===\n" + "\n".join(mates) + "\n")


def compile_and_gate(worker, src: str) -> float:
    from procedura_brep.gates import check_model
    from procedura_brep.program.sandbox import CompileOptions
    t = time.perf_counter()
    model = worker.compile(src, CompileOptions(name="bench"))
    assert model.ok, model.findings[:3]
    check_model(model, src)
    return time.perf_counter() - t


def measure(n: int, repeat: int) -> tuple[float, float]:
    from procedura_brep.gates import clear_caches
    from procedura_brep.program.sandbox import Worker
    colds, adds = [], []
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as cache:
            w = Worker(cache_dir=cache)
            try:
                w.compile(program(2))  # boot the worker (import cost is not the build's)
                clear_caches()
                colds.append(compile_and_gate(w, program(n)))
                adds.append(compile_and_gate(w, program(n + 1)))
            finally:
                w.close()
    return statistics.median(colds), statistics.median(adds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--sizes", default="10,40,160")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    cold: dict[int, float] = {}
    ratio: dict[int, float] = {}
    print(f"{'parts':>6} {'cold s':>9} {'add-one s':>10} {'ratio':>7}")
    for n in sizes:
        c, a = measure(n, args.repeat)
        cold[n], ratio[n] = c, a / c
        print(f"{n:>6} {c:>9.2f} {a:>10.2f} {a / c:>7.3f}", flush=True)
    if 40 in cold and 160 in cold:
        print(f"ratio(add/cold) at 40 parts = {ratio[40]:.3f} (target <= 0.15); "
              f"t160/t40 = {cold[160] / cold[40]:.2f} (target <= 4.5)")


if __name__ == "__main__":
    main()
