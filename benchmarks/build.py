"""Build benchmark (issue 2 item 9, issue 12 items 1 and 10).

For each golden program: the cold ``procedura-brep build`` time, measured from process start to
exit (imports and worker start included, every export written), where that time goes by stage
(from report.json's timings: ``imports`` is the wall time before ``build`` starts, i.e. process
start, imports and argument parsing; then compile (worker start and warm-up included), gates,
each export (``export`` is their sum, ``articulate`` the shared tree and masses), evidence,
battery; ``total`` is ``build`` itself), and
the per-part compile time in a warm worker (median over runs; each run compiles the whole
program with the part cache off, and a part's time is its function plus its features).

``--before REV`` also builds with the package as it was at git revision REV (exported to a
temporary folder), the same way, and prints both: the before/after figure of a change. The two
trees take turns run by run, after one untimed build each; the builds run with bytecode caching
on (``PYTHONDONTWRITEBYTECODE`` dropped from their environment), as an installed package has it.

``--warm`` also starts ``procedura-brep serve`` (the warm server, on a private socket) and builds
through it from the same fresh processes, taking turns with the cold builds: each such build
runs in a fork of the server (src/procedura_brep/served.py), everything imported; its first run
compiles the program in the server's worker, later runs find its parts in the server's cache
(what a ``check`` or ``render`` right after a ``build`` sees). The cold builds never use it.

Run: ``python benchmarks/build.py [--runs 3] [--formats step] [--simulate] [--only rover]
[--before HEAD~1] [--warm] [--no-parts]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ("rover", "arm", "vise")
#: Stages printed in this order (report.json timing keys); any other ``*_s`` key follows.
STAGES = ("compile_s", "gates_s", "export_articulate_s", "export_step_s", "export_obj_s",
          "export_glb_s", "export_usd_s", "export_urdf_s", "export_mjcf_s", "export_s",
          "evidence_s", "battery_s", "total_s")


def cold_build(name: str, formats: str | None, *, simulate: bool = False,
               src: Path | None = None, socket: Path | None = None) -> dict[str, float]:
    """One cold build in a fresh process: ``{"wall_s", "imports_s", <report timings>}``."""
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-m", "procedura_brep", "build", str(ROOT / "golden" / name / "program.py"),
               "-o", out, "-q"]
        if formats:
            cmd += ["--formats", formats]
        if simulate:
            cmd += ["--simulate"]
        # bytecode caching on, as an installed package has it (a shell that sets
        # PYTHONDONTWRITEBYTECODE would recompile the whole package on every run)
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        env["PROCEDURA_BREP_SERVER"] = "off"
        if src is not None:
            env["PYTHONPATH"] = str(src)
        if socket is not None:  # through the warm server
            env.pop("PROCEDURA_BREP_SERVER")
            env["PROCEDURA_BREP_SOCKET"] = str(socket)
        t = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
        dt = time.perf_counter() - t
        if proc.returncode != 0:
            raise SystemExit(f"build of {name} with {src or 'this tree'} failed: "
                             f"{proc.stderr.strip() or proc.stdout.strip()}")
        timings = json.loads((Path(out) / "report.json").read_text())["timings"]
    row = {k: float(v) for k, v in timings.items() if k.endswith("_s")}
    row["wall_s"] = dt
    row["imports_s"] = dt - row.get("total_s", 0.0)  # process start to build(): imports, parsing
    return row


def stage_line(rows: list[dict[str, float]]) -> str:
    """Median per stage over ``rows``, in pipeline order."""
    keys = ["imports_s", *[k for k in STAGES if any(k in r for r in rows)],
            *sorted({k for r in rows for k in r} - set(STAGES) - {"imports_s", "wall_s"})]
    return ", ".join(f"{k[:-2]} {statistics.median(r.get(k, 0.0) for r in rows):.2f}" for k in keys)


def export_tree(rev: str, into: Path) -> Path:
    """The ``src/`` of git revision ``rev`` under ``into`` (made world-readable: the sandbox's
    compile child may run as an unprivileged user, and a tree it cannot read would make it
    import another copy of the package)."""
    into.chmod(0o755)
    tar = into / "tree.tar"
    with open(tar, "wb") as fh:
        subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src"], stdout=fh, check=True)
    with tarfile.open(tar) as tf:
        tf.extractall(into, filter="data")
    return into / "src"


def part_times(name: str, runs: int) -> dict[str, float]:
    from procedura_brep.program.sandbox import CompileOptions, default_worker
    src = (ROOT / "golden" / name / "program.py").read_text()
    w = default_worker()
    per: dict[str, list[float]] = {}
    for _ in range(runs):
        m = w.compile(src, CompileOptions(name=name, cache=False))
        mates = {mm.name: (mm.child, mm.parent) for mm in m.mates}
        for p in m.parts:
            t = m.timings.get(f"part:{p.name}", 0.0)
            t += sum(v for k, v in m.timings.items() if k.startswith("mate:")
                     and p.name in mates.get(k[5:], ()))
            per.setdefault(p.name, []).append(t)
    return {k: statistics.median(v) for k, v in per.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description="cold build by stage, before/after, and warm per-part compile times")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--formats", default=None, help="exports for the cold build (default: all)")
    ap.add_argument("--simulate", action="store_true", help="cold build with the MuJoCo battery")
    ap.add_argument("--only", default=None, help="one golden (default: all three)")
    ap.add_argument("--before", default=None, metavar="REV", help="also build with src/ at git REV")
    ap.add_argument("--no-parts", action="store_true", help="skip the warm per-part compile times")
    ap.add_argument("--warm", action="store_true", help="also build through `procedura-brep serve`")
    args = ap.parse_args()
    names = (args.only,) if args.only else GOLDEN
    with tempfile.TemporaryDirectory() as tmp:
        trees: list[tuple[str, Path | None, Path | None]] = [("after", ROOT / "src", None)]
        if args.before:
            trees.insert(0, (f"before ({args.before})", export_tree(args.before, Path(tmp)), None))
        server = None
        if args.warm:
            sock = Path(tmp) / "srv" / "w.sock"
            server = start_server(sock)
            trees.append(("after, warm server", ROOT / "src", sock))
        for name in names:
            if not (ROOT / "golden" / name / "program.py").exists():
                print(f"{name}: missing")
                continue
            what = f"formats {args.formats or 'all'}{', battery' if args.simulate else ''}"
            rows_of: dict[str, list[dict[str, float]]] = {label: [] for label, _, _ in trees}
            for _, src, sock in trees:  # untimed: bytecode written, files in the page cache
                if sock is None:
                    cold_build(name, args.formats, simulate=args.simulate, src=src)
            for _ in range(args.runs):  # the trees take turns, so drift in the machine hits both
                for label, src, sock in trees:
                    rows_of[label].append(cold_build(name, args.formats, simulate=args.simulate,
                                                     src=src, socket=sock))
            for label, _, _ in trees:
                rows = rows_of[label]
                walls = [r["wall_s"] for r in rows]
                print(f"{name} {label}: cold build median {statistics.median(walls):.2f} s (min "
                      f"{min(walls):.2f}, {args.runs} runs: {', '.join(f'{w:.2f}' for w in walls)}; "
                      f"{what}); by stage (median s): {stage_line(rows)}", flush=True)
            if server is not None:
                cold = statistics.median(r["wall_s"] for r in rows_of["after"])
                warm = rows_of["after, warm server"]
                print(f"{name}: warm server / cold, same run: first build "
                      f"{warm[0]['wall_s'] / cold:.2f}, later builds "
                      f"{statistics.median(r['wall_s'] for r in warm[1:] or warm) / cold:.2f}", flush=True)
            if not args.no_parts:
                per = part_times(name, args.runs)
                worst = max(per, key=per.get)
                print(f"{name}: {len(per)} parts, warm per-part compile median "
                      f"{statistics.median(per.values()) * 1000:.0f} ms, max {per[worst] * 1000:.0f} ms "
                      f"({worst})", flush=True)
        if server is not None:
            server.terminate()
            server.wait(10)


def start_server(sock: Path) -> subprocess.Popen[str]:
    """``procedura-brep serve --socket sock``, returned once it listens."""
    proc = subprocess.Popen([sys.executable, "-m", "procedura_brep.cli", "serve", "--socket", str(sock)],
                            env=dict(os.environ, PROCEDURA_BREP_SERVER="off"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, text=True)
    deadline = time.monotonic() + 60
    while not sock.exists():
        if proc.poll() is not None or time.monotonic() > deadline:
            raise SystemExit("procedura-brep serve did not start")
        time.sleep(0.1)
    return proc


if __name__ == "__main__":
    main()
