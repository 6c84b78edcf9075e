"""Benchmark: seconds for a 12-view contact sheet of golden/rover at 512 px (parts mode).

Usage: ``python benchmarks/render.py [--size 512] [--mode parts] [--parts 40]``

Uses golden/rover/program.py compiled by ``procedura_brep.program.compile_source`` when it
exists; otherwise a synthetic many-part model (a chassis with cylinders and boxes), and says
which. Prints the cold time (tessellation + GL), the warm time (meshes cached, images redrawn)
and the cached time (every image reused from the manifest).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def synthetic(n_parts: int):
    """A rover-like model: a chassis plate, wheels on both sides, boxes and masts on top."""
    from build123d import Box, Cylinder, Rotation

    from procedura_brep import kernel
    from procedura_brep.program.model import CompiledModel, CompiledPart

    def tr(x: float, y: float, z: float) -> np.ndarray:
        m = np.eye(4)
        m[:3, 3] = (x, y, z)
        return m

    wheel = kernel.write_brep((Rotation(90, 0, 0) * Cylinder(60, 40)).wrapped)
    parts = [CompiledPart("chassis", kernel.write_brep(Box(600, 300, 40).wrapped), tr(0, 0, 100),
                          material="painted_aluminium")]
    k = 0
    while len(parts) < n_parts:
        i = len(parts)
        if k < 6:
            x, side = -250 + 250 * (k % 3), (-1 if k < 3 else 1)
            parts.append(CompiledPart(f"wheel_{k}", wheel, tr(x, side * 190, 60), material="rubber"))
        else:
            a = 2 * math.pi * (i / max(n_parts, 1))
            shape = Cylinder(10 + i % 7, 40 + 5 * (i % 9)) if i % 2 else Box(30 + i % 5 * 6, 24, 18 + i % 4 * 5)
            parts.append(CompiledPart(f"module_{i}", kernel.write_brep(shape.wrapped),
                                      tr(220 * math.cos(a), 110 * math.sin(a), 150 + 10 * (i % 5)),
                                      material="brushed_steel" if i % 3 else "gold_foil"))
        k += 1
    return CompiledModel("synthetic_rover", {}, parts, [])


def load(n_parts: int):
    prog = ROOT / "golden" / "rover" / "program.py"
    if prog.is_file():
        from procedura_brep.program import compile_source
        t = time.perf_counter()
        model = compile_source(prog.read_text(), name="rover")
        print(f"model: golden/rover ({len(model.parts)} parts, compiled in {time.perf_counter() - t:.1f} s)")
        return model
    model = synthetic(n_parts)
    print(f"model: SYNTHETIC ({len(model.parts)} parts; golden/rover/program.py not present yet)")
    return model


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--mode", default="parts", choices=["parts", "clay", "pbr"])
    ap.add_argument("--parts", type=int, default=40, help="parts in the synthetic fallback")
    a = ap.parse_args()
    from procedura_brep.render import DEFAULT_VIEWS, render_to_dir
    from procedura_brep.render.gl import renderer

    model = load(a.parts)
    t = time.perf_counter()
    info = renderer().info
    print(f"GL: {info.get('GL_RENDERER')} (context {time.perf_counter() - t:.2f} s)")
    views = list(DEFAULT_VIEWS)
    with tempfile.TemporaryDirectory() as d1, tempfile.TemporaryDirectory() as d2:
        cold = render_to_dir(model, d1, views=views, mode=a.mode, size=a.size, sheet=True)
        warm = render_to_dir(model, d2, views=views, mode=a.mode, size=a.size, sheet=True)
        cached = render_to_dir(model, d2, views=views, mode=a.mode, size=a.size, sheet=True)
    print(f"12-view sheet, {a.size} px, mode={a.mode}: cold {cold.seconds:.2f} s "
          f"(tessellation + render), warm {warm.seconds:.2f} s (meshes cached, "
          f"{warm.seconds / len(views) * 1000:.0f} ms/view incl. sheet), cached {cached.seconds:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
