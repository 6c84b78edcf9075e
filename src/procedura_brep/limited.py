"""Run the parent's heavy stages (meshing, exports, gates, battery) in a limited forked child.

The compile runs in the sandbox worker, but the compiled model is then tessellated, exported,
gated and simulated in the CLI's own process: a model whose meshes blow up memory, or a gate
that never ends, would take the CLI down (or hang it) with no report. :func:`run_limited` forks
a child that sets ``RLIMIT_AS`` (:data:`procedura_brep.config.PARENT`), runs one function and
sends its JSON result back over a pipe, with ``{"stage": ..., "line": ...}`` messages on the way
(progress lines and the stage an interrupt report names). The parent waits with the wall-clock
limit, kills the child on overrun, and turns every way the child can die into one
:class:`ChildFailure` with a one-line message.

Users: the pipeline (``build``, and ``generate``'s builds) and :mod:`procedura_brep.run.commands`
(``check``, ``render``, ``export``, ``simulate``).

Fork before the parent ever meshes: a child forked after OCCT's parallel mesher ran hangs. The
pipeline keeps every tessellation in the child, so the parent only reads BRep (volumes, boxes).
"""

from __future__ import annotations

import json
import os
import resource
import select
import signal
import time
from collections.abc import Callable
from typing import Any

from . import interrupt
from .config import PARENT, ParentLimits
from .paths import json_default

Send = Callable[[dict[str, Any]], None]
#: Exception types (by name) that mean "out of memory" from native code under RLIMIT_AS.
OUT_OF_MEMORY = ("Standard_OutOfMemory", "bad_alloc")
PR_SET_PDEATHSIG = 1


class ChildFailure(Exception):
    """The child died, overran or raised; ``kind`` is memory | timeout | killed | crash | error."""

    def __init__(self, kind: str, message: str, *, stage: str, exc_type: str | None = None) -> None:
        self.kind, self.stage, self.exc_type = kind, stage, exc_type
        self.oserror = self.procedura = False  # for kind "error": what the child raised
        super().__init__(message)


def run_limited(fn: Callable[[Send], dict[str, Any]], *, stage: str,
                on_message: Callable[[dict[str, Any]], None] | None = None,
                limits: ParentLimits | None = None) -> dict[str, Any]:
    """Run ``fn(send)`` in a forked child under ``limits``; return its dict.

    ``fn`` may call ``send({...})`` to pass JSON messages to ``on_message`` while it runs.

    Raises:
        ChildFailure: out of memory, over the wall-clock limit, killed, crashed, or ``fn`` raised
            (``kind == "error"``; ``exc_type`` names the exception class).
    """
    child = Limited(fn, stage=stage, limits=limits)
    with interrupt.on_interrupt(child.kill):
        return child.collect(on_message)


class Limited:
    """A forked, limited child running ``fn(send)`` (as :func:`run_limited`) while the caller
    goes on: :meth:`collect` waits for its dict, :meth:`kill` ends it. A child that forks one
    of its own (an overlapped stage) relays that one's :class:`ChildFailure` as its own."""

    def __init__(self, fn: Callable[[Send], dict[str, Any]], *, stage: str,
                 limits: ParentLimits | None = None) -> None:
        self.stage, self.limits = stage, limits or PARENT
        r, w = os.pipe()
        parent = os.getpid()
        pid = os.fork()
        if pid == 0:  # child: never returns
            die_with(parent)
            _child(fn, w, r, self.limits)
        os.close(w)
        self.pid, self._r = pid, r
        self._deadline = time.monotonic() + self.limits.wall_s
        self._reaped = False  # once waited for, its pid may belong to another process

    def collect(self, on_message: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
        """The child's dict (the wall-clock limit counts from its start).

        Raises:
            ChildFailure: as :func:`run_limited`.
        """
        try:
            return _collect(self.pid, self._r, self.limits, {"stage": self.stage}, on_message,
                            deadline=self._deadline)
        except BaseException:
            self.kill()
            raise
        finally:
            self._reaped = True  # _collect waited for it, or kill did
            self._close()

    def kill(self) -> None:
        """End the child now and reap it (safe to call twice, from any thread; the pipe stays
        open for a :meth:`collect` under way: :meth:`close` it after)."""
        if not self._reaped:
            _kill(self.pid)

    def close(self) -> None:
        """Kill the child if it still runs and close its pipe (for a caller that does not
        :meth:`collect`)."""
        self.kill()
        self._close()

    def _close(self) -> None:
        r, self._r = self._r, -1
        if r >= 0:
            try:
                os.close(r)
            except OSError:
                pass


def die_with(parent: int, sig: int = signal.SIGKILL) -> None:
    """Have ``sig`` sent to this forked child when ``parent``, the process that forked it, dies
    (a killed CLI must not leave its limited child running, since the parent is what enforces
    the wall-clock limit; a warm server's command gets SIGTERM, to stop as a local one does).
    A parent already gone before the request took effect ends the child at once."""
    try:
        import ctypes
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, sig, 0, 0, 0)
    except (OSError, AttributeError):  # pragma: no cover - not Linux
        return
    if os.getppid() != parent:  # it died before the prctl
        os._exit(3)


