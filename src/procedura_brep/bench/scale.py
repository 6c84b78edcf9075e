"""Executors: one case x variant per task, in this process, in N spawned processes, or as Ray
tasks. Every executor runs :func:`.runner.run_task`, which writes into the shared bench
directory and skips finished runs, so resume works across modes (start with ``--jobs 4``,
finish with ``--ray``)."""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from .cases import BenchError
from .runner import run_task

Task = dict[str, Any]
Record = dict[str, Any]
Done = Callable[[Record], None]


def run_serial(tasks: list[Task], done: Done) -> list[Record]:
    """Run the tasks one after another in this process (one warm compile worker)."""
    out = []
    for t in tasks:
        out.append(run_task(t))
        done(out[-1])
    return out


def run_processes(tasks: list[Task], jobs: int, done: Done) -> list[Record]:
    """Run the tasks in ``jobs`` spawned processes; each keeps its own warm compile worker
    across the cases it runs. Results come back in task order."""
    ctx = multiprocessing.get_context("spawn")
    out: list[Record | None] = [None] * len(tasks)
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
        futures = {pool.submit(run_task, t): i for i, t in enumerate(tasks)}
        for fut in as_completed(futures):
            out[futures[fut]] = fut.result()
            done(out[futures[fut]])  # type: ignore[arg-type]  # filled just above
    return [r for r in out if r is not None]


def ray_module() -> Any:
    """Ray, or a one-line error saying how to install it."""
    try:
        import ray
    except ImportError:
        raise BenchError("--ray needs Ray, which is not installed: pip install 'procedura-brep[ray]'") from None
    return ray


def run_ray(tasks: list[Task], address: str | None, done: Done) -> list[Record]:
    """Run each task as a Ray task asking for its case's ``cpus``.

    ``address`` None: ``ray.init()`` on this machine (or the instance already initialised in this
    process); otherwise connect to that cluster (``auto``, ``ray://host:10001``, ``host:6379``).
    Every node must see the bench directory at the same path (a shared filesystem).
    """
    ray = ray_module()
    if not ray.is_initialized():
        try:
            ray.init(address=address, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise BenchError(f"cannot start or reach Ray at {address or 'this machine'}: {exc}") from None
    remote = ray.remote(run_task)
    refs = {remote.options(num_cpus=float(t.get("cpus", 1.0))).remote(t): i for i, t in enumerate(tasks)}
    out: list[Record | None] = [None] * len(tasks)
    pending = list(refs)
    while pending:
        ready, pending = ray.wait(pending, num_returns=1)
        for ref in ready:
            out[refs[ref]] = ray.get(ref)
            done(out[refs[ref]])  # type: ignore[arg-type]  # filled just above
    return [r for r in out if r is not None]


def execute(tasks: list[Task], *, jobs: int = 1, ray: bool = False, address: str | None = None,
            done: Done | None = None) -> list[Record]:
    """Run every task with the chosen executor; ``done`` hears each record as it comes."""
    hear = done or (lambda rec: None)
    if ray:
        return run_ray(tasks, address, hear)
    if jobs > 1 and len(tasks) > 1:
        return run_processes(tasks, min(jobs, len(tasks)), hear)
    return run_serial(tasks, hear)
