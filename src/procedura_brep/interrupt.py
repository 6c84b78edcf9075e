"""Ctrl-C for the command line: stop within a second or two, whatever the main thread is doing.

A ``KeyboardInterrupt`` raised in the main thread is unreliable here: ``import trimesh`` and
other libraries catch ``BaseException``, an OCCT call does not return to Python for seconds, and
an interrupt inside a C-extension import surfaces as ``ImportError``. So :func:`install` (the
CLI's entry point calls it) replaces SIGINT/SIGTERM with a handler that does nothing in the main
thread; the C-level handler also writes the signal number to a wake-up pipe, and a watcher
thread that blocks on that pipe (without the GIL) runs the shutdown: it waits for a running
:func:`critical` section (a run directory's commit, milliseconds), runs the registered cleanups
(the pipeline writes report.json with status ``interrupted``, the sandbox kills its worker and
the worker's children), prints ``error: interrupted`` and ends the process with exit code 130
(143 for SIGTERM). Libraries never see the signal.

Child processes started inside :func:`children_ignore_sigint` (the compile worker) never act on
the terminal's SIGINT, which the terminal sends to the whole foreground process group: their
parent owns their lifetime and ends them itself.

Without :func:`install` (library use, tests in-process) nothing changes: Ctrl-C raises
``KeyboardInterrupt`` and the pipeline still writes its ``interrupted`` report on the way out.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator

log = logging.getLogger(__name__)

#: Exit status per signal, as a shell reports a process killed by it (128 + number).
EXIT_CODES: dict[int, int] = {signal.SIGINT: 130, signal.SIGTERM: 143}
#: How long the shutdown waits for a critical section before it ends the process anyway.
CRITICAL_WAIT_S: float = 5.0

_critical = threading.RLock()
_cleanups: list[Callable[[], None]] = []
_installed = False
_stopping = threading.Event()


def installed() -> bool:
    """Whether :func:`install` is active in this process."""
    return _installed


def install() -> None:
    """Route SIGINT and SIGTERM to the watcher thread (main thread only; idempotent)."""
    global _installed
    if _installed or threading.current_thread() is not threading.main_thread():
        return
    r, w = os.pipe()
    os.set_blocking(w, False)
    signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    for sig in EXIT_CODES:
        signal.signal(sig, _ignore_in_main)
    threading.Thread(target=_watch, args=(r,), name="procedura-interrupt", daemon=True).start()
    _installed = True


def _ignore_in_main(signum: int, frame: object) -> None:
    """The Python-level handler: nothing; the watcher thread acts on the wake-up byte."""


def _watch(fd: int) -> None:
    while True:
        data = os.read(fd, 64)
        for signum in data:
            if signum in EXIT_CODES:
                shutdown(signum)


def shutdown(signum: int = signal.SIGINT) -> None:
    """Run the cleanups and end the process now (called by the watcher thread)."""
    if _stopping.is_set():
        return
    _stopping.set()
    _critical.acquire(timeout=CRITICAL_WAIT_S)  # held until the process ends
    try:
        for fn in reversed(list(_cleanups)):
            try:
                fn()
            except BaseException:  # noqa: BLE001 - a closed or broken stdout must not stop the exit - a cleanup must not stop the exit
                log.debug("cleanup failed during interrupt", exc_info=True)
        name = "interrupted" if signum == signal.SIGINT else f"terminated ({signal.Signals(signum).name})"
        try:
            sys.stdout.flush()
        except BaseException:  # noqa: BLE001 - a closed or broken stdout must not stop the exit
            pass
        os.write(2, f"\nerror: {name}\n".encode())
    finally:
        os._exit(EXIT_CODES.get(signum, 130))


def stopping() -> bool:
    """Whether a shutdown is under way (the watcher thread will end the process)."""
    return _stopping.is_set()


def hold() -> None:
    """Block the calling thread while a shutdown is under way: the main thread must not exit
    (or print its own error) before the watcher has written the report and ended the process."""
    while _stopping.is_set():
        time.sleep(CRITICAL_WAIT_S)


@contextlib.contextmanager
def critical() -> Iterator[None]:
    """A short section the shutdown waits for (e.g. the renames that commit a run directory)."""
    with _critical:
        yield


@contextlib.contextmanager
def on_interrupt(fn: Callable[[], None]) -> Iterator[None]:
    """Run ``fn`` if the process is interrupted while the block runs (innermost first)."""
    _cleanups.append(fn)
    try:
        yield
    finally:
        with contextlib.suppress(ValueError):
            _cleanups.remove(fn)


def add_cleanup(fn: Callable[[], None]) -> None:
    """Run ``fn`` on any interrupt for the rest of the process (e.g. kill the compile worker)."""
    if fn not in _cleanups:
        _cleanups.insert(0, fn)


def forget() -> None:
    """Start over in a forked child that will run a command of its own (a warm server's run,
    :mod:`procedura_brep.served`): no cleanups, no shutdown under way, SIGINT and SIGTERM at
    their defaults and no wake-up pipe (the parent's watcher thread did not survive the fork),
    so :func:`install` installs afresh. Main thread only (a forked child's one thread is)."""
    global _installed
    _installed = False
    _cleanups.clear()
    _stopping.clear()
    signal.set_wakeup_fd(-1)
    for sig in EXIT_CODES:
        signal.signal(sig, signal.SIG_DFL)


@contextlib.contextmanager
def children_ignore_sigint() -> Iterator[None]:
    """Processes started in this block start with SIGINT blocked: a blocked signal stays
    blocked across fork and exec, and Python does not unblock it, so theirs stays pending for
    good. In this process only the main thread blocks it, for the block's duration: a Ctrl-C
    that arrives meanwhile reaches the watcher thread (:func:`install`), or this thread when
    the block ends; it is never lost (ignoring SIGINT here instead lost a Ctrl-C that came
    while the worker was starting). Main thread only; elsewhere a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


__all__ = ["install", "installed", "forget", "shutdown", "critical", "on_interrupt", "add_cleanup",
           "children_ignore_sigint", "EXIT_CODES"]
