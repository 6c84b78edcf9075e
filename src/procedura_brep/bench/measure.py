"""What one case costs: wall time, CPU seconds and peak resident memory (PSS) of the process
tree (the bench process, its compile worker and their children), sampled on a background
thread."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

import psutil

SAMPLE_S: float = 0.2
"""Interval of the memory sampler, seconds (a peak shorter than this can be missed)."""


def _tree() -> list[psutil.Process]:
    me = psutil.Process()
    try:
        return [me, *me.children(recursive=True)]
    except psutil.Error:
        return [me]


def _cpu_s() -> float:
    total = 0.0
    for p in _tree():
        try:
            t = p.cpu_times()
            total += t.user + t.system + t.children_user + t.children_system
        except psutil.Error:
            continue
    return total


def _rss() -> int:
    """Resident memory of the tree: proportional set sizes (shared pages split between the
    processes that share them, so a forked compile child is not counted twice), RSS where PSS
    is not available."""
    total = 0
    for p in _tree():
        try:
            total += getattr(p.memory_full_info(), "pss", None) or p.memory_info().rss
        except psutil.Error:
            continue
    return total


@dataclass
class Cost:
    """Measured cost of a block: ``wall_s``, ``cpu_s`` and ``peak_rss_mb`` (peak PSS, MiB) of
    the process tree.

    CPU time of processes that started and ended inside the block is counted once they are
    reaped (the sandbox worker reaps its per-compile children), so it is a lower bound.
    """

    wall_s: float = 0.0
    cpu_s: float = 0.0
    peak_rss_mb: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {"wall_s": round(self.wall_s, 3), "cpu_s": round(self.cpu_s, 3),
                "peak_rss_mb": round(self.peak_rss_mb, 1)}


class Meter:
    """``with Meter() as m: ...`` then ``m.cost``."""

    def __init__(self) -> None:
        self.cost = Cost()
        self._stop = threading.Event()
        self._peak = 0
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def _sample(self) -> None:
        while not self._stop.is_set():
            self._peak = max(self._peak, _rss())
            self._stop.wait(SAMPLE_S)

    def __enter__(self) -> Meter:
        self._t0, self._c0 = time.perf_counter(), _cpu_s()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self._peak = max(self._peak, _rss())
        self.cost = Cost(time.perf_counter() - self._t0, max(0.0, _cpu_s() - self._c0),
                         self._peak / 2**20)
