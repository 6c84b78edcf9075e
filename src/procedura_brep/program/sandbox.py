"""The sandboxed compile, parent side: a warm worker process and the call that uses it.

:class:`Worker` starts ``python -m procedura_brep.program.worker`` once (it imports build123d,
~3 s) with an allowlisted environment (:data:`.spawn.ENV_ALLOW`: no credentials can reach it), and
sends it one request per compile. The worker forks a fresh child per compile with CPU, memory,
file-size and open-file limits, a scratch directory and an empty environment; a crash, hang or
memory blow-up kills only that child and comes back as a :class:`CompileError` with a finding
that says what happened. The child's reply is untrusted: :mod:`.trust` validates every field.

Temporary folders are named ``procedura-parts-<pid>-*`` / ``procedura-compile-<pid>-*`` after
the process that owns them; a new worker removes those whose owner is dead (a killed parent
cannot clean up after itself).
"""

from __future__ import annotations

import atexit
import itertools
import json
import logging
import os
import re
import shutil
import stat
import subprocess
import tempfile
import threading
from dataclasses import asdict, dataclass, replace
from typing import Any

from ..config import SANDBOX, SandboxLimits
from ..errors import CompileError, ProceduraError, ProgramFormatError
from .model import CompiledModel, Finding
from .spawn import clean_env, take_early, worker_process
from .trust import ResultError, finding_from_json, model_from_json

log = logging.getLogger(__name__)
TEMP_PREFIXES = ("procedura-parts-", "procedura-compile-")
SIGNAL_MEANING = {
    "SIGXCPU": "exceeded its CPU time limit", "SIGKILL": "was killed (CPU or memory limit)",
    "SIGSEGV": "crashed the CAD kernel (segmentation fault)", "SIGABRT": "aborted in the CAD kernel",
    "SIGXFSZ": "exceeded its file-size limit", "SIGBUS": "crashed (bus error)",
}


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_stale_temp(folder: str | None = None) -> list[str]:
    """Remove ``procedura-parts-<pid>-*`` / ``procedura-compile-<pid>-*`` folders whose owning
    process is dead; returns what was removed. Folders of live processes, and names without
    a pid, are left alone."""
    folder = folder or tempfile.gettempdir()
    removed: list[str] = []
    try:
        names = os.listdir(folder)
    except OSError:
        return removed
    for entry in names:
        prefix = next((p for p in TEMP_PREFIXES if entry.startswith(p)), None)
        if prefix is None:
            continue
        pid_text = entry[len(prefix):].split("-", 1)[0]
        if not pid_text.isdigit() or int(pid_text) == os.getpid() or _pid_alive(int(pid_text)):
            continue
        path = os.path.join(folder, entry)
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


@dataclass(frozen=True)
class CompileOptions:
    """Per-call settings: the program's name and the sandbox limits."""

    name: str = "model"
    limits: SandboxLimits = SANDBOX
    cache: bool = True


