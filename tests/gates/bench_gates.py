"""Benchmark: gate cost on an N-part model, cold and after adding one part (prints figures).

Run: ``python tests/gates/bench_gates.py [N]`` from the repo root.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from procedura_brep.gates import check_model, clear_caches
from procedura_brep.mates.fits import iso286
from procedura_brep.mates.placement import trans
from procedura_brep.program.model import CompiledMate, CompiledModel
from procedura_brep.testing.models import cpart


def grid_model(n: int) -> CompiledModel:
    """A plate with ``n`` pegged cylindrical posts (curved faces, one static mate each)."""
    from build123d import Align, Box, Cylinder

    d = 8.0
    f = iso286(d, "location")
    side = int(np.ceil(np.sqrt(n)))
    pitch = 40.0
    plate = Box(side * pitch, side * pitch, 20, align=(Align.MIN, Align.MIN, Align.MAX))
    top = (Align.CENTER, Align.CENTER, Align.MAX)
    for k in range(n):
        x, y = (k % side + 0.5) * pitch, (k // side + 0.5) * pitch
        plate -= Cylinder(f.hole / 2, d + 0.4, align=top).translate((x, y, 0))
    post = Cylinder(12, 30, align=(Align.CENTER, Align.CENTER, Align.MIN)) + Cylinder(f.shaft / 2, d, align=top)
    parts = [cpart("plate", plate)]
    mates = []
    for k in range(n):
        x, y = (k % side + 0.5) * pitch, (k // side + 0.5) * pitch
        parts.append(cpart(f"post_{k}", post, trans(x, y, 0)))
        mates.append(CompiledMate(name=f"m{k}", type="peg_socket", kind="static", child=f"post_{k}",
                                  child_frame="origin", parent="plate", parent_frame="origin",
                                  nominal_name="d", nominal=d, fit=f.as_dict(), options={}, dof={},
                                  world_frame=trans(x, y, 0)))
    return CompiledModel(name="grid", params={}, parts=parts, mates=mates)


def main(n: int = 40) -> None:
    model = grid_model(n)
    clear_caches()
    t = time.perf_counter()
    rep = check_model(model)
    cold = time.perf_counter() - t
    print(f"N={n} parts+1: cold check_model {cold:.2f} s  {rep.timings}")
    assert rep.passed, rep.feedback
    model.parts[-1].placement = trans(0, 0, 0.0) @ model.parts[-1].placement  # same digest
    t = time.perf_counter()
    check_model(model)
    print(f"warm (nothing changed) {time.perf_counter() - t:.3f} s")
    bigger = grid_model(n + 1)
    t = time.perf_counter()
    rep = check_model(bigger)
    print(f"warm after adding part {n + 1} (plate changed too: new socket) "
          f"{time.perf_counter() - t:.2f} s, n_vis={rep.as_dict()['n_vis']}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
