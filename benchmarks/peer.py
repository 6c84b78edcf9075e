"""Cold call against a peer (issue 24 item 2): our cold ``build`` of the 3-part lamp against
mini-articraft's cold compile of its 2-part hinged box, in alternating pairs.

Ours: ``python -m procedura_brep build tests/program/lamp.py -o DIR -q`` in a fresh process with the part
store empty (``PROCEDURA_BREP_CACHE=off``) and no server: compile, gates, STEP, OBJ, GLB, USD,
URDF, MJCF, the viewer and ``sheet.png``.

The peer: its documented cold path, ``python -m mini_articraft.environments.worker RUN`` with
``RUN/workspace/main.py`` its ``examples/hinged_box/main.py``: the model, its tests, its
compiler checks (the hinge sweep among them) and its USDZ, validated. The peer is not on PyPI
and is not part of this repository: pass the folder that holds it (``src/mini_articraft``, a
``.venv`` with its dependencies, ``examples/hinged_box/main.py``) as ``--peer``.

The tree measured on 2026-12-04 (:data:`PEER_FILES`) was assembled file by file from the stored
public index of mattzh72/mini-articraft (the machine has no network but the package
registries), around commit 2a34955 (worker, local, sdk/export, sdk/testing, _mesh_core), each
other module at a stored version whose names and signatures match those files' calls; no
single commit is proven to hold them all, nothing was patched, and it runs clean (status
success, no failures, as its own test of the example expects). Its dependencies are those of
its pyproject.toml at 0deb2e3, installed by pip into the folder's ``.venv``; the package runs
from ``src`` (``PYTHONPATH``).

Both sides run with bytecode caching on (``PYTHONDONTWRITEBYTECODE`` unset, as on a user's
machine), after one untimed run each. Wall time is the figure; CPU is user+sys of the waited-for
child processes (a process a side leaves to die unwaited is not counted).

``--before REV`` also times our build at git revision REV (its ``src/`` exported to a temporary
folder) after each pair: the before/after of a change, beside the peer.

``--server`` also starts ``procedura-brep serve`` (on a socket of its own, before the first pair)
and times our build through it after each pair: a fresh CLI process that finds the warm server
running (the build runs in the server's fork, src/procedura_brep/served.py), against the same
peer call.

Run: ``python benchmarks/peer.py --peer /tmp/peer [--pairs 7] [--before REV] [--server]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: (path in mattzh72/mini-articraft, commit) of every file of the measured peer tree.
PEER_FILES: tuple[tuple[str, str], ...] = tuple(
    (f"src/mini_articraft/{p}", c) for p, c in (
        ("environments/worker.py", "2a34955ec94aada3f095f933304365c230d57d07"),
        ("environments/local.py", "2a34955ec94aada3f095f933304365c230d57d07"),
        ("sdk/export.py", "2a34955ec94aada3f095f933304365c230d57d07"),
        ("sdk/testing.py", "2a34955ec94aada3f095f933304365c230d57d07"),
        ("sdk/_mesh_core.py", "2a34955ec94aada3f095f933304365c230d57d07"),
        ("sdk/_collision.py", "e5215b3f6f3025aece336c1053e0fd30a0d08052"),
        ("compile_feedback.py", "e5215b3f6f3025aece336c1053e0fd30a0d08052"),
        ("compile_result.py", "e5215b3f6f3025aece336c1053e0fd30a0d08052"),
        ("sdk/object.py", "25b777dc35be84bf9917bd7ede79a2ea6ccb3982"),
        ("sdk/errors.py", "25b777dc35be84bf9917bd7ede79a2ea6ccb3982"),
        ("sdk/joints.py", "838183ff98e5190cc53c6e59f9d6c90599f8abe3"),
        ("sdk/__init__.py", "161180313e485c5744f6bbd36143979f38d0d839"),
        ("sdk/_mesh_sweeps.py", "c100e9f3379bf52a8db661f435972f33467028f0"),
        ("sdk/_mesh_profiles.py", "e1604c7d80458e33ad533878934be99ec6e56802"),
        ("environments/__init__.py", "b383b73169724a3117ae0fa64dbd46566bb30a42"),
        ("__init__.py", "ff6fe397a0bb699b562789768fc160780d49584d"),
        ("settings.py", "77447ea6b6059b65d4ae566bbf2abe33fd683076"),
        ("record.py", "453e9cecbf1210b1b9e5c06e43eefbf14d432dd7"),
        ("_child_process.py", "669a06dac5721dfcca4740b2e015c1708777812c"),
    )) + (("examples/hinged_box/main.py", "6a0b0d4ef6cc4ee3fe21926cc991f50f5698ee8c"),
          ("pyproject.toml", "0deb2e3c8f74fa4e435570f565032d3c6c16ed65"))
LAMP = ROOT / "tests" / "program" / "lamp.py"


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """(wall s, CPU s) of one run of ``cmd``; raises on a failed run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    done = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(cmd[:4])} ... failed ({done.returncode}): {done.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def ours(tmp: Path, src: Path | None = None, sock: Path | None = None) -> tuple[float, float]:
    """Our cold build; with ``src``, of the package tree there (``--before``); with ``sock``,
    through the warm server listening there (``--server``)."""
    out = tmp / "ours"
    shutil.rmtree(out, ignore_errors=True)
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PROCEDURA_BREP_SERVER")}
    env.update(PROCEDURA_BREP_CACHE="off")
    if sock is None:
        env["PROCEDURA_BREP_SERVER"] = "off"
    else:
        env["PROCEDURA_BREP_SOCKET"] = str(sock)
    if src is not None:
        env["PYTHONPATH"] = str(src)
    return timed([sys.executable, "-m", "procedura_brep", "build", str(LAMP), "-o", str(out), "-q"], env)


def peer(tmp: Path, folder: Path) -> tuple[float, float]:
    run = tmp / "peer"
    shutil.rmtree(run, ignore_errors=True)
    (run / "workspace").mkdir(parents=True)
    shutil.copy(folder / "examples" / "hinged_box" / "main.py", run / "workspace" / "main.py")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(folder / "src")
    return timed([str(folder / ".venv" / "bin" / "python"), "-m", "mini_articraft.environments.worker",
                  str(run)], env)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--peer", type=Path, required=True, help="the folder holding mini-articraft")
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--before", default=None, metavar="REV",
                    help="also time our build at git revision REV, in turn with the others")
    ap.add_argument("--server", action="store_true",
                    help="also time our build through a warm server (procedura-brep serve)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        server = sock = None
        if args.server:
            from build import start_server  # benchmarks/build.py, beside this script
            sock = tmp / "srv" / "w.sock"
            server = start_server(sock)
        try:
            run_pairs(args, tmp, sock)
        finally:
            if server is not None:
                server.terminate()
                server.wait(10)


def run_pairs(args: argparse.Namespace, tmp: Path, sock: Path | None) -> None:
    before = None
    if args.before:
        from build import export_tree  # benchmarks/build.py, beside this script
        before = export_tree(args.before, tmp)
        ours(tmp, before)
    ours(tmp), peer(tmp, args.peer)  # untimed: bytecode caches written, files in the page cache
    if sock is not None:
        ours(tmp, sock=sock)
    old: list[float] = []
    warm: list[float] = []
    rows: list[tuple[float, float, float, float]] = []
    for i in range(args.pairs):
        a, b = (ours(tmp), peer(tmp, args.peer)) if i % 2 == 0 else reversed((peer(tmp, args.peer), ours(tmp)))
        rows.append((*a, *b))
        print(f"pair {i + 1}: ours {a[0]:.2f} s wall {a[1]:.2f} s CPU; peer {b[0]:.2f} s wall "
              f"{b[1]:.2f} s CPU; wall ratio {a[0] / b[0]:.2f}", flush=True)
        if before is not None:
            old.append(ours(tmp, before)[0])
        if sock is not None:
            warm.append(ours(tmp, sock=sock)[0])
            print(f"        ours through the warm server {warm[-1]:.2f} s wall: "
                  f"{warm[-1] / b[0]:.2f} of the peer", flush=True)
    ow, oc, pw, pc = (statistics.median(r[k] for r in rows) for k in range(4))
    ratios = sorted(r[0] / r[2] for r in rows)
    print(f"ours (lamp, cold build, 6 formats + sheet): median {ow:.2f} s wall, {oc:.2f} s CPU")
    print(f"peer (hinged box, cold compile + checks + USDZ): median {pw:.2f} s wall, {pc:.2f} s CPU")
    print(f"wall ratio of medians {ow / pw:.2f} (pairs: {ratios[0]:.2f}-{ratios[-1]:.2f}, median "
          f"{statistics.median(ratios):.2f}); CPU ratio {oc / pc:.2f}")
    if old:
        print(f"ours before ({args.before}): median {statistics.median(old):.2f} s wall; "
              f"after/before {ow / statistics.median(old):.2f}; before/peer {statistics.median(old) / pw:.2f}")
    if warm:
        wm = statistics.median(warm)
        print(f"ours through the warm server (a fresh CLI process, `procedura-brep serve` running): "
              f"median {wm:.2f} s wall; {wm / pw:.2f} of the peer; {wm / ow:.2f} of our cold build")


if __name__ == "__main__":
    main()