class Worker:
    """A warm zygote that compiles programs in forked, limited children. Thread-safe."""

    def __init__(self, cache_dir: str | os.PathLike[str] | None = None) -> None:
        """Args:
            cache_dir: the per-part cache folder (default: a private temp folder per worker).
        """
        self._own_cache = cache_dir is None
        try:
            clean_stale_temp()
        except OSError:  # pragma: no cover - a best effort
            log.debug("stale temp cleanup failed", exc_info=True)
        self.cache_dir = str(cache_dir) if cache_dir else tempfile.mkdtemp(
            prefix=f"{TEMP_PREFIXES[0]}{os.getpid()}-")
        self._proc: subprocess.Popen[str] | None = None
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._prebuilt = False  # the first compile of a worker may be shared out (prebuild)
        #: the OS layers the last compile child reported (``applied: ...; not applied: ...``)
        self.isolation = "unknown (nothing compiled yet)"

    def start(self) -> "Worker":
        """Start the worker process (idempotent); returns immediately, ready on first use."""
        if self._proc is None or self._proc.poll() is not None:
            self._proc = worker_process()
            self._ready = False
        return self

    def adopt(self, proc: subprocess.Popen[str]) -> None:
        """Take ``proc``, a worker process started elsewhere (:func:`.spawn.start_early`), as
        this worker's process (it must have no running one of its own)."""
        assert self._proc is None or self._proc.poll() is not None, "a worker runs already"
        self._proc, self._ready = proc, False

    def _ensure_ready(self) -> subprocess.Popen[str]:
        self.start()
        os.makedirs(self.cache_dir, exist_ok=True)  # (re)made lazily after close()
        os.chmod(self.cache_dir, 0o755)  # the sandbox child may run as an unprivileged user
        assert self._proc is not None and self._proc.stdout is not None
        if not self._ready:
            line = self._proc.stdout.readline()
            if not line:
                raise CompileError("the compile worker failed to start (is build123d installed? "
                                   "run `procedura-brep doctor`)")
            self._ready = True
        return self._proc

    def wait_ready(self) -> None:
        """Start the worker and wait until it has imported build123d (a warm server's start)."""
        with self._lock:
            self._ensure_ready()

    def relay(self, req: dict[str, Any]) -> dict[str, Any]:
        """One raw request to the zygote and its reply (a warm server forwarding a client's;
        the client reads and validates the result itself). Raises :class:`CompileError` when
        the worker died (it restarts on the next request)."""
        with self._lock:
            return self._ask(self._ensure_ready(), req)

    def close(self) -> None:
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._proc.wait()
        self._proc = None
        if self._own_cache:
            shutil.rmtree(self.cache_dir, ignore_errors=True)

    def compile(self, source: str, options: CompileOptions = CompileOptions()) -> CompiledModel:
        """Compile ``source`` in a fresh sandboxed child.

        Returns the model (whose ``findings`` may hold part or mate errors). Raises
        :class:`CompileError` when the child was killed, crashed or timed out. A worker's
        first compile with the cache on is shared out among several children first
        (:meth:`_prebuild`): a cold build uses every core.
        """
        refuse_oversized(source, options.limits)
        with self._lock:
            proc = self._ensure_ready()
            built = 0  # parts built rather than loaded from the store, over every child
            if options.cache and not self._prebuilt:
                self._prebuilt = True
                built = self._prebuild(proc, source, options)
            scratch = tempfile.mkdtemp(prefix=f"{TEMP_PREFIXES[1]}{os.getpid()}-")
            try:
                reply = self._ask(proc, {
                    "id": next(self._ids), "source": source, "name": options.name,
                    "scratch": scratch, "limits": asdict(options.limits),
                    "cache_dir": self.cache_dir if options.cache else None})
                self.isolation = _isolation_line(scratch)
                log.debug("compile child isolation: %s", self.isolation)
                model = _result(reply if isinstance(reply, dict) else {}, scratch, options.limits,
                                name=options.name,
                                cache_dir=self.cache_dir if options.cache else None)
                model.isolation = self.isolation
                model.timings["parts_built"] = float(  # twins took a solid without running
                    built + len(model.parts) - int(model.timings.get("cache_hits", 0))
                    - int(model.timings.get("twins", 0)))
                if options.cache and model.ok:
                    from .cache import store_model
                    store_model(self.cache_dir, model, options.limits)
                return model
            finally:
                shutil.rmtree(scratch, ignore_errors=True)

    def _ask(self, proc: subprocess.Popen[str], req: dict[str, Any]) -> dict[str, Any]:
        """Send one request to the zygote and read its one-line reply ({} if not an object)."""
        assert proc.stdin is not None and proc.stdout is not None
        try:
            proc.stdin.write(json.dumps(req) + "\n")
            proc.stdin.flush()
            line = proc.stdout.readline()
        except (BrokenPipeError, OSError):
            line = ""
        if not line:
            self.close()
            raise CompileError("the compile worker died; it will be restarted on the next call")
        try:
            reply = json.loads(line)
        except ValueError:
            reply = {}
        return reply if isinstance(reply, dict) else {}

    def _prebuild(self, proc: subprocess.Popen[str], source: str, options: CompileOptions) -> int:
        """A parallel cold compile: a worker's first compile of a program of at least
        ``2 * PREBUILD_SHARE`` parts runs first in up to :data:`PREBUILD_JOBS` children at
        once (one per core), each building the final solids of its share of the parts for the
        part cache (dealt round robin in plan order among the parts the store lacks, one part
        per key: twins are built once); the compile proper then finds every part there. The
        shares are gated by nothing: a part that fails in its share is not stored and fails
        again, with its finding, in the compile proper. A share that is killed or
        times out is the compile's error (the compile proper would end the same way).
        Returns how many parts the shares built (not loaded from the store)."""
        from .cache import store_model
        from .splice import program_parts
        try:
            names = program_parts(source)
        except (ProceduraError, SyntaxError, ValueError):
            return 0  # the compile proper reports it
        jobs = min(PREBUILD_JOBS, os.cpu_count() or 1, len(names) // PREBUILD_SHARE)
        if jobs < 2:
            return 0
        built = 0
        scratches = [tempfile.mkdtemp(prefix=f"{TEMP_PREFIXES[1]}{os.getpid()}-") for _ in range(jobs)]
        try:
            reply = self._ask(proc, {
                "id": next(self._ids), "op": "prebuild", "source": source, "name": options.name,
                "limits": asdict(options.limits), "cache_dir": self.cache_dir,
                "jobs": [{"scratch": s} for s in scratches]})
            rows = reply.get("jobs")
            for i, scratch in enumerate(scratches):
                row = rows[i] if isinstance(rows, list) and i < len(rows) and isinstance(rows[i], dict) else {}
                share = _result(row, scratch, options.limits, name=options.name, cache_dir=self.cache_dir)
                built += len(share.parts)  # a share returns only the parts it built
                store_model(self.cache_dir, share, options.limits)
        finally:
            for scratch in scratches:
                shutil.rmtree(scratch, ignore_errors=True)
        return built


#: A worker's first compile is shared out among at most this many children at once ...
PREBUILD_JOBS = 4
#: ... each with at least this many parts (so a program needs twice as many to be shared).
PREBUILD_SHARE = 3


def _isolation_line(scratch: str) -> str:
    """``applied: ...; not applied: ...`` from the head of the child's ``child.log`` (written
    before any program code runs; bounded, printable ASCII only)."""
    try:
        with open(os.path.join(scratch, "child.log"), "rb") as fh:
            head = fh.read(512).decode("ascii", "replace").splitlines()[:2]
    except OSError:
        return "unknown (no child.log)"
    fields = dict(ln.split(":", 1) for ln in head if ":" in ln)
    clean = {k: re.sub(r"[^a-z_ ]", "", v).strip() or "-" for k, v in fields.items()}
    return f"applied: {clean.get('isolation', '-')}; not applied: {clean.get('not applied', '-')}"


def refuse_oversized(source: str, limits: SandboxLimits = SANDBOX) -> None:
    """Raise :class:`CompileError` (finding ``too-large``, naming the cap) for a program over
    ``limits.source_bytes``: call it before paying for anything else."""
    from .sections import check_size
    try:
        check_size(source, limit=limits.source_bytes)
    except ProgramFormatError as exc:
        f = Finding("too-large", str(exc))
        raise CompileError(f.message, [f]) from None


def _read_result(path: str, limits: SandboxLimits) -> Any:
    """The child's ``result.json``: a regular file (not a link), bounded in size, valid JSON."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    with os.fdopen(fd, "rb") as fh:
        if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
            raise ResultError("the compile child returned an invalid result: result.json is not a file")
        data = fh.read(limits.result_bytes + 1)
    if len(data) > limits.result_bytes:
        raise ResultError(f"the compile child returned an invalid result: result.json is over "
                          f"{limits.result_bytes} bytes (config.SANDBOX.result_bytes)")
    try:
        return json.loads(data)
    except (ValueError, RecursionError):
        raise ResultError("the compile child returned an invalid result: result.json is not "
                          "valid JSON") from None


def _result(reply: dict[str, Any], scratch: str, limits: SandboxLimits, *,
            name: str | None = None, cache_dir: str | None = None) -> CompiledModel:
    """The model from the child's reply and ``result.json``, or a :class:`CompileError` with a
    finding (a killed, timed-out or crashed child, or a result that breaks the schema)."""
    path = os.path.join(scratch, "result.json")
    status, detail = reply.get("status"), reply.get("detail")
    if status == "timeout":
        f = Finding("timeout", f"the program did not finish within the wall-clock limit "
                               f"({limits.wall_s:g} s)", limit=limits.wall_s)
        raise CompileError(f.message, [f])
    if os.path.lexists(path):
        try:
            payload = _read_result(path, limits)
            if isinstance(payload, dict) and "fatal" in payload:
                f = finding_from_json(payload["fatal"], "fatal")
                raise CompileError(f.message, [f])
            return model_from_json(payload, name=name, cache_dir=cache_dir)
        except (ResultError, OSError) as exc:
            f = Finding("bad-result", str(exc))
            raise CompileError(f.message, [f]) from None
    if status == "signal":
        detail = str(detail)[:40]
        meaning = SIGNAL_MEANING.get(detail, f"was killed by {detail}")
        if detail in ("SIGXCPU", "SIGKILL"):
            meaning += f" (CPU limit {limits.cpu_s} s, memory limit {limits.address_space_bytes // 2**20} MiB)"
        f = Finding("killed", f"the program {meaning}")
        raise CompileError(f.message, [f])
    f = Finding("crash", f"the compile child exited without a result ({str(status)[:40]} {str(detail)[:80]})")
    raise CompileError(f.message, [f])


class RemoteWorker(Worker):
    """A :class:`Worker` whose zygote is a warm server's (``procedura-brep serve``,
    :mod:`.server`): requests go over its socket, and the result is read and validated here,
    from this process's own scratch folder, as with a local worker."""

    def __init__(self, conn: Any, cache_dir: str, path: Any) -> None:
        super().__init__(cache_dir=cache_dir)
        self._own_cache = False  # the server's, for as long as it runs
        from .server import _Lines
        self._conn, self._lines, self.path = conn, _Lines(conn), path

    def start(self) -> "RemoteWorker":
        return self

    def _ensure_ready(self) -> Any:
        if self._conn is None:
            raise CompileError(f"the warm worker at {self.path} went away; run the command "
                               "again (it starts its own worker when no server answers)")
        return self._conn

    def _ask(self, proc: Any, req: dict[str, Any]) -> dict[str, Any]:
        from .server import _send
        try:
            _send(proc, {"op": "zygote", "req": req})
            msg = self._lines.read()
        except OSError:
            msg = None
        if msg is None:
            self.close()
            raise CompileError(f"the warm worker at {self.path} went away; run the command "
                               "again (it starts its own worker when no server answers)")
        reply = msg.get("reply")
        return reply if isinstance(reply, dict) else {}

    def close(self) -> None:
        if self._conn is not None:
            try:
                self._conn.close()
            except OSError:
                pass
        self._conn = None


