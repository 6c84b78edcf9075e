"""``procedura-brep view RUN``: serve a run directory's offline viewer over HTTP on loopback.

The page needs no server (it opens from the file system); serving it is for a browser that
cannot open local files, another machine's browser through an SSH tunnel, or a link to paste.
:func:`viewer_page` checks the run directory first; :class:`ViewServer` serves the directory
read-only (files only, no listing outside it) on ``127.0.0.1``; :func:`serve_until_interrupted`
runs it in the calling thread until Ctrl-C or SIGTERM and then closes it.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import signal
import threading
from collections.abc import Callable, Iterator
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

from ..errors import InputError

log = logging.getLogger(__name__)

#: The address the viewer is served on: loopback only.
HOST = "127.0.0.1"
#: The page, relative to the run directory.
PAGE = "viewer.html"


def viewer_page(run_dir: Path) -> Path:
    """``run_dir/viewer.html``.

    Raises:
        InputError: ``run_dir`` is not a directory, or has no viewer (the message says to build
            it again).
    """
    if not run_dir.is_dir():
        raise InputError(f"run directory {run_dir} does not exist or is not a directory")
    page = run_dir / PAGE
    if not page.is_file() or not (run_dir / "viewer" / "data.js").is_file():
        raise InputError(f"{run_dir} has no viewer ({PAGE} and viewer/): build it again, e.g. "
                         f"procedura-brep build {run_dir / 'program.py'} -o {run_dir}")
    return page


class _Handler(SimpleHTTPRequestHandler):
    """Files of the run directory; requests logged at debug level, not on the terminal."""

    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 - the base class's name
        log.debug("view: " + format, *args)

    def end_headers(self) -> None:
        self.send_header("Cache-Control", "no-store")  # a rebuild shows at the next reload
        super().end_headers()


class ViewServer:
    """The run directory ``run_dir`` served on :data:`HOST` at ``port`` (0: a free one).

    Raises:
        InputError: no viewer in ``run_dir`` (:func:`viewer_page`).
        OSError: the port cannot be bound (in use, not permitted).
    """

    def __init__(self, run_dir: Path, port: int = 0) -> None:
        self.page = viewer_page(run_dir)
        handler = functools.partial(_Handler, directory=str(run_dir.resolve()))
        self.httpd = ThreadingHTTPServer((HOST, port), handler)
        self.httpd.daemon_threads = True

    @property
    def port(self) -> int:
        return int(self.httpd.server_address[1])

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://{HOST}:{self.port}/{PAGE}"

    @property
    def file_url(self) -> str:
        """The page on the file system (it works without the server too)."""
        return self.page.resolve().as_uri()

    def start(self) -> ViewServer:
        """Serve from a daemon thread (returns at once; :meth:`close` stops it)."""
        threading.Thread(target=self.httpd.serve_forever, name="procedura-view", daemon=True).start()
        return self

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


@contextlib.contextmanager
def _interruptible() -> Iterator[None]:
    """Ctrl-C and SIGTERM raise ``KeyboardInterrupt`` in the main thread while the block runs,
    instead of ending the process through the command line's interrupt watcher
    (:mod:`procedura_brep.interrupt`): a server stopped by Ctrl-C is a clean exit."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old_fd = signal.set_wakeup_fd(-1)
    old = {s: signal.signal(s, signal.default_int_handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in old.items():
            signal.signal(s, handler)
        if old_fd != -1:
            signal.set_wakeup_fd(old_fd, warn_on_full_buffer=False)


def serve_until_interrupted(run_dir: Path, *, port: int = 0,
                            ready: Callable[[ViewServer], None] | None = None) -> None:
    """Serve ``run_dir`` until Ctrl-C or SIGTERM, then close the server and return.

    Args:
        run_dir: a run directory with a viewer.
        port: the port (0: a free one).
        ready: called with the server once it listens (print its address there).

    Raises:
        InputError: no viewer in ``run_dir``.
        OSError: the port cannot be bound.
    """
    server = ViewServer(run_dir, port)
    with _interruptible():
        try:
            if ready is not None:
                ready(server)
            server.httpd.serve_forever()
        except KeyboardInterrupt:
            log.debug("view: interrupted")
        finally:
            server.httpd.server_close()


__all__ = ["HOST", "PAGE", "ViewServer", "serve_until_interrupted", "viewer_page"]
