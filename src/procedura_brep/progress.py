"""Progress lines for the command line, always on stderr (stdout stays clean for ``--json``).

On a terminal: a ``rich`` spinner shows the running stage, and each finished stage leaves one
dim line with its duration. Elsewhere (CI, a pipe): one plain line per stage,
``  3.2 s  running the gates``. ``quiet`` prints nothing. Every line is passed through
:func:`procedura_brep.text.terminal_safe` (stage lines may quote a program or a model).
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any, TextIO

from . import interrupt
from .text import markup_safe, terminal_safe

#: Restores the cursor a spinner hid (written when the process is interrupted).
SHOW_CURSOR = b"\x1b[?25h"


class Progress:
    """A callable ``progress(line)``; use as a context manager so the spinner stops."""

    def __init__(self, *, quiet: bool = False, stream: TextIO | None = None) -> None:
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = time.perf_counter()
        self._status: Any = None
        self._console: Any = None
        self._current: tuple[str, float] | None = None

    def __call__(self, line: str) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        if not self.tty:
            self.stream.write(f"{now - self.t0:6.1f} s  {terminal_safe(line)}\n")
            self.stream.flush()
            return
        from rich.console import Console
        if self._console is None:
            self._console = Console(file=self.stream, highlight=False)
            interrupt.add_cleanup(self._restore_cursor)
        self._finish_current(now)
        self._current = (line, now)
        if self._status is None:
            self._status = self._console.status(markup_safe(line), spinner="dots")
            self._status.start()
        else:
            self._status.update(markup_safe(line))

    def note(self, line: str) -> None:
        """A line that stays (e.g. an attempt's feedback), printed above the spinner."""
        if self.quiet:
            return
        if not self.tty:
            self(line)
            return
        self._finish_current(time.perf_counter())
        self._current = None
        from rich.console import Console
        self._console = self._console or Console(file=self.stream, highlight=False)
        self._console.print(markup_safe(line))

    def _finish_current(self, now: float) -> None:
        if self._current is not None and self._console is not None:
            text, t = self._current
            self._console.print(f"[dim]{markup_safe(text)} ({now - t:.1f} s)[/]")

    def close(self) -> None:
        if self._status is not None:
            self._finish_current(time.perf_counter())
            self._status.stop()
            self._status = None
        self._current = None

    def _restore_cursor(self) -> None:
        os.write(self.stream.fileno(), SHOW_CURSOR)

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ = ["Progress"]
