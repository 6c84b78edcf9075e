"""The warm compile worker (a zygote): imports the CAD kernel once, then forks one limited,
disposable child per compile (forked ahead of its request: :class:`_Spare`).

Protocol: one JSON object per line on stdin (``{"id", "source", "name", "scratch", "limits"}``),
one JSON object per line on stdout (``{"id", "status", "detail"}``); the child writes its
``result.json`` into the scratch directory, then says so on its done pipe, and the zygote
answers at once (status ``done``) and reaps the child after the answer has left. The zygote itself
never runs program code and never
meshes (a fork after OCCT's parallel mesher hangs), so every child starts clean.

Run as ``python -m procedura_brep.program.worker``.
"""

from __future__ import annotations

import functools
import importlib.abc
import importlib.machinery
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


#: The fd on which a compile child tells the zygote that its ``result.json`` is complete.
DONE_FD = 3


def _limit_child(limits: dict[str, Any], scratch: str, cache_dir: str | None,
                 done: int | None = None) -> int | None:
    """Apply every limit to this (child) process; returns an fd of the part cache, if any.
    ``done`` (the write end of the zygote's done pipe) is kept open as :data:`DONE_FD`; every
    other inherited descriptor is closed.

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
    if done is not None:
        os.dup2(done, DONE_FD)
    os.closerange(DONE_FD + (done is not None), 4096)
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


def _child(req: dict[str, Any], done: int | None = None) -> None:
    scratch = req["scratch"]
    cache_fd = _limit_child(req["limits"], scratch, req.get("cache_dir"), done)
    from .model import Finding, to_json
    from .runtime import compile_program
    try:
        from ..config import SandboxLimits
        limits = SandboxLimits(**req["limits"])
        share = (int(req["share"][0]), int(req["share"][1])) if req.get("share") is not None else None
        model = compile_program(req["source"], name=req.get("name", "model"), cache_dir=cache_fd,
                                limits=limits, share=share)
        payload = to_json(model, by_key=cache_fd is not None)  # cached solids: by key
    except MemoryError:
        payload = {"fatal": Finding("memory", "the program ran out of memory (address-space limit "
                                    f"{req['limits']['address_space_bytes'] // 2**20} MiB)").as_dict()}
    except RecursionError:
        payload = {"fatal": Finding("recursion", "the program recursed too deeply (limit "
                                    f"{req['limits']['recursion']})").as_dict()}
    # relative to the scratch dir (the cwd): its ancestors may not be searchable by nobody
    with open("result.json.tmp", "w", encoding="utf-8") as fh:
        fh.write(json.dumps(payload))  # one write: much faster than json.dump's many
    os.replace("result.json.tmp", "result.json")
    if done is not None:  # the zygote may answer now; it kills this process and reaps it
        os.write(DONE_FD, b"1")


class _Spare:
    """A child forked ahead of its request, waiting on a pipe: forking the warm zygote costs
    10-20 ms here (its page tables), paid while the parent gates the last result instead of
    on the next compile's path. The spare holds nothing of the zygote's pipes (its stdin and
    stdout are ``/dev/null``), so a dead zygote's parent still sees end-of-file; it exits
    when its pipe closes without a request."""

    def __init__(self) -> None:
        r, w = os.pipe()
        done_r, done_w = os.pipe()
        pid = os.fork()
        if pid == 0:  # the spare
            code = 0
            try:
                os.close(w)
                os.close(done_r)
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
                    _child(json.loads(b"".join(chunks)), done_w)
            except BaseException:  # noqa: BLE001 - the forked child reports any failure as exit 3
                code = 3
            finally:
                os._exit(code)
        os.close(r)
        os.close(done_w)  # end-of-file on done_r once the child is gone
        self.pid, self._w, self.done = pid, w, done_r

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
            os.close(self.done)
            return False
        finally:
            os.close(self._w)


def _start(req: dict[str, Any], spare: _Spare | None) -> _Spare | None:
    """Hand ``req`` to ``spare`` (or to a newly forked child); that child, or None."""
    if spare is not None and spare.start(req):
        return spare
    fresh = _Spare()
    return fresh if fresh.start(req) else None


#: Children that reported done and were killed, not yet reaped (see :func:`_finish`).
_UNREAPED: list[int] = []


def reap() -> None:
    """Wait for the children :func:`_finish` killed after their done report (each is dying:
    this takes as long as the kernel needs to tear down its address space)."""
    while _UNREAPED:
        try:
            os.waitpid(_UNREAPED.pop(), 0)
        except ChildProcessError:
            pass


def _run_one(req: dict[str, Any], spare: _Spare | None = None) -> dict[str, Any]:
    if req.get("op") == "prebuild":
        return _prebuild(req, spare)
    t0 = time.monotonic()
    child = _start(req, spare)
    if child is None:
        return {"id": req["id"], "status": "error", "detail": "the compile child did not start"}
    return {"id": req["id"], **_finish(child, t0, float(req["limits"]["wall_s"]))}


def _prebuild(req: dict[str, Any], spare: _Spare | None) -> dict[str, Any]:
    """One child per job (``{"scratch"}``), all at once, under one wall-clock limit: the
    shares of a parallel cold compile (job i builds share (i, number of jobs)). Replies with
    each job's status, in order."""
    t0 = time.monotonic()
    children = []
    for i, job in enumerate(req["jobs"]):
        children.append(_start({**req, "op": "compile", "scratch": job["scratch"],
                                "share": [i, len(req["jobs"])]}, spare if i == 0 else None))
    wall = float(req["limits"]["wall_s"])
    jobs = [{"status": "error", "detail": "the compile child did not start"} if child is None
            else _finish(child, t0, wall) for child in children]
    return {"id": req["id"], "jobs": jobs}


