"""The MuJoCo battery's wall time where users wait: `procedura-brep simulate` of golden/rover and
of the sliding-contact linear axis (tests/sim/slide.py: four bearing blocks touching two rails
over 760 mm, without and with a stop block in their path), each a cold CLI call in a fresh
process, this tree against ``--before REV`` run by run (the trees take turns, so a ratio is
measured in one run under the same load).

Prints per case and tree: the median wall seconds of the whole `simulate` call, B2's own
seconds and exact booleans, B2's verdict and its message head.

Usage: ``python benchmarks/battery.py [--before 34702fd] [--runs 3] [--only rover,slide,stop]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from build import ROOT, export_tree  # noqa: E402  the benchmarks folder is not a package


def cases(tmp: Path) -> dict[str, Path]:
    sys.path.insert(0, str(ROOT))
    from tests.sim.slide import program
    # the rover with its chassis weighed as a solid (no hollow=, which trees before issue 26.5
    # cannot compile): the sweeps and checks see the same geometry
    rover = tmp / "rover.py"
    rover.write_text((ROOT / "golden" / "rover" / "program.py").read_text().replace(
        "hollow=body_wall,", ""))
    out = {"rover": rover}
    for name, stop in (("slide", False), ("stop", True)):
        p = tmp / f"{name}.py"
        p.write_text(program(stop))
        out[name] = p
    return out


def simulate(path: Path, src: Path | None) -> dict:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src)
    cmd = [sys.executable, "-m", "procedura_brep.cli", "simulate", str(path), "--json", "-q"]
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t
    if proc.returncode not in (0, 1):
        raise SystemExit(f"simulate {path} with {src or 'this tree'} exited {proc.returncode}: "
                         f"{proc.stderr.strip()[-400:]}")
    report = json.loads(proc.stdout)
    b2 = next(c for c in report["checks"] if c["id"] == "B2")
    return {"wall": wall, "b2": b2["seconds"], "booleans": b2["measured"].get("booleans", 0),
            "passed": b2["passed"], "message": b2["message"][:110]}


def main() -> None:
    ap = argparse.ArgumentParser(description="simulate wall time, before/after")
    ap.add_argument("--before", default=None, metavar="REV")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", default="rover,slide,stop")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        tmp.chmod(0o755)  # the compile child may run unprivileged: it must read the old tree
        todo = {k: v for k, v in cases(tmp).items() if k in args.only.split(",")}
        trees: list[tuple[str, Path | None]] = [("this tree", None)]
        if args.before:
            (tmp / "before").mkdir()
            trees.insert(0, (f"before ({args.before})", export_tree(args.before, tmp / "before")))
        rows: dict[tuple[str, str], list[dict]] = {}
        for _ in range(args.runs):
            for case, path in todo.items():
                for label, src in trees:
                    rows.setdefault((case, label), []).append(simulate(path, src))
        for case in todo:
            walls = {}
            for label, _ in trees:
                r = rows[(case, label)]
                walls[label] = statistics.median(x["wall"] for x in r)
                last = r[-1]
                print(f"{case:6s} {label:22s} simulate {walls[label]:6.2f} s (median of {len(r)}), "
                      f"B2 {statistics.median(x['b2'] for x in r):6.2f} s, "
                      f"{last['booleans']} booleans, B2 {'pass' if last['passed'] else 'FAIL'}: "
                      f"{last['message']}")
            if len(trees) == 2:
                print(f"{case:6s} ratio this/before: {walls['this tree'] / walls[trees[0][0]]:.3f}")


if __name__ == "__main__":
    main()
