"""The console entry point (``procedura-brep``, ``python -m procedura_brep``): a command runs in
a warm server's fork when one answers with this code (:mod:`procedura_brep.served`), else here.

Before anything else, so a served command imports only the standard library and the server's
wire (about 0.05 s) instead of the command line and what its commands need.
"""

from __future__ import annotations

import os
import sys


def main() -> None:
    """``procedura-brep``: a command of :data:`~.served.SERVED` through a warm server when one
    answers, else the command line here."""
    from .served import served, subcommand
    code = served(sys.argv[1:])
    if code is None:
        if subcommand(sys.argv[1:]) in EARLY_WORKER:
            from .program.spawn import start_early
            start_early()  # its build123d import runs beside the command line's own start
        from .cli import main as local
        local()
        return
    os._exit(code)


#: The commands that start the compile worker first thing when they run here: the cold
#: ``build``, which always compiles.
EARLY_WORKER = frozenset({"build"})


__all__ = ["EARLY_WORKER", "main"]