def _child(fn: Callable[[Send], dict[str, Any]], w: int, r: int, lim: ParentLimits) -> None:
    code = 0
    try:
        os.close(r)
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides (and kills us)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        resource.setrlimit(resource.RLIMIT_AS, (lim.address_space_bytes, lim.address_space_bytes))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))

        def send(msg: dict[str, Any]) -> None:
            _write(w, msg)

        try:
            out = {"result": fn(send)}
        except MemoryError:
            out = {"failure": {"kind": "memory", "message": "ran out of memory"}}
        except ChildFailure as exc:  # a child of this child failed: its failure is ours
            out = {"failure": {"kind": exc.kind, "type": exc.exc_type, "message": str(exc),
                               "oserror": exc.oserror, "procedura": exc.procedura}}
        except BaseException as exc:  # noqa: BLE001 - reported to the parent
            from .errors import ProceduraError
            out = {"failure": {"kind": "error", "type": type(exc).__name__, "message": str(exc),
                               "oserror": isinstance(exc, OSError),
                               "procedura": isinstance(exc, ProceduraError)}}
            if type(exc).__name__ in OUT_OF_MEMORY:  # OCCT's own, under the same limit
                out = {"failure": {"kind": "memory", "message": "ran out of memory"}}
        _write(w, out)
    except MemoryError:
        code = 3
        try:
            os.write(w, b'{"failure": {"kind": "memory", "message": "ran out of memory"}}\n')
        except OSError:
            pass
    except BaseException:  # noqa: BLE001 - the forked child reports any failure as exit 3
        code = 3
    finally:
        os._exit(code)


def _write(fd: int, msg: dict[str, Any]) -> None:
    data = (json.dumps(msg, default=json_default) + "\n").encode()
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]


def _collect(pid: int, fd: int, lim: ParentLimits, current: dict[str, str],
             on_message: Callable[[dict[str, Any]], None] | None, *,
             deadline: float) -> dict[str, Any]:
    buf = b""
    final: dict[str, Any] | None = None
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            _kill(pid)
            raise ChildFailure("timeout", f"the {current['stage']} stage did not finish within "
                                          f"the wall-clock limit ({lim.wall_s:g} s, "
                                          f"config.PARENT.wall_s)", stage=current["stage"])
        ready, _, _ = select.select([fd], [], [], min(left, 1.0))
        if not ready:
            continue
        chunk = os.read(fd, 1 << 16)
        if not chunk:
            break
        buf += chunk
        *lines, buf = buf.split(b"\n")
        for line in lines:
            msg = json.loads(line)
            if "result" in msg or "failure" in msg:
                final = msg
            else:
                current["stage"] = str(msg.get("stage", current["stage"]))
                if on_message is not None:
                    on_message(msg)
    try:
        _, status = os.waitpid(pid, 0)
    except ChildProcessError:  # reaped by the interrupt cleanup: it was killed
        status = signal.SIGKILL
    stage = current["stage"]
    mib = lim.address_space_bytes // 2**20
    if final is not None and "result" in final:
        result: dict[str, Any] = final["result"]
        return result
    if final is not None:
        f = final["failure"]
        if f["kind"] == "memory":
            raise ChildFailure("memory", f"the {stage} stage ran out of memory (address-space "
                                         f"limit {mib} MiB, config.PARENT)", stage=stage)
        if f["kind"] in ("timeout", "killed", "crash"):  # relayed from the child's own child
            raise ChildFailure(f["kind"], str(f["message"]), stage=stage)
        err = ChildFailure("error", f["message"], stage=stage, exc_type=f.get("type"))
        err.oserror, err.procedura = bool(f.get("oserror")), bool(f.get("procedura"))
        raise err
    if os.WIFSIGNALED(status):
        name = signal.Signals(os.WTERMSIG(status)).name
        raise ChildFailure("killed", f"the {stage} stage was killed by {name} (address-space "
                                     f"limit {mib} MiB, config.PARENT)", stage=stage)
    raise ChildFailure("crash", f"the {stage} stage exited without a result (status "
                                f"{os.WEXITSTATUS(status)}; address-space limit {mib} MiB)",
                       stage=stage)


def _kill(pid: int) -> None:
    """SIGKILL the child and reap it (safe to call twice, from any thread)."""
    try:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    except (ProcessLookupError, ChildProcessError):
        pass


__all__ = ["ChildFailure", "Limited", "die_with", "run_limited"]
