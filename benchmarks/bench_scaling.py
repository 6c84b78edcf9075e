"""Bench scale-out benchmark (issue 14): the CI-sized bench (3 cases x 2 variants over the
hand-written replay tapes in tests/bench/tapes/, real pipeline with the MuJoCo battery, replayed
judge) run fresh with --jobs 1, --jobs 2 and --ray (a local Ray instance with 2 CPUs; skipped
when Ray is not installed).

Prints, per mode: the bench's wall time (generation, judge and tables) and per run its wall
time, CPU seconds and peak resident memory of its process tree (what a case costs, for sizing
a cluster). The figures depend on the machine's load; each run prints them again.

Run: ``python benchmarks/bench_scaling.py [--modes jobs1,jobs2,ray] [--no-simulate] [--table]``.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TAPES = ROOT / "tests" / "bench" / "tapes"
PROMPTS = ROOT / "tests" / "bench" / "ci_prompts.toml"


def run(mode: str, out: Path, simulate: bool) -> tuple[float, list[dict], str]:
    from procedura_brep.bench import BenchOptions, run_bench
    opts = BenchOptions(model=f"replay:{TAPES}", prompts=PROMPTS, variants=("full", "one-shot"), salt="ci",
                        simulate=simulate, jobs=2 if mode == "jobs2" else 1, ray=mode == "ray")
    t0 = time.perf_counter()
    if mode == "ray":
        import ray
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            res = run_bench(out, opts)
        finally:
            ray.shutdown()
    else:
        res = run_bench(out, opts)
    return time.perf_counter() - t0, res.records, res.tables["summary.md"].read_text(encoding="utf-8")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--modes", default="jobs1,jobs2,ray")
    ap.add_argument("--no-simulate", action="store_true")
    ap.add_argument("--table", action="store_true", help="Also print each mode's summary table.")
    args = ap.parse_args()
    for mode in args.modes.split(","):
        if mode == "ray":
            try:
                import ray  # noqa: F401 - only checks that Ray is installed
            except ImportError:
                print("ray: not installed (pip install 'procedura-brep[ray]'); skipped")
                continue
        with tempfile.TemporaryDirectory() as tmp:
            wall, recs, table = run(mode, Path(tmp) / "b", not args.no_simulate)
        print(f"{mode}: bench wall {wall:.1f} s for {len(recs)} runs "
              f"(median run {statistics.median(r['wall_s'] for r in recs):.1f} s)")
        for r in recs:
            print(f"  {r['case']}/{r['variant']}: {r['status']}, wall {r['wall_s']:.1f} s, "
                  f"CPU {r['cpu_s']:.1f} s, peak {r['peak_rss_mb']:.0f} MB")
        if args.table:
            print(table)


if __name__ == "__main__":
    main()
