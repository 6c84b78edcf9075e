"""The warm compile worker (a zygote): imports the CAD kernel once, then forks one limited,
disposable child per compile (forked ahead of its request: :class:`_Spare`).

Protocol: one JSON object per line on stdin (``{"id", "source", "name", "scratch", "limits"}``),
one JSON object per line on stdout (``{"id", "status", "detail"}``); the child writes its
``result.json`` into the scratch directory. The zygote itself never runs program code and never
meshes (a fork after OCCT's parallel mesher hangs), so every child starts clean.

Run as ``python -m procedura_brep.program.worker``.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import sys
import time
from typing import Any


#: A root-run worker's children each switch to their own unprivileged uid (and gid),
#: ``CHILD_UID_BASE + pid % CHILD_UID_SPAN``: no passwd entry, no files, and no other process
#: (not even another compile's child) to signal or trace.
CHILD_UID_BASE = 2_000_000_000
CHILD_UID_SPAN = 1_000_000
#: RLIMIT_NPROC after the switch: room for OCCT's and BLAS's threads, not for a fork bomb.
NOBODY_NPROC = 256


def child_uid(pid: int) -> int:
    """The uid (and gid) a root-run worker's child ``pid`` switches to."""
    return CHILD_UID_BASE + pid % CHILD_UID_SPAN


