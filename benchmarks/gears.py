"""Measure the two gear libraries the program's gear helpers may build on (issue 27, item 2).

For bd_warehouse 0.4.0 and py_gearworks 0.0.24: build time of a spur gear (m = 1.5, w = 10,
z = 20 and z = 60), an internal ring gear (z = 60) and a rack (20 teeth); solid validity
(BRepCheck), face count, solid count, volume against the pitch-disc estimate pi r_p^2 w (a ring:
the annulus from the pitch circle to the rim; a rack: pitch line to back face), and whether the
result survives a boolean (a 10 mm bore through the centre, a hole through the ring's rim, the
rack's end cut off) as one valid solid. Then a lead screw (d 12, lead 3, 60 long, core and
thread fused into one solid): bd_warehouse's ``Thread`` against the helper's one helical sweep
(``procedura_brep.program.gearing.lead_screw``).

    python benchmarks/gears.py

Prints one row per case; nothing is asserted (tests/program/test_gearing.py holds the checks).
bd_warehouse is not a dependency (the helpers use py_gearworks and their own thread sweep): its
rows need ``pip install bd_warehouse==0.4.0`` and are skipped without it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

M, W = 1.5, 10.0


def _row(lib: str, case: str, build: Callable[[], Any], estimate: float, cut: Any) -> None:
    from OCP.BRepCheck import BRepCheck_Analyzer

    t0 = time.perf_counter()
    try:
        shape = build()
    except Exception as exc:  # a library that cannot build the case: say so, keep going
        print(f"{lib:13s} {case:22s} FAILED: {type(exc).__name__}: {str(exc)[:80]}")
        return
    dt = time.perf_counter() - t0
    solids = shape.solids()
    valid = BRepCheck_Analyzer(shape.wrapped).IsValid()
    t1 = time.perf_counter()
    try:
        after = shape - cut
        cut_ok = len(after.solids()) == 1 and BRepCheck_Analyzer(after.wrapped).IsValid()
    except Exception:
        cut_ok = False
    dc = time.perf_counter() - t1
    print(f"{lib:13s} {case:22s} {dt * 1000:8.0f} ms  valid={valid!s:5s} solids={len(solids)} "
          f"faces={len(shape.faces()):4d}  V/V_pitch={shape.volume / estimate:5.3f}  "
          f"boolean ok={cut_ok!s:5s} ({dc * 1000:.0f} ms)")


def main() -> None:
    import build123d as bd
    import py_gearworks as pgw
    try:
        from bd_warehouse.gear import RackGear
        from bd_warehouse.gear import SpurGear as BdSpur
    except ImportError:
        print("bd_warehouse is not installed: its rows are skipped")

        def BdSpur(*a: Any) -> Any:  # noqa: N802 - stands in for the class
            raise ImportError("bd_warehouse is not installed")
        RackGear = BdSpur

    bore = bd.Cylinder(5, 3 * W)

    def disc(z: int) -> float:
        return math.pi * (M * z / 2) ** 2 * W

    for z in (20, 60):
        _row("bd_warehouse", f"spur z={z}", lambda z=z: BdSpur(M, z, 20, W), disc(z), bore)
        _row("py_gearworks", f"spur z={z}",
             lambda z=z: pgw.SpurGear(number_of_teeth=z, module=M, height=W).build_part(),
             disc(z), bore)
    rim = M * 60 / 2 + 2.5 * M
    ring_est = math.pi * (rim ** 2 - (M * 60 / 2) ** 2) * W
    ring_cut = bd.Pos(rim, 0, 0) * bd.Cylinder(2, 3 * W)
    _row("py_gearworks", "ring z=60",
         lambda: pgw.SpurRingGear(number_of_teeth=60, module=M, height=W).build_part(),
         ring_est, ring_cut)
    print(f"{'bd_warehouse':13s} {'ring z=60':22s} none: bd_warehouse 0.4.0 has no internal gear")
    length = 20 * math.pi * M
    rack_est = length * W * 3.25 * M  # pitch line to the base: dedendum 1.25 m + base 2 m
    # bd_warehouse: the rack runs along X; py_gearworks: along Y. Cut 10 mm off its far end.
    _row("bd_warehouse", "rack 20 teeth", lambda: RackGear(M, 20, 20, W), rack_est,
         bd.Pos(length / 2, 0, 0) * bd.Box(20, 50, 50))
    _row("py_gearworks", "rack 20 teeth",
         lambda: pgw.InvoluteRack(number_of_teeth=20, module=M, height=W).build_part(),
         rack_est, bd.Pos(0, length / 2, 0) * bd.Box(50, 20, 50))
    _threads(bd)


def _threads(bd: Any) -> None:
    from procedura_brep.program.gearing import lead_screw

    d, lead, n = 12.0, 3.0, 60.0
    est = math.pi * (d / 2 - lead / 4) ** 2 * n  # the cylinder of the mean flank diameter
    z0 = (bd.Align.CENTER, bd.Align.CENTER, bd.Align.MIN)

    def warehouse() -> Any:
        from bd_warehouse.thread import Thread

        thread = Thread(apex_radius=d / 2, apex_width=0.366 * lead, root_radius=d / 2 - lead / 2,
                        root_width=0.634 * lead, pitch=lead, length=n)
        return bd.Cylinder(d / 2 - lead / 2, n, align=z0) + thread

    hole = bd.Cylinder(2, 3 * n, align=z0)
    _row("bd_warehouse", "lead screw 20 turns", warehouse, est, hole)
    _row("helper sweep", "lead screw 20 turns", lambda: lead_screw(d, lead, n), est, hole)


if __name__ == "__main__":
    main()