def _finish(child: _Spare, t0: float, wall: float) -> dict[str, Any]:
    """Wait for ``child`` until ``t0 + wall``: its status, detail and seconds.

    A child that reports done (its ``result.json`` is complete) is killed with its process
    group at once and answered for with status ``done``; it is reaped later (:func:`reap`),
    so the teardown of its address space (several ms for a copy of the warm zygote) runs on
    another core while its caller reads the result.
    """
    pid = child.pid
    try:
        status = _wait(pid, t0 + wall, child.done)
    finally:
        os.close(child.done)
    if status is None:
        _kill_group(pid, child_too=True)
        os.waitpid(pid, 0)
        return {"status": "timeout", "detail": f"wall-clock limit {wall:g} s",
                "seconds": time.monotonic() - t0}
    out: dict[str, Any] = {"seconds": time.monotonic() - t0}
    if status == DONE:
        _kill_group(pid, child_too=True)  # the child and anything it left behind
        _UNREAPED.append(pid)
        out.update(status="done", detail="0")
        return out
    _kill_group(pid)  # anything the child left behind
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else str(sig)
        out.update(status="signal", detail=name)
    else:
        out.update(status="exit", detail=str(os.WEXITSTATUS(status)))
    return out


#: :func:`_wait`'s answer for a child that reported done (not a wait status).
DONE = -1


def _wait(pid: int, deadline: float, done: int | None = None) -> int | None:
    """The child's wait status, :data:`DONE` once it writes to the ``done`` pipe, or None once
    ``deadline`` (monotonic) passes first. Blocks on a pidfd where the kernel has them (Linux
    5.3) and on the done pipe, so the reply leaves as soon as the child is done or exits;
    else polls every 5 ms."""
    import select
    try:
        fd = os.pidfd_open(pid)
    except (AttributeError, OSError):
        fd = None
    try:
        while True:
            exited, status = os.waitpid(pid, os.WNOHANG)
            if exited:
                return status
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            watch = [x for x in (fd, done) if x is not None]
            ready = select.select(watch, [], [], left if fd is not None else min(0.005, left))[0]
            if done is not None and done in ready:
                if os.read(done, 1):
                    return DONE
                done = None  # end-of-file: the child died without a report; wait for its exit
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


