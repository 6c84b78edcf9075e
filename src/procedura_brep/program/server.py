"""A warm compile worker that later command-line calls reuse: ``procedura-brep serve``.

(The command line also hands it whole commands to run in its forks, a request this module
leaves to a handler its caller passes, :mod:`procedura_brep.served`; what follows is the
compile worker's side.)

A cold command pays for starting the compile worker (a Python process importing build123d, 2-3
s here) before its first compile. ``serve`` keeps one :class:`~.sandbox.Worker` warm behind a
Unix socket; :func:`~.sandbox.default_worker` of any later process connects to it when it is
running and answers the handshake (:func:`~.sandbox.connect_server`, the client side), and
starts its own worker otherwise. This module is the server side and the wire; it knows no
worker class (the caller hands :func:`serve` its worker). The server is never required and
never stale:

- the handshake compares :func:`code_digest` (this package's source files, the Python
  executable and version, build123d's version): a server started from other code, or before an
  edit of it, is ignored (and says so in the log), so a changed install is never served by an
  old process;
- a server that is gone, or does not answer within :data:`CONNECT_TIMEOUT_S`, is ignored;
- ``PROCEDURA_BREP_SERVER=off`` never connects (the test suite sets it).

Security is the local worker's: every program still runs in a forked, limited, sandboxed
child of the server's zygote (:mod:`.worker`), and the client validates the child's reply
itself (:mod:`.trust`), reading the result from its own scratch folder. The socket lives in a
folder only its user can enter (mode 0700). The server serialises compiles through its one
zygote; a client that goes away mid-compile leaves the server alive (the compile ends within
the sandbox's time limit and its result is dropped). Its part cache lives as long as it does,
so a program built once recompiles only the parts that changed, from any command.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import socket
import sys
import tempfile
import threading
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

from ..errors import CompileError

log = logging.getLogger(__name__)

#: How long a client waits to connect and for the handshake before starting its own worker.
CONNECT_TIMEOUT_S = 2.0
#: The environment switch that keeps a process off any server (``off``).
ENV_SWITCH = "PROCEDURA_BREP_SERVER"
#: The environment variable naming the socket (default: :func:`socket_path`).
ENV_SOCKET = "PROCEDURA_BREP_SOCKET"
#: File descriptors one message may carry (a served command's stdin, stdout and stderr).
MAX_FDS = 3

#: A request the caller of :func:`serve` answers itself: ``handler(conn, message, fds)`` owns
#: the file descriptors the message carried and answers on ``conn``; the connection closes after.
Handler = Callable[[socket.socket, dict[str, Any], list[int]], None]


def socket_path() -> Path:
    """``$PROCEDURA_BREP_SOCKET``, else ``$XDG_RUNTIME_DIR/procedura-brep/worker.sock``, else
    ``<tmp>/procedura-brep-<uid>/worker.sock``."""
    if os.environ.get(ENV_SOCKET):
        return Path(os.environ[ENV_SOCKET])
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = (Path(runtime) / "procedura-brep" if runtime
            else Path(tempfile.gettempdir()) / f"procedura-brep-{os.getuid()}")
    return base / "worker.sock"


@lru_cache(maxsize=1)
def code_digest() -> str:
    """sha256 over this package's ``.py`` files (path and bytes), the environment (``sys.prefix``,
    the real interpreter and its version) and build123d's installed version: what a server must
    share with its client."""
    from importlib import metadata
    h = hashlib.sha256()
    root = Path(__file__).resolve().parent.parent
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    try:
        b3d = metadata.version("build123d")
    except metadata.PackageNotFoundError:
        b3d = "none"
    h.update(f"{sys.prefix}\0{os.path.realpath(sys.executable)}\0{sys.version}\0{b3d}".encode())
    return h.hexdigest()


def _send(conn: socket.socket, obj: dict[str, Any]) -> None:
    conn.sendall((json.dumps(obj) + "\n").encode())


class _Lines:
    """Newline-delimited JSON over one connected socket; file descriptors a message carries
    (``SCM_RIGHTS``, at most :data:`MAX_FDS` a read) collect in :attr:`fds`, which the reader
    owns and closes."""

    def __init__(self, conn: socket.socket) -> None:
        self.conn, self.buf = conn, b""
        self.fds: list[int] = []

    def read(self) -> dict[str, Any] | None:
        while b"\n" not in self.buf:
            chunk, fds, _, _ = socket.recv_fds(self.conn, 65536, MAX_FDS)
            self.fds += fds
            if not chunk:
                return None
            self.buf += chunk
        line, _, self.buf = self.buf.partition(b"\n")
        try:
            obj = json.loads(line)
        except ValueError:
            return {}
        return obj if isinstance(obj, dict) else {}


def serve(worker: Any, path: Path | None = None, *, ready: Any = None,
          handlers: dict[str, Handler] | None = None) -> None:
    """Serve ``worker`` (a :class:`~.sandbox.Worker`, closed at the end) warm on the Unix socket
    ``path`` until interrupted (Ctrl-C, SIGTERM).

    Args:
        worker: the worker whose zygote answers the clients.
        path: the socket (default :func:`socket_path`); its folder is made mode 0700.
        ready: called with the path once the worker is warm and the socket listens.
        handlers: further requests by ``op``, answered by the caller (the command line's
            served commands, :mod:`procedura_brep.served`); each after the client's handshake.

    Raises:
        CompileError: the worker does not start (build123d missing).
        OSError: another server answers at ``path`` already, or the socket cannot be made.
    """
    path = Path(path or socket_path())
    path.parent.mkdir(parents=True, exist_ok=True)
    os.chmod(path.parent, 0o700)
    if path.exists():
        if _alive(path):
            raise OSError(f"a server already answers at {path}")
        path.unlink()
    worker.wait_ready()  # warm before the first client: that is the point
    srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        srv.bind(str(path))
        os.chmod(path, 0o600)
        srv.listen(16)
        log.info("warm worker listening on %s (pid %d)", path, os.getpid())
        if ready is not None:
            ready(path)
        while True:
            conn, _ = srv.accept()
            threading.Thread(target=_client, args=(conn, worker, handlers or {}), daemon=True).start()
    finally:
        srv.close()
        try:
            path.unlink()
        except OSError:
            pass
        worker.close()


def _close_fds(fds: list[int]) -> None:
    for fd in fds:
        try:
            os.close(fd)
        except OSError:
            pass


def _alive(path: Path) -> bool:
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
            s.settimeout(CONNECT_TIMEOUT_S)
            s.connect(str(path))
            return True
    except OSError:
        return False


def _client(conn: socket.socket, worker: Any, handlers: dict[str, Handler]) -> None:
    """One client connection: a handshake, then zygote requests forwarded one at a time, or one
    request of ``handlers`` (which ends the connection)."""
    lines = _Lines(conn)
    greeted = False
    try:
        while True:
            msg = lines.read()
            fds, lines.fds = lines.fds, []
            if msg is None:
                _close_fds(fds)
                return
            op = msg.get("op")
            if op in handlers and greeted:
                handlers[op](conn, msg, fds)  # it owns the descriptors now
                return
            _close_fds(fds)  # none expected
            if op == "hello":
                greeted = True
                _send(conn, {"digest": code_digest(), "cache_dir": worker.cache_dir, "pid": os.getpid()})
            elif op == "zygote" and isinstance(msg.get("req"), dict):
                try:
                    reply = worker.relay(msg["req"])
                except CompileError as exc:  # the zygote died: it restarts on the next request
                    reply = {"id": msg["req"].get("id"), "status": "error", "detail": str(exc)}
                _send(conn, {"reply": reply})
            else:
                _send(conn, {"error": f"unknown request {op!r}"})
    except OSError:  # the client went away: its result, if any, is dropped
        return
    finally:
        conn.close()
