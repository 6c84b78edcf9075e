"""How the battery's exact sweep and rest scan grow with the parts (issue 24.4): synthetic rows
of hinges (a base plate, and per hinge a post seated on it with a flap swinging +-60 deg on a
revolute at its top, spaced so no flap reaches a neighbour), at 40 and 160 parts; prints per
size the seconds of B2 (MuJoCo sweeps and exact sweeps) and B3, the exact booleans, and
t160/t40. Linear would be 4.0 (the joints grow with the parts); pairs are pruned per joint.

With ``--before REV`` the same programs (written by this tree's generator) are run by that
revision's ``src/`` too, each tree in its own fresh process, trees taking turns per size, and
the ratios this/before are printed.

Run: ``python benchmarks/battery_scale.py [--sizes 40,160] [--before 34702fd]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def measure(program: Path, name: str) -> dict:
    """B2 and B3 of one program with the ``procedura_brep`` on the path (the worker's job)."""
    from procedura_brep.program import compile_source
    from procedura_brep.sim import run_battery
    model = compile_source(program.read_text(), name=name)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        rep = run_battery(model, out_dir=tmp, checks=["B2", "B3"], frames=False)
        wall = time.perf_counter() - t
    b2, b3 = rep.check("B2"), rep.check("B3")

    def status(c) -> str:  # an old tree's CheckResult may predate ``status``
        return getattr(c, "status", "pass" if c.passed else "fail")
    return {"parts": len(model.parts), "joints": len(model.mates) // 2, "b2": b2.seconds,
            "b3": b3.seconds, "wall": wall, "booleans": b2.measured.get("booleans"),
            "b2_status": status(b2), "b3_status": status(b3)}


def run_tree(program: Path, name: str, src: Path | None) -> dict:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src)
    proc = subprocess.run([sys.executable, __file__, "--worker", str(program), "--name", name],
                          capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        raise SystemExit(f"{name} with {src or 'this tree'} exited {proc.returncode}: "
                         f"{proc.stderr.strip()[-600:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="40,160")
    ap.add_argument("--before", default=None, metavar="REV")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--name", default="hinges", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(measure(Path(args.worker), args.name)))
        return
    from procedura_brep.testing.programs import hinge_row
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from build import export_tree  # the benchmarks folder is not a package

    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        tmp.chmod(0o755)  # the compile child may run unprivileged: it must read the old tree
        trees: list[tuple[str, Path | None]] = [("this tree", None)]
        if args.before:
            (tmp / "before").mkdir()
            trees.insert(0, (f"before ({args.before})", export_tree(args.before, tmp / "before")))
        times: dict[str, dict[int, dict]] = {label: {} for label, _ in trees}
        for n in (int(x) for x in args.sizes.split(",")):
            program = tmp / f"hinges{n}.py"
            program.write_text(hinge_row(n))
            program.chmod(0o644)
            for label, src in trees:
                r = times[label][n] = run_tree(program, f"hinges{n}", src)
                print(f"{label:22s} {r['parts']:4d} parts, {r['joints']:3d} joints: B2 {r['b2']:6.2f} s "
                      f"({r['booleans']} booleans, {r['b2_status']}), B3 {r['b3']:5.2f} s "
                      f"({r['b3_status']}), battery call {r['wall']:6.2f} s")
        sizes = sorted(next(iter(times.values())))
        if len(sizes) >= 2:
            a, b = sizes[0], sizes[-1]
            for label, _ in trees:
                t = times[label]
                print(f"{label:22s} t{b}/t{a}: B2 {t[b]['b2'] / t[a]['b2']:.2f}, "
                      f"B3 {t[b]['b3'] / t[a]['b3']:.2f}, battery call {t[b]['wall'] / t[a]['wall']:.2f} "
                      f"(parts ratio {b / a:.1f})")
        if len(trees) == 2:
            old, new = times[trees[0][0]], times["this tree"]
            for n in sizes:
                print(f"{n:4d} parts, ratio this/before: B2 {new[n]['b2'] / old[n]['b2']:.3f}, "
                      f"B3 {new[n]['b3'] / old[n]['b3']:.3f}, battery call "
                      f"{new[n]['wall'] / old[n]['wall']:.3f}")


if __name__ == "__main__":
    main()