def _limit_child(limits: dict[str, Any], scratch: str, cache_dir: str | None) -> int | None:
    """Apply every limit to this (child) process; returns an fd of the part cache, if any.

    Then the OS layers of :mod:`.isolation` (a private network namespace, no-new-privs,
    Landlock file access beneath the scratch dir (read-write), the cache and the library
    folders (read-only), a seccomp filter denying sockets, exec, namespaces and new processes),
    each where the kernel allows it; ``child.log`` names those applied and those not. When the worker
    runs as root (CI, containers), the child also drops to its own unprivileged uid
    (:func:`child_uid`): the scratch dir is handed over first, and the cache folder stays
    readable through an fd opened before the switch, so the program can read neither root-only
    files (such as the calling process's ``/proc/<pid>/environ``) nor write outside
    world-writable places.
    """
    os.setsid()
    cpu = int(limits["cpu_s"])
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 1))
    resource.setrlimit(resource.RLIMIT_AS, (limits["address_space_bytes"],) * 2)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limits["file_size_bytes"],) * 2)
    resource.setrlimit(resource.RLIMIT_NOFILE, (limits["open_files"],) * 2)
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    os.chdir(scratch)
    os.environ.clear()
    os.environ.update({"HOME": scratch, "TMPDIR": scratch, "PATH": "/nonexistent"})
    sys.setrecursionlimit(int(limits["recursion"]))
    log = os.open(os.path.join(scratch, "child.log"), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.dup2(log, 1)
    os.dup2(log, 2)
    os.closerange(3, 4096)
    log = 1
    cache_fd = None
    if cache_dir:
        try:
            cache_fd = os.open(cache_dir, os.O_RDONLY | os.O_DIRECTORY)
        except OSError:
            cache_fd = None
    from .isolation import isolate
    layers = isolate(scratch=scratch, read_fds=[cache_fd] if cache_fd is not None else [])
    if os.geteuid() == 0:
        _drop_root(scratch)
        layers.applied.append("own_uid")
    else:
        layers.missing.append("own_uid")
    os.write(log, ("isolation: " + " ".join(layers.applied) + "\n"
                   + "not applied: " + " ".join(layers.missing) + "\n").encode())
    return cache_fd


def _drop_root(scratch: str) -> None:
    uid = gid = child_uid(os.getpid())
    os.chown(scratch, uid, gid)
    os.chown(os.path.join(scratch, "child.log"), uid, gid)
    os.setgroups([])
    os.setgid(gid)
    os.setuid(uid)
    # this uid's processes and threads together (the kernel's threads count): bounds a fork bomb
    resource.setrlimit(resource.RLIMIT_NPROC, (NOBODY_NPROC, NOBODY_NPROC))


def _child(req: dict[str, Any]) -> None:
    scratch = req["scratch"]
    cache_fd = _limit_child(req["limits"], scratch, req.get("cache_dir"))
    from .model import Finding, to_json
    from .runtime import compile_program
    try:
        from ..config import SandboxLimits
        limits = SandboxLimits(**req["limits"])
        only = frozenset(req["only"]) if req.get("only") is not None else None
        model = compile_program(req["source"], name=req.get("name", "model"), cache_dir=cache_fd,
                                limits=limits, only=only)
        payload = to_json(model, by_key=cache_fd is not None)  # cached solids: by key
    except MemoryError:
        payload = {"fatal": Finding("memory", "the program ran out of memory (address-space limit "
                                    f"{req['limits']['address_space_bytes'] // 2**20} MiB)").as_dict()}
    except RecursionError:
        payload = {"fatal": Finding("recursion", "the program recursed too deeply (limit "
                                    f"{req['limits']['recursion']})").as_dict()}
    # relative to the scratch dir (the cwd): its ancestors may not be searchable by nobody
    with open("result.json.tmp", "w", encoding="utf-8") as fh:
        json.dump(payload, fh)
    os.replace("result.json.tmp", "result.json")


class _Spare:
    """A child forked ahead of its request, waiting on a pipe: forking the warm zygote costs
    10-20 ms here (its page tables), paid while the parent gates the last result instead of
    on the next compile's path. The spare holds nothing of the zygote's pipes (its stdin and
    stdout are ``/dev/null``), so a dead zygote's parent still sees end-of-file; it exits
    when its pipe closes without a request."""

    def __init__(self) -> None:
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the spare
            code = 0
            try:
                os.close(w)
                null = os.open(os.devnull, os.O_RDWR)
                os.dup2(null, 0)
                os.dup2(null, 1)
                chunks = []
                while True:
                    chunk = os.read(r, 1 << 20)
                    if not chunk:
                        break
                    chunks.append(chunk)
                if chunks:
                    _child(json.loads(b"".join(chunks)))
            except BaseException:  # noqa: BLE001
                code = 3
            finally:
                os._exit(code)
        os.close(r)
        self.pid, self._w = pid, w

    def start(self, req: dict[str, Any]) -> bool:
        """Hand ``req`` over; False when the spare is gone (it is reaped)."""
        data = json.dumps(req).encode()
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(self._w, view):]
            return True
        except OSError:
            try:
                os.kill(self.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            try:
                os.waitpid(self.pid, 0)
            except ChildProcessError:
                pass
            return False
        finally:
            os.close(self._w)


def _start(req: dict[str, Any], spare: _Spare | None) -> int | None:
    """Hand ``req`` to ``spare`` (or to a newly forked child); the child's pid, or None."""
    if spare is not None and spare.start(req):
        return spare.pid
    fresh = _Spare()
    return fresh.pid if fresh.start(req) else None


def _run_one(req: dict[str, Any], spare: _Spare | None = None) -> dict[str, Any]:
    if req.get("op") == "prebuild":
        return _prebuild(req, spare)
    t0 = time.monotonic()
    pid = _start(req, spare)
    if pid is None:
        return {"id": req["id"], "status": "error", "detail": "the compile child did not start"}
    return {"id": req["id"], **_finish(pid, t0, float(req["limits"]["wall_s"]))}


def _prebuild(req: dict[str, Any], spare: _Spare | None) -> dict[str, Any]:
    """One child per job (``{"scratch", "only"}``), all at once, under one wall-clock limit:
    the shares of a parallel cold compile. Replies with each job's status, in order."""
    t0 = time.monotonic()
    pids = []
    for i, job in enumerate(req["jobs"]):
        pids.append(_start({**req, "op": "compile", "scratch": job["scratch"], "only": job["only"]},
                           spare if i == 0 else None))
    wall = float(req["limits"]["wall_s"])
    jobs = [{"status": "error", "detail": "the compile child did not start"} if pid is None
            else _finish(pid, t0, wall) for pid in pids]
    return {"id": req["id"], "jobs": jobs}


def _finish(pid: int, t0: float, wall: float) -> dict[str, Any]:
    """Wait for child ``pid`` until ``t0 + wall``: its status, detail and seconds."""
    status = _wait(pid, t0 + wall)
    if status is None:
        _kill_group(pid, child_too=True)
        os.waitpid(pid, 0)
        return {"status": "timeout", "detail": f"wall-clock limit {wall:g} s",
                "seconds": time.monotonic() - t0}
    out: dict[str, Any] = {"seconds": time.monotonic() - t0}
    _kill_group(pid)  # anything the child left behind
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else str(sig)
        out.update(status="signal", detail=name)
    else:
        out.update(status="exit", detail=str(os.WEXITSTATUS(status)))
    return out


def _wait(pid: int, deadline: float) -> int | None:
    """The child's wait status, or None once ``deadline`` (monotonic) passes first. Blocks on a
    pidfd where the kernel has them (Linux 5.3), so the reply leaves as soon as the child
    exits; else polls every 5 ms."""
    import select
    try:
        fd = os.pidfd_open(pid)
    except (AttributeError, OSError):
        fd = None
    try:
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                return status
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            if fd is not None:
                select.select([fd], [], [], left)
            else:
                time.sleep(min(0.005, left))
    finally:
        if fd is not None:
            os.close(fd)


def _kill_group(pid: int, *, child_too: bool = False) -> None:
    """Kill the child's process group (its own, from ``setsid``); with ``child_too``, also the
    child itself (not yet reaped, so its pid is still its own), in case it never got as far as
    ``setsid``."""
    for kill in (os.killpg, os.kill) if child_too else (os.killpg,):
        try:
            kill(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass


def _stub_unused_imports() -> None:
    """Skip scikit-learn (~0.5-1 s of build123d's import): build123d uses it only for
    ``import_stl``'s clustering, and programs have no file import. The stub raises if used."""
    import types
    if "sklearn" in sys.modules:
        return
    sk, cluster = types.ModuleType("sklearn"), types.ModuleType("sklearn.cluster")

    class DBSCAN:  # noqa: D401 - stand-in
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            raise ImportError("scikit-learn is not loaded in the compile worker (STL import is "
                              "not available to programs)")

    cluster.DBSCAN = DBSCAN  # type: ignore[attr-defined]
    sk.cluster = cluster  # type: ignore[attr-defined]
    sys.modules["sklearn"], sys.modules["sklearn.cluster"] = sk, cluster


def main() -> None:
    _stub_unused_imports()
    import build123d  # noqa: F401 - the whole point: pay the import once

    from . import guards, runtime  # noqa: F401
    from .. import kernel  # noqa: F401
    guards.harden_kernel()
    guards.baseline()
    from . import caps, isolation, trust  # noqa: F401 - imported before any child drops privileges
    isolation.preload()
    import gc
    # everything imported so far lives as long as the zygote: out of the cyclic collector's
    # reach, so a child's collections never walk it (and never copy its pages on write)
    gc.collect()
    gc.freeze()
    out = sys.stdout
    out.write(json.dumps({"ready": True, "pid": os.getpid()}) + "\n")
    out.flush()
    spare: _Spare | None = _Spare()
    for line in sys.stdin:
        if not line.strip():
            continue
        req = json.loads(line)
        try:
            reply = _run_one(req, spare)
        except Exception as exc:  # noqa: BLE001
            reply = {"id": req.get("id"), "status": "error", "detail": str(exc)}
        out.write(json.dumps(reply) + "\n")
        out.flush()
        try:
            spare = _Spare()  # the next compile's child, forked after this reply left
        except OSError:
            spare = None


if __name__ == "__main__":
    main()
