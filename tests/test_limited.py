"""isolate.run_limited: the limited child does not outlive the process that forked it."""

from __future__ import annotations

import os
import signal
import time

import pytest

from procedura_brep.limited import run_limited


def _gone(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except OSError:
        return True


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="needs /proc")
def test_a_killed_parent_takes_its_limited_child_with_it():
    r, w = os.pipe()
    cli = os.fork()
    if cli == 0:  # plays the CLI: runs a stage that would sleep a minute
        try:
            os.close(r)

            def stage(send):
                send({"stage": "gates", "line": str(os.getpid())})
                time.sleep(60)
                return {}

            run_limited(stage, stage="gates",
                        on_message=lambda m: os.write(w, (m["line"] + "\n").encode()))
        finally:
            os._exit(0)
    os.close(w)
    with os.fdopen(r) as fh:
        child = int(fh.readline())
        os.kill(cli, signal.SIGKILL)  # a user's kill -9, or a timeout's
        os.waitpid(cli, 0)
    deadline = time.monotonic() + 10
    while not _gone(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    gone = _gone(child)
    if not gone:
        os.kill(child, signal.SIGKILL)
    assert gone, "the limited child outlived its parent"
