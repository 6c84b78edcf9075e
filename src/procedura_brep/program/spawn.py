"""The compile worker's process: its environment, its start, and an early start for a cold
``build`` (standard library only, so the entry point can call it before anything else).

A cold ``build`` waits about 1 s for the worker to import build123d. The command line's own
start (its imports and argument parsing, about 0.1 s) can run beside that on a second core:
:func:`start_early` starts the worker first thing, and :func:`procedura_brep.program.sandbox.default_worker`
adopts it (:func:`take_early`). An early worker nobody adopts (the command failed before it
compiled, or was interrupted) is killed at exit or on the interrupt; one that outlives its
parent anyway ends at its standard input's end of file.
"""

from __future__ import annotations

import atexit
import os
import re
import signal
import subprocess
import sys
import tempfile

#: The only environment variables the worker inherits (exact names or, ending in ``*``,
#: prefixes): locale, paths, the Python path, headless-rendering switches and this tool's own
#: non-secret settings. Everything else (API keys, ``DATABASE_URL``, ``GH_PAT`` ...) stays out.
ENV_ALLOW = ("PATH", "HOME", "USER", "LOGNAME", "LANG", "LANGUAGE", "LC_*", "TZ", "TMPDIR",
             "TEMP", "TMP", "PYTHONPATH", "PYTHONHASHSEED", "PYTHONDONTWRITEBYTECODE",
             "VIRTUAL_ENV", "CONDA_PREFIX", "LD_LIBRARY_PATH", "MUJOCO_GL", "PYOPENGL_PLATFORM",
             "EGL_PLATFORM", "MESA_*", "LIBGL_*", "GALLIUM_DRIVER", "DISPLAY", "XDG_RUNTIME_DIR",
             "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "CASROOT", "CSF_*",
             "FONTCONFIG_*", "PROCEDURA_BREP_NO_NETWORK", "PROCEDURA_UPDATE_GOLDEN")
#: Even an allowlisted name is dropped when it looks like a credential (``PROCEDURA_*_KEY``).
SECRET_RE = re.compile(r"KEY|TOKEN|SECRET|PASSWORD|PASSWD|CREDENTIAL|AUTH|COOKIE|SESSION|PAT\b", re.I)

_EARLY: subprocess.Popen[str] | None = None


def _allowed(name: str) -> bool:
    if SECRET_RE.search(name):
        return False
    return any(name == a or (a.endswith("*") and name.startswith(a[:-1])) for a in ENV_ALLOW)


def clean_env() -> dict[str, str]:
    """The worker's environment: only the allowlisted variables (:data:`ENV_ALLOW`)."""
    return {k: v for k, v in os.environ.items() if _allowed(k)}


def worker_process() -> subprocess.Popen[str]:
    """Start ``python -P -m procedura_brep.program.worker`` (``-P``: its start folder, the temp
    folder, is not on the import path) with :func:`clean_env`, pipes to talk to it, and no
    standard error."""
    return subprocess.Popen([sys.executable, "-P", "-m", "procedura_brep.program.worker"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True, env=clean_env(),
                            cwd=tempfile.gettempdir())


def start_early() -> None:
    """Start the worker process now, for :func:`take_early`; with SIGINT blocked in it, as
    :func:`procedura_brep.interrupt.children_ignore_sigint` starts it (the terminal's Ctrl-C is
    the command line's to handle). A failure to start is left for the normal start to report.
    Main thread only."""
    global _EARLY
    if _EARLY is not None:
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        _EARLY = worker_process()
    except OSError:
        return
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
    atexit.register(_discard)
    from .. import interrupt
    interrupt.add_cleanup(_discard)  # a Ctrl-C ends the process without its atexit handlers


def take_early() -> subprocess.Popen[str] | None:
    """The worker :func:`start_early` started, if it is still running; it is the caller's from
    now on (None when there is none)."""
    global _EARLY
    proc, _EARLY = _EARLY, None
    if proc is not None and proc.poll() is not None:
        return None
    return proc


def _discard() -> None:
    """At exit: kill an early worker nobody took."""
    proc = take_early()
    if proc is not None:
        proc.kill()
        proc.wait()


__all__ = ["ENV_ALLOW", "SECRET_RE", "clean_env", "start_early", "take_early", "worker_process"]