def connect_server(path: Any = None) -> "RemoteWorker | None":
    """A :class:`RemoteWorker` on the server at ``path`` when one answers the handshake with
    this code's digest; None otherwise (no server, another version, switched off)."""
    import socket
    from pathlib import Path

    from .server import CONNECT_TIMEOUT_S, ENV_SWITCH, _Lines, _send, code_digest, socket_path
    if os.environ.get(ENV_SWITCH, "").lower() in ("off", "0", "no", "false"):
        return None
    path = Path(path or socket_path())
    if not path.exists():
        return None
    try:
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        conn.settimeout(CONNECT_TIMEOUT_S)
        conn.connect(str(path))
        _send(conn, {"op": "hello"})
        hello = _Lines(conn).read() or {}
    except OSError as exc:
        log.debug("no warm worker at %s (%s)", path, exc)
        return None
    if hello.get("digest") != code_digest() or not isinstance(hello.get("cache_dir"), str):
        conn.close()
        log.info("ignoring the warm worker at %s: it runs other code (restart `procedura-brep "
                 "serve`)", path)
        return None
    conn.settimeout(None)
    log.info("using the warm worker at %s (pid %s)", path, hello.get("pid"))
    return RemoteWorker(conn, hello["cache_dir"], path)


_DEFAULT: Worker | None = None


