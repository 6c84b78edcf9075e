"""How the battery's exact sweep and rest scan grow with the parts (issue 24.4): synthetic rows
of hinges (a base plate, and per hinge a post seated on it with a flap swinging +-60 deg on a
revolute at its top, spaced so no flap reaches a neighbour), at 40 and 160 parts; prints per
size the seconds of B2 (MuJoCo sweeps and exact sweeps) and B3, the exact booleans, and
t160/t40. Linear would be 4.0 (the joints grow with the parts); pairs are pruned per joint.

Run: ``python benchmarks/battery_scale.py [--sizes 40,160]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="40,160")
    args = ap.parse_args()
    from procedura_brep.program import compile_source
    from procedura_brep.sim import run_battery
    from procedura_brep.testing.programs import hinge_row

    times = {}
    for n in (int(x) for x in args.sizes.split(",")):
        model = compile_source(hinge_row(n), name=f"hinges{n}")
        with tempfile.TemporaryDirectory() as tmp:
            t = time.perf_counter()
            rep = run_battery(model, out_dir=tmp, checks=["B2", "B3"], frames=False)
            wall = time.perf_counter() - t
        b2, b3 = rep.check("B2"), rep.check("B3")
        times[n] = (b2.seconds, b3.seconds, wall)
        print(f"{len(model.parts):4d} parts, {len(model.mates) // 2:3d} joints: B2 {b2.seconds:6.2f} s "
              f"({b2.measured.get('booleans')} booleans, {b2.status}), B3 {b3.seconds:5.2f} s "
              f"({b3.status}), battery call {wall:6.2f} s")
    sizes = sorted(times)
    if len(sizes) >= 2:
        a, b = sizes[0], sizes[-1]
        print(f"t{b}/t{a}: B2 {times[b][0] / times[a][0]:.2f}, B3 {times[b][1] / times[a][1]:.2f}, "
              f"battery call {times[b][2] / times[a][2]:.2f} (parts ratio {b / a:.1f})")


if __name__ == "__main__":
    main()
