"""Commands in a warm server's fork: the client (:func:`served`) and the server's side
(:func:`run_served`); :mod:`procedura_brep.entry` is the console entry point that uses them.

A cold ``procedura-brep build`` spends most of its time importing: build123d in the compile
worker, OCP, the gates and the exporters in this process (about 1.4 s of a 2 s lamp build
here). ``procedura-brep serve`` does those imports once; then this module, which imports only
the standard library and :mod:`procedura_brep.program.server`, hands a command of
:data:`SERVED` to it: its arguments, working folder, environment, umask and the terminal's
stdin, stdout and stderr (the descriptors themselves, ``SCM_RIGHTS``). The server forks a child
that becomes this command (:func:`run_served`): it takes the descriptors as its 0, 1 and 2, the
folder, the environment and the umask, runs the command line's ``main`` and reports the exit
status. Output, progress, colours and exit codes are the local run's, byte for byte, because
the same code runs; it only started warm. Programs still compile in the sandbox: the child is
a client of the server's zygote like any command.

Never required, never stale: the command runs here when ``PROCEDURA_BREP_SERVER=off``, when no
server answers, or when the server runs other code (:func:`~.program.server.code_digest`,
compared by both sides); the server says so before it forks, so nothing runs twice. Ctrl-C (and
SIGTERM, SIGHUP) reach the child: this process forwards them, and the child handles them as a
local run does (``report.json`` with status ``interrupted``, exit 130). A client that dies
leaves nothing running: the server interrupts its child when the connection drops, and a
server that dies takes its children with it (SIGTERM).

What the child cannot take from the client: its resource limits (``ulimit``) are the server's,
and so is any setting read when a module was imported (none of this package's are; the
environment is replaced before the command starts).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: The commands a warm server runs: those that compile, gate, render or export.
SERVED = frozenset({"build", "check", "render", "export", "simulate", "edit"})
#: Signals this process forwards to the served command.
FORWARDED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
#: How often the server checks its child and the client's connection while a command runs
#: (where it cannot wait on the child's pidfd), and the client a pending signal.
POLL_S = 0.05
#: How long a client waits for the server to start its command once asked (it forks at once).
ANSWER_S = 30.0


def subcommand(argv: list[str]) -> str | None:
    """The subcommand of ``argv`` (after the global ``-v``), None for help or none."""
    rest = [a for a in argv if a not in ("-v", "--verbose")]
    if not rest or any(a in ("--help", "-h") for a in argv):
        return None
    return rest[0]


def served(argv: list[str], path: Path | None = None) -> int | None:
    """Run ``argv`` in a fork of the warm server at ``path``; its exit status, or None when it
    must run here (see the module doc). Writes nothing itself except when the server goes away
    during the command (then a one-line error, status 1)."""
    from .program.server import ENV_SWITCH, socket_path
    if os.environ.get(ENV_SWITCH, "").lower() in ("off", "0", "no", "false"):
        return None
    if subcommand(argv) not in SERVED:
        return None
    path = Path(path or socket_path())
    if not path.exists():
        return None
    try:
        for fd in (0, 1, 2):
            os.fstat(fd)
    except OSError:  # a closed standard stream: nothing to hand over
        return None
    relay = _Relay()  # from here on, a Ctrl-C waits for the child's pid (or ends this process)
    code = _ask(argv, path, relay)
    if code is None:
        relay.restore()
    return code


class _Relay:
    """The client's SIGINT, SIGTERM and SIGHUP handler: held until the served command's pid is
    known, then forwarded to it (a signal arriving before it is not lost)."""

    def __init__(self) -> None:
        self.pid: int | None = None
        self.pending: list[int] = []
        self.saved = {sig: signal.signal(sig, self.handle) for sig in FORWARDED}

    def handle(self, signum: int, frame: object) -> None:
        if self.pid is None:
            self.pending.append(signum)
            return
        try:
            os.kill(self.pid, signum)
        except OSError:  # it has just ended: the server reports its status
            pass

    def start(self, pid: int) -> None:
        self.pid = pid
        for signum in self.pending:
            self.handle(signum, None)

    def restore(self) -> None:
        """Back to the handlers before (the command runs here); a signal that came meanwhile
        ends this process as it would have (130 for Ctrl-C)."""
        for sig, handler in self.saved.items():
            signal.signal(sig, handler)
        if self.pending:
            os._exit(128 + self.pending[0])


def _ask(argv: list[str], path: Path, relay: _Relay) -> int | None:
    """The handshake and the request; then follow the command to its exit status."""
    from .program.server import CONNECT_TIMEOUT_S, _Lines, _send, code_digest
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        conn.settimeout(CONNECT_TIMEOUT_S)
        conn.connect(str(path))
        lines = _Lines(conn)
        _send(conn, {"op": "hello"})
        hello = lines.read() or {}
        digest = code_digest()
        if hello.get("digest") != digest:
            conn.close()
            return None
        umask = os.umask(0o022)
        os.umask(umask)
        request = {"op": "run", "argv": argv, "cwd": os.getcwd(), "env": dict(os.environ),
                   "umask": umask, "digest": digest, "prog": _prog()}
        socket.send_fds(conn, [(json.dumps(request) + "\n").encode()], [0, 1, 2])
    except OSError:  # no answer, or another server's: nothing was asked to run
        conn.close()
        return None
    # asked: from here the command may be running there, so it never also runs here
    started = _answer(conn, lines, relay)
    if started is None:
        return 1
    if isinstance(started, int):
        return started
    if "error" in started:  # refused before anything ran: run it here
        conn.close()
        return None
    if not isinstance(started.get("pid"), int):  # it went away mid-request: its fork may have run
        conn.close()
        os.write(2, b"error: the warm server (procedura-brep serve) went away as it took the command\n")
        return 1
    conn.settimeout(None)
    if "-v" in argv or "--verbose" in argv:  # as the command line's own log lines look
        os.write(2, f"INFO procedura_brep.served: running in a fork of the warm server at {path} "
                    f"(pid {started['pid']})\n".encode())
    relay.start(started["pid"])
    return _follow(lines)


def _prog() -> list[Any]:
    """``[argv[0], __main__'s package]``: what the command line names itself after in usage
    lines (``procedura-brep``, or ``python -m procedura_brep``), for the fork to name itself
    the same."""
    return [sys.argv[0] if sys.argv else "procedura-brep",
            getattr(sys.modules.get("__main__"), "__package__", None)]


def _answer(conn: socket.socket, lines: Any, relay: _Relay) -> dict[str, Any] | int | None:
    """The server's answer to a run request: its message; an exit status when a signal came
    first (the connection is closed, so the server stops the command if it started one); None,
    with a one-line error, when the server said nothing within :data:`ANSWER_S`."""
    deadline = time.monotonic() + ANSWER_S
    conn.settimeout(POLL_S)
    while time.monotonic() < deadline:
        if relay.pending:
            conn.close()
            return 128 + relay.pending[0]
        try:
            return lines.read() or {}  # {}: the connection ended without an answer
        except TimeoutError:
            continue
        except OSError:
            break
    conn.close()
    os.write(2, b"error: the warm server (procedura-brep serve) took the command but did not start it; "
                b"PROCEDURA_BREP_SERVER=off runs commands without it\n")
    return None


def _follow(lines: Any) -> int:
    """The served command's exit status, once the server reports it."""
    while True:
        try:
            msg = lines.read()
        except InterruptedError:
            continue
        except OSError:
            msg = None
        if msg is None:
            os.write(2, b"error: the warm server (procedura-brep serve) went away during the command\n")
            return 1
        if isinstance(msg.get("exit"), int):
            return int(msg["exit"])


def run_served(conn: socket.socket, msg: dict[str, Any], fds: list[int], *,
               command: Callable[[], None]) -> None:
    """The server's side of ``run`` (with ``command``, the command line's ``main``, bound: a
    :data:`~.program.server.Handler`): fork, let the child become the client's command, report
    its exit status; interrupt it if the client goes away."""
    from .program.server import _close_fds, _send, code_digest
    argv, env = msg.get("argv"), msg.get("env")
    ok = (len(fds) == 3 and isinstance(argv, list) and all(isinstance(a, str) for a in argv)
          and isinstance(env, dict) and all(isinstance(k, str) and isinstance(v, str) for k, v in env.items())
          and isinstance(msg.get("cwd"), str) and isinstance(msg.get("umask"), int)
          and subcommand(argv) in SERVED)
    if not ok or msg.get("digest") != code_digest():
        _close_fds(fds)
        _send(conn, {"error": "refused: other code, or not a served command"})
        return
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    server = os.getpid()
    try:
        pid = os.fork()
    except OSError as exc:  # no process to spare: the client runs the command itself
        _close_fds(fds)
        _send(conn, {"error": f"cannot fork: {exc}"})
        return
    if pid == 0:  # the child: never returns
        _become(conn, msg, fds, command, server=server)
    _close_fds(fds)
    try:
        _send(conn, {"pid": pid})
    except OSError:  # the client is already gone: stop its command (and still reap it)
        os.kill(pid, signal.SIGINT)
    code = _wait(conn, pid)
    try:
        _send(conn, {"exit": code})
    except OSError:  # the client went away meanwhile: nobody to tell
        pass


def _wait(conn: socket.socket, pid: int) -> int:
    """The exit status of the served child (128 + N when signal N ended it); SIGINT to it once
    the client's connection drops. Wakes when the child ends (its pidfd), else polls."""
    import select
    try:
        pidfd: int | None = os.pidfd_open(pid)
    except (AttributeError, OSError):  # pragma: no cover - before Linux 5.3: poll
        pidfd = None
    told = False
    try:
        while True:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                code = os.waitstatus_to_exitcode(status)
                return code if code >= 0 else 128 - code
            watch = ([] if told else [conn]) + ([] if pidfd is None else [pidfd])
            if not watch:
                time.sleep(POLL_S)
                continue
            readable, _, _ = select.select(watch, [], [], POLL_S if pidfd is None else 5.0)
            if conn in readable:
                try:
                    gone = not conn.recv(4096)  # the client sends nothing more: only its end matters
                except OSError:
                    gone = True
                if gone:
                    told = True
                    os.kill(pid, signal.SIGINT)
    finally:
        if pidfd is not None:
            os.close(pidfd)


def _become(conn: socket.socket, msg: dict[str, Any], fds: list[int], command: Callable[[], None], *,
            server: int) -> None:
    """In the forked child: take the client's streams, folder, environment and umask, then run
    the command line as the client would have; end with its exit status."""
    code = 1
    try:
        conn.close()
        os.setsid()  # not in the server's terminal session: only the client's signals reach it
        from .limited import die_with
        die_with(server, signal.SIGTERM)  # it stops as a local command does on SIGTERM
        for target, fd in enumerate(fds):
            os.dup2(fd, target)
            os.close(fd)
        try:
            os.chdir(msg["cwd"])
        except OSError as exc:  # the client's folder went away meanwhile: its mistake, one line
            os.write(2, f"error: cannot enter the working folder {msg['cwd']}: {exc.strerror}\n".encode())
            os._exit(2)
        os.umask(msg["umask"])
        os.environ.clear()
        os.environ.update(msg["env"])
        _fresh_streams()
        import atexit
        import logging
        atexit._clear()  # the server's exit handlers are not this command's
        logging.root.handlers.clear()  # the command configures its own, on the new stderr
        from . import interrupt
        interrupt.forget()
        prog = msg.get("prog")
        argv0, package = prog if isinstance(prog, list) and len(prog) == 2 else ("procedura-brep", None)
        sys.argv = [str(argv0), *msg["argv"]]
        main = sys.modules.get("__main__")
        if main is not None:  # the name usage lines give the program: the client's, not the server's
            main.__package__ = package if isinstance(package, str) else None
        command()  # the command line's main: leaves with os._exit
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 1
    except BaseException:  # noqa: BLE001 - the child must never return into the server's thread
        import traceback
        traceback.print_exc()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)


def _fresh_streams() -> None:
    """``sys.stdin``, ``sys.stdout`` and ``sys.stderr`` over descriptors 0-2 (now the client's),
    buffered as Python buffers a terminal's or a file's."""
    import io
    unbuffered = bool(os.environ.get("PYTHONUNBUFFERED"))

    def text(fd: int, mode: str) -> io.TextIOWrapper:
        raw = io.FileIO(fd, mode, closefd=False)
        tty = raw.isatty()
        buffered: Any = io.BufferedReader(raw) if mode == "r" else io.BufferedWriter(raw)
        return io.TextIOWrapper(buffered, encoding="utf-8", errors="backslashreplace" if fd == 2 else "strict",
                                line_buffering=tty or fd == 2, write_through=unbuffered and mode == "w")
    sys.stdin, sys.stdout, sys.stderr = text(0, "r"), text(1, "w"), text(2, "w")


__all__ = ["SERVED", "run_served", "served", "subcommand"]
