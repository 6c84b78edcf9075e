"""Benchmark: tessellation of the rover's parts (and the B-rep triangle estimate) and of the
three oversized parts of issue 10 (Sphere(1e5), Sphere(3000), Cylinder(1e6, 1)).

Run: python benchmarks/mesh.py   (prints figures; no assertions)
"""

from __future__ import annotations

import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "golden"


def main() -> None:
    import build123d as bd

    from procedura_brep import kernel
    from procedura_brep.program import compile_source
    from procedura_brep.program.sandbox import default_worker

    for label, shape in (("Sphere(1e5)", bd.Sphere(1e5)), ("Sphere(3000)", bd.Sphere(3000)),
                         ("Cylinder(1e6, 1)", bd.Cylinder(1e6, 1))):
        t = time.perf_counter()
        mesh = kernel.tessellate(shape.wrapped, name=label)
        print(f"{label}: deflection {kernel.mesh_deflection(shape.wrapped):.3g} mm, "
              f"{len(mesh.faces)} triangles, {time.perf_counter() - t:.2f} s")
    model = compile_source((ROOT / "rover" / "program.py").read_text(), name="rover",
                           worker=default_worker())
    shapes = [p.shape() for p in model.parts]
    t = time.perf_counter()
    n = sum(len(kernel.tessellate(s).faces) for s in shapes)
    print(f"rover, {len(shapes)} parts: {n} triangles, tessellate {time.perf_counter() - t:.2f} s")
    t = time.perf_counter()
    est = sum(kernel.estimate_triangles(s, linear=kernel.mesh_deflection(s)) for s in shapes)
    print(f"rover: B-rep estimate {est} triangles, {time.perf_counter() - t:.2f} s")


if __name__ == "__main__":
    main()