def default_worker() -> Worker:
    """The process-wide worker: a running warm server's when one answers with this code
    (:func:`connect_server`), else a local one on the persistent part store
    (:func:`.cache.persistent_dir`), in the process the entry point started early when there
    is one (:func:`.spawn.start_early`), else started on first use; stopped at exit."""
    global _DEFAULT
    if _DEFAULT is None:
        early = take_early()  # the entry point's, started beside the command line's start
        if (server := connect_server()) is not None:
            _DEFAULT = server
            if early is not None:
                early.kill()
                early.wait()
        else:
            from .cache import persistent_dir
            _DEFAULT = Worker(cache_dir=persistent_dir())
            if early is not None:
                _DEFAULT.adopt(early)
        atexit.register(_DEFAULT.close)
    return _DEFAULT.start()


def compile_source(source: str, *, name: str = "model", limits: SandboxLimits | None = None,
                   worker: Worker | None = None) -> CompiledModel:
    """Compile a program text in the sandbox and return the :class:`CompiledModel`.

    Example:
        >>> model = compile_source(open("golden/arm/program.py").read(), name="arm")  # doctest: +SKIP
        >>> [p.name for p in model.parts][:2]                                          # doctest: +SKIP
        ['base', 'turret']
    """
    opts = CompileOptions(name=name, limits=limits or SANDBOX)
    return (worker or default_worker()).compile(source, opts)


__all__ = ["CompileOptions", "RemoteWorker", "Worker", "compile_source", "connect_server", "default_worker",
           "clean_env",
           "clean_stale_temp", "kill_default_worker", "refuse_oversized", "replace"]


def kill_default_worker() -> None:
    """Ctrl-C path: end the default worker and every compile child it forked, now.

    Each compile child leads its own session, so neither the terminal's SIGINT nor the worker's
    death reaches it: the worker is stopped (so it forks no more), its children's process
    groups are killed, then the worker. Safe to call from any thread.
    """
    import signal
    w = _DEFAULT
    if w is None:
        return
    proc = w._proc
    if proc is None or proc.poll() is not None:
        return
    try:
        os.kill(proc.pid, signal.SIGSTOP)
    except OSError:
        return
    for pid in _child_pids(proc.pid):
        for kill in (os.killpg, os.kill):
            try:
                kill(pid, signal.SIGKILL)
            except OSError:
                pass
    w.close()


def _child_pids(parent: int) -> list[int]:
    """The pids whose parent is ``parent`` (from /proc)."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat[stat.rfind(b")") + 2:].split()
        if len(fields) > 1 and int(fields[1]) == parent:
            out.append(int(entry))
    return out
