"""Ctrl-C latency: seconds from SIGINT (to the process group, as a terminal sends it) to the exit
of a real ``procedura-brep build golden/rover/program.py``, at each stage; prints one line each.

Run: ``python benchmarks/interrupt.py [--repeat N]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_interrupt import ROVER, interrupt_build  # noqa: E402 - after the sys.path line above

POINTS = (("compiling", 0.05, "CLI imports"), ("compiling", 3.0, "worker compile"),
          ("writing", 0.05, "exports"), ("running the gates", 0.05, "gates"))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    for when, delay, label in POINTS:
        times, codes, left, status = [], set(), 0, set()
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory() as tmp:
                out = Path(tmp) / "run"
                code, dt, _err, pids = interrupt_build(ROVER, out, when=when, delay_s=delay)
                times.append(dt)
                codes.add(code)
                left += len(pids)
                status.add(json.loads((out / "report.json").read_text())["status"])
        print(f"{label:15s} stop after {statistics.median(times):.2f} s median "
              f"(max {max(times):.2f} s, {args.repeat} run(s)); exit {sorted(codes)}; "
              f"report {sorted(status)}; processes left {left}")


if __name__ == "__main__":
    main()
