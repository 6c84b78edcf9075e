"""Incremental build benchmark (README, Performance; issue 3 item 7, issue 12 item 3).

Generates synthetic programs of 10, 40 and 160 parts (``procedura_brep.testing.programs.tower``:
filleted, bored blocks, each seated on the one below by a peg_socket and turned 15 deg, so no
two parts overlap), and measures in one warm worker:

  cold:   compile + gates of the whole program with an empty part cache and empty gate caches;
  add:    compile + gates after appending one more part to the already-built program;
  splice: the staged agent's step: splice the five-block reply of part k+1 into the built
          program of k parts (part cache and gate caches warm for those k, and the heap
          settled as the agent's commit of part k leaves it: ``run.settle``), compile, gates;
  cold+1: compile + gates of all k+1 parts from empty caches (what the splice is compared with).

Prints the figures and the ratios add/cold and splice/cold+1 per size, and t160/t40 for the
cold builds. Targets: add/cold <= 0.15 at 40 parts; splice/cold+1 <= 0.10 at 40 parts;
t160/t40 <= 4.5. Run: ``python benchmarks/incremental.py [--repeat 3] [--sizes 10,40,160]``.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import statistics
import tempfile
import time
from collections.abc import Iterator


def program(n: int) -> str:
    """The synthetic tower of ``n`` blocks (``procedura_brep.testing.programs.tower``)."""
    from procedura_brep.testing.programs import tower
    return tower(n)


def compile_and_gate(worker, src: str) -> float:
    from procedura_brep.gates import check_model
    from procedura_brep.program.sandbox import CompileOptions
    t = time.perf_counter()
    model = worker.compile(src, CompileOptions(name="bench"))
    assert model.ok, model.findings[:3]
    check_model(model, src)
    return time.perf_counter() - t


def splice_and_gate(worker, src: str, reply: str) -> float:
    """Splice ``reply`` into ``src``, compile, gate (the new part's step in a staged build)."""
    from procedura_brep.gates import check_model
    from procedura_brep.program.sandbox import CompileOptions
    from procedura_brep.program.splice import splice
    t = time.perf_counter()
    new = splice(src, reply).source
    model = worker.compile(new, CompileOptions(name="bench"))
    assert model.ok, model.findings[:3]
    check_model(model, new, baseline=0)
    return time.perf_counter() - t


@contextlib.contextmanager
def booted_worker() -> Iterator[object]:
    """A worker with its own empty part cache, booted (import cost is not the build's) and
    with the parent's caches cleared (the gates' and the model's tessellations and read-back
    shapes: a cold build tessellates every part); closed afterwards."""
    from procedura_brep.gates import clear_caches
    from procedura_brep.program.model import clear_mesh_cache
    from procedura_brep.program.sandbox import Worker
    with tempfile.TemporaryDirectory() as cache:
        w = Worker(cache_dir=cache)
        try:
            w.compile(program(2))
            clear_caches()
            clear_mesh_cache()
            yield w
        finally:
            w.close()


def measure(n: int, repeat: int) -> dict[str, float]:
    """Median seconds of cold, add, splice and cold+1 at ``n`` parts."""
    from procedura_brep.run import settle
    from procedura_brep.testing.programs import tower_reply
    runs: dict[str, list[float]] = {"cold": [], "add": [], "splice": [], "cold1": []}
    for _ in range(repeat):
        with booted_worker() as w:
            runs["cold"].append(compile_and_gate(w, program(n)))
            runs["add"].append(compile_and_gate(w, program(n + 1)))
        with booted_worker() as w:
            runs["cold1"].append(compile_and_gate(w, program(n + 1)))
        with booted_worker() as w:
            compile_and_gate(w, program(n))  # the k parts built: warm part and gate caches
            settle()  # what the agent's commit of part k does
            runs["splice"].append(splice_and_gate(w, program(n), tower_reply(n)))
            gc.unfreeze()  # the next measurements start from an unfrozen heap
    return {k: statistics.median(v) for k, v in runs.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--sizes", default="10,40,160")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    cold: dict[int, float] = {}
    ratio: dict[int, float] = {}
    spliced: dict[int, float] = {}
    print(f"{'parts':>6} {'cold s':>9} {'add-one s':>10} {'ratio':>7} {'cold k+1 s':>11} "
          f"{'splice k+1 s':>13} {'ratio':>7}")
    for n in sizes:
        t = measure(n, args.repeat)
        cold[n], ratio[n], spliced[n] = t["cold"], t["add"] / t["cold"], t["splice"] / t["cold1"]
        print(f"{n:>6} {t['cold']:>9.2f} {t['add']:>10.2f} {ratio[n]:>7.3f} {t['cold1']:>11.2f} "
              f"{t['splice']:>13.3f} {spliced[n]:>7.3f}", flush=True)
    for n in sizes:
        print(f"splice part k+1 into k = {n} parts: ratio(splice/cold k+1) = {spliced[n]:.3f}"
              + (" (target <= 0.10)" if n == 40 else ""))
    if 40 in cold:
        print(f"ratio(add/cold) at 40 parts = {ratio[40]:.3f} (target <= 0.15)")
    if 40 in cold and 160 in cold:
        print(f"t160/t40 = {cold[160] / cold[40]:.2f} (target <= 4.5)")


if __name__ == "__main__":
    main()
