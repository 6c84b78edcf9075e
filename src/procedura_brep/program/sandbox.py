"""The sandboxed compile, parent side: a warm worker process and the call that uses it.

:class:`Worker` starts ``python -m procedura_brep.program.worker`` once (it imports build123d,
~3 s) with an environment stripped of credentials, and sends it one request per compile. The
worker forks a fresh child per compile with CPU, memory, file-size and open-file limits, a
scratch directory and an empty environment; a crash, hang or memory blow-up kills only that
child and comes back as a :class:`CompileError` with a finding that says what happened.
"""

from __future__ import annotations

import atexit
import itertools
import json
import logging
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
from dataclasses import asdict, dataclass, replace
from typing import Any

from ..config import SANDBOX, SandboxLimits
from ..errors import CompileError
from .model import CompiledModel, Finding, from_json

log = logging.getLogger(__name__)
SECRET_RE = re.compile(r"KEY|TOKEN|SECRET|PASSWORD|CREDENTIAL|AUTH|COOKIE|SESSION", re.I)
SIGNAL_MEANING = {
    "SIGXCPU": "exceeded its CPU time limit", "SIGKILL": "was killed (CPU or memory limit)",
    "SIGSEGV": "crashed the CAD kernel (segmentation fault)", "SIGABRT": "aborted in the CAD kernel",
    "SIGXFSZ": "exceeded its file-size limit", "SIGBUS": "crashed (bus error)",
}


def clean_env() -> dict[str, str]:
    """The current environment minus anything that looks like a credential."""
    return {k: v for k, v in os.environ.items() if not SECRET_RE.search(k)}


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
        self.cache_dir = str(cache_dir) if cache_dir else tempfile.mkdtemp(prefix="procedura-parts-")
        self._proc: subprocess.Popen[str] | None = None
        self._lock = threading.Lock()
        self._ids = itertools.count(1)

    def start(self) -> "Worker":
        """Start the worker process (idempotent); returns immediately, ready on first use."""
        if self._proc is None or self._proc.poll() is not None:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "procedura_brep.program.worker"], stdin=subprocess.PIPE,
                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=clean_env(),
                cwd=tempfile.gettempdir())
            self._ready = False
        return self

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
        :class:`CompileError` when the child was killed, crashed or timed out.
        """
        with self._lock:
            proc = self._ensure_ready()
            scratch = tempfile.mkdtemp(prefix="procedura-compile-")
            try:
                req = {"id": next(self._ids), "source": source, "name": options.name,
                       "scratch": scratch, "limits": asdict(options.limits),
                       "cache_dir": self.cache_dir if options.cache else None}
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
                reply = json.loads(line)
                model = _result(reply, scratch, options.limits)
                if options.cache and model.ok:
                    from .cache import store_model
                    store_model(self.cache_dir, model)
                return model
            finally:
                shutil.rmtree(scratch, ignore_errors=True)


def _result(reply: dict[str, Any], scratch: str, limits: SandboxLimits) -> CompiledModel:
    path = os.path.join(scratch, "result.json")
    status, detail = reply.get("status"), reply.get("detail")
    if status == "timeout":
        f = Finding("timeout", f"the program did not finish within the wall-clock limit "
                               f"({limits.wall_s:g} s)", limit=limits.wall_s)
        raise CompileError(f.message, [f])
    if os.path.exists(path):
        with open(path, encoding="utf-8") as fh:
            payload = json.load(fh)
        if "fatal" in payload:
            f = Finding(**payload["fatal"])
            raise CompileError(f.message, [f])
        return from_json(payload)
    if status == "signal":
        meaning = SIGNAL_MEANING.get(str(detail), f"was killed by {detail}")
        if detail in ("SIGXCPU", "SIGKILL"):
            meaning += f" (CPU limit {limits.cpu_s} s, memory limit {limits.address_space_bytes // 2**20} MiB)"
        f = Finding("killed", f"the program {meaning}")
        raise CompileError(f.message, [f])
    f = Finding("crash", f"the compile child exited without a result ({status} {detail})")
    raise CompileError(f.message, [f])


_DEFAULT: Worker | None = None


def default_worker() -> Worker:
    """The process-wide worker, started on first use and stopped at exit."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = Worker()
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


__all__ = ["CompileOptions", "Worker", "compile_source", "default_worker", "clean_env", "replace"]


def kill_default_worker() -> None:
    """Ctrl-C path: end the default worker and every compile child it forked, now.

    Each compile child leads its own session, so neither the terminal's SIGINT nor the worker's
    death reaches it: the worker is stopped (so it forks no more), its children's process
    groups are killed, then the worker. Safe to call from any thread.
    """
    import signal
    w = _DEFAULT
    proc = w._proc if w is not None else None
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
