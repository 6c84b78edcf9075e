"""Gate benchmark (issues 11.1 and 10.1): prints its figures, asserts nothing.

1. golden/rover: the whole gate (``check_model``: mate, pieces, interference, connectivity,
   metrics; caches cleared) and each gate's share, against a cold ``procedura-brep build`` of the
   same program (process start to exit, every export), as a ratio.
2. One part of n separate 1 mm boxes in a row (``Pos(0, 2 i, 0) * Box(1, 1, 1)``): connectivity
   and pieces time for n = 1000, 3000, 10000 (near-linear: was 82 s at 3000, quadratic).
3. Two parts of n thin plates each, crossed, seated with ``features=False``: the mate gate's time
   for n = 25, 50, 100 (the exact common is skipped over ``TOL.boolean_face_budget`` and a mesh
   estimate used: was 3.4 s / 21 s / 441 s), and the exact common's own time at n = 25 for
   reference (``--exact``).

Run: ``python benchmarks/gates.py [--runs 1] [--skip-build] [--exact]``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def cold_build(runs: int) -> float:
    times = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as out:
            cmd = [sys.executable, "-m", "procedura_brep.cli", "build",
                   str(ROOT / "golden" / "rover" / "program.py"), "-o", out]
            t = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
            times.append(time.perf_counter() - t)
            if proc.returncode != 0:
                raise SystemExit(f"build failed: {proc.stderr.strip() or proc.stdout.strip()}")
    return float(np.median(times))


def rover_gates(runs: int) -> dict[str, float]:
    from procedura_brep.gates import check_model, clear_caches
    from procedura_brep.program import compile_source
    from procedura_brep.program.model import clear_mesh_cache

    src = (ROOT / "golden" / "rover" / "program.py").read_text()
    model = compile_source(src, name="rover")
    rows = []
    for _ in range(runs):
        clear_caches()
        clear_mesh_cache()
        for p in model.parts:  # a fresh shape too: nothing measured before is reused
            p._shape = None
        report = check_model(model, src)
        assert report.passed, report.feedback
        rows.append(report.timings)
    return {k: float(np.median([r[k] for r in rows])) for k in rows[0]}


def boxes(n: int) -> tuple[float, float]:
    from build123d import Box, Compound, Pos

    from procedura_brep import kernel
    from procedura_brep.gates.connectivity import analyse
    from procedura_brep.gates.geometry import clear_caches
    from procedura_brep.gates.pieces import pieces_gate
    from procedura_brep.program.model import CompiledModel, CompiledPart

    shape = Compound([Pos(0, 2 * i, 0) * Box(1, 1, 1) for i in range(n)])
    part = CompiledPart("row", kernel.write_brep(shape.wrapped), np.eye(4), {"origin": np.eye(4)})
    model = CompiledModel("boxes", {}, [part], [])
    clear_caches()
    part.mesh()  # tessellation is the exports' too; time the gates' own work
    t = time.perf_counter()
    conn = analyse(model)
    t_conn = time.perf_counter() - t
    assert len(conn.components) == n
    t = time.perf_counter()
    findings, _ = pieces_gate(model)
    t_pieces = time.perf_counter() - t
    assert findings
    return t_conn, t_pieces


def plates_model(n: int):
    from build123d import Align, Box, Compound, Pos

    from procedura_brep import kernel
    from procedura_brep.mates.fits import iso286
    from procedura_brep.program.model import CompiledMate, CompiledModel, CompiledPart

    pitch, t, L = 4.0, 1.0, n * 4.0 + 10
    a = Compound([Pos(0, pitch * i, 0) * Box(L, t, 20, align=(Align.MIN, Align.CENTER, Align.MAX))
                  for i in range(n)])
    b = Compound([Pos(pitch * i + 2, -5, 0) * Box(t, L, 20, align=(Align.CENTER, Align.MIN, Align.MAX))
                  for i in range(n)])
    parts = [CompiledPart("rack", kernel.write_brep(a.wrapped), np.eye(4), {"top": np.eye(4)}),
             CompiledPart("comb", kernel.write_brep(b.wrapped), np.eye(4), {"foot": np.eye(4)})]
    mate = CompiledMate("comb_foot", "seat_face", "static", "comb", "foot", "rack", "top", "d",
                        10.0, iso286(10.0, "location").as_dict(), {"features": False}, {},
                        np.eye(4))
    return CompiledModel("plates", {"d": 10.0}, parts, [mate])


def plates(n: int) -> tuple[float, int, bool]:
    from procedura_brep.gates.geometry import clear_caches
    from procedura_brep.gates.mate_gate import mate_gate

    model = plates_model(n)
    clear_caches()
    for p in model.parts:
        p.mesh()
    t = time.perf_counter()
    findings, res = mate_gate(model)
    dt = time.perf_counter() - t
    m = res.measured["comb_foot"]
    return dt, len(findings), bool(m["exact"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--skip-build", action="store_true", help="no cold build (no ratio)")
    ap.add_argument("--exact", action="store_true", help="also time the exact common at n = 25")
    args = ap.parse_args()
    from procedura_brep.config import TOL

    g = rover_gates(args.runs)
    print("golden/rover gates (cold caches), seconds:")
    for k in ("mate", "pieces", "interference", "connectivity", "metrics", "total"):
        print(f"  {k:<13} {g[k]:7.3f}")
    if not args.skip_build:
        b = cold_build(args.runs)
        print(f"cold build of golden/rover: {b:.2f} s")
        print(f"  whole gate / cold build        = {g['total'] / b:.3f}")
        print(f"  interference + pieces / build  = {(g['interference'] + g['pieces']) / b:.3f}")
    print("one part of n separate 1 mm boxes: connectivity s, pieces s")
    for n in (1000, 3000, 10000):
        c, p = boxes(n)
        print(f"  n = {n:>5}: {c:7.3f} {p:7.3f}")
    print(f"crossed plates, features=False, mate gate s (face budget {TOL.boolean_face_budget}):")
    for n in (25, 50, 100):
        dt, nf, exact = plates(n)
        print(f"  n = {n:>3}: {dt:7.3f}  ({'exact' if exact else 'mesh estimate'}, {nf} findings)")
    if args.exact:
        from procedura_brep.gates.common import exact_common
        model = plates_model(25)
        t = time.perf_counter()
        exact_common(model.parts[1].shape(), model.parts[0].shape())
        print(f"  exact common at n = 25 (what the budget skips): {time.perf_counter() - t:.2f} s")


if __name__ == "__main__":
    main()