#: Packages build123d imports at its own import but uses only to read or write files (DXF and
#: SVG, 3MF, glTF materials, STL clustering), on the network (an upload to an online viewer)
#: or in a notebook (pretty printing): a program has no file or network access, so the zygote
#: never loads them (about 0.3-0.8 s of its start-up; requests alone about 0.03 s).
UNUSED_IMPORTS: tuple[str, ...] = ("sklearn", "ezdxf", "svgpathtools", "lib3mf", "threejs_materials",
                                   "IPython", "requests")


def _stub_unused_imports() -> None:
    """Stand in for :data:`UNUSED_IMPORTS` and their submodules (before build123d is imported):
    any attribute of a stand-in module is a stand-in class whose attributes are stand-ins too
    (build123d reads some at import, ``ezdxf.units.MM`` in a class body), and calling one raises
    ``ImportError`` naming it, so a use says what is missing instead of misbehaving."""
    if "build123d" in sys.modules or any(isinstance(f, _Unused) for f in sys.meta_path):
        return
    sys.meta_path.insert(0, _Unused())


class _StandInType(type):
    def __getattr__(cls, attr: str) -> Any:
        return _member(cls.__qualname__, attr)


def _member(owner: str, attr: str) -> type:
    """The stand-in for ``owner.attr`` (dunder lookups are left to Python's defaults)."""
    if attr.startswith("__"):
        raise AttributeError(attr)
    return _stand_in(f"{owner}.{attr}")


def _stand_in(name: str) -> type:
    def refuse(*args: Any, **kwargs: Any) -> None:
        raise ImportError(f"{name} is not loaded in the compile worker (programs neither read nor "
                          f"write files; build123d needs it only for that)")
    return _StandInType(name.rsplit(".", 1)[-1], (), {"__init__": refuse, "__qualname__": name})


class _Unused(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """The import finder and loader of :func:`_stub_unused_imports`."""

    def find_spec(self, name: str, path: Any, target: Any = None) -> Any:
        if name.split(".")[0] not in UNUSED_IMPORTS:
            return None
        return importlib.machinery.ModuleSpec(name, self, is_package=True)

    def create_module(self, spec: Any) -> Any:
        import types
        module = types.ModuleType(spec.name)
        module.__path__ = []  # a package: its submodules come here too
        module.__getattr__ = functools.partial(_member, spec.name)  # type: ignore[method-assign]  # PEP 562
        return module

    def exec_module(self, module: Any) -> None:
        """Nothing to run: every attribute is a stand-in."""


def main() -> None:
    import gc
    # no collections while the zygote imports (about 0.2 s of its 1.2 s start here): the
    # imports make objects, not garbage, and what they do leave (about 1,300 unreachable
    # objects, measured) is frozen with the rest below rather than collected for 0.1 s more
    gc.disable()
    _stub_unused_imports()
    import build123d  # noqa: F401 - the whole point: pay the import once

    from .. import kernel  # noqa: F401 - imported once in the zygote, inherited by every child
    from ..mates import features, joints  # noqa: F401 - every compile uses them: load them once
    from . import guards, runtime  # noqa: F401 - imported once in the zygote, inherited by every child
    guards.harden_kernel()
    guards.baseline()
    from . import caps, isolation, trust  # noqa: F401 - imported before any child drops privileges
    isolation.preload()
    # everything imported so far lives as long as the zygote: out of the cyclic collector's
    # reach, so a child's collections never walk it (and never copy its pages on write)
    gc.freeze()
    gc.enable()
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
        except Exception as exc:  # noqa: BLE001 - one bad request must not end the zygote
            reply = {"id": req.get("id"), "status": "error", "detail": str(exc)}
        out.write(json.dumps(reply) + "\n")
        out.flush()
        reap()  # after the reply: a dying child's teardown is off the caller's path
        try:
            spare = _Spare()  # the next compile's child, forked after this reply left
        except OSError:
            spare = None


if __name__ == "__main__":
    main()
