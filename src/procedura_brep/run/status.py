"""How a run ended (:class:`Status`) and the one map from a status to a process exit code.

``report.json`` carries ``status`` as the enum's string value; the CLI's ``build``,
``generate`` and ``revise`` all exit with :func:`exit_code` of their status.
"""

from __future__ import annotations

from enum import StrEnum

EXIT_OK, EXIT_FAIL, EXIT_USAGE, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


class Status(StrEnum):
    """How a build (or a generate / revise run) ended.

    Members:
        OK: every step passed.
        GATES_FAILED: the model compiled; a gate found an error.
        BATTERY_FAILED: the gates passed; a MuJoCo battery check failed.
        FAILED: the program did not compile, or a step failed (an export that cannot be
            written as asked, a child over its limits).
        INTERRUPTED: Ctrl-C or SIGTERM.
        BUDGET_EXCEEDED: an agent run spent its cost cap before it finished.
    """

    OK = "ok"
    GATES_FAILED = "gates_failed"
    BATTERY_FAILED = "battery_failed"
    FAILED = "failed"
    INTERRUPTED = "interrupted"
    BUDGET_EXCEEDED = "budget_exceeded"


#: Exit code per status (FAILED before any model compiled is a usage error: see exit_code).
EXIT_CODES: dict[Status, int] = {
    Status.OK: EXIT_OK,
    Status.GATES_FAILED: EXIT_FAIL,
    Status.BATTERY_FAILED: EXIT_FAIL,
    Status.FAILED: EXIT_FAIL,
    Status.INTERRUPTED: EXIT_INTERRUPTED,
    Status.BUDGET_EXCEEDED: EXIT_FAIL,
}


def exit_code(status: Status | str, *, compiled: bool = True) -> int:
    """The exit code for ``status``: 0 ok; 1 a gate, check or step failed; 2 a program that
    does not compile (``FAILED`` with ``compiled=False``: the user's input is at fault); 130
    interrupted. A status this enum does not know (an agent's own verdict, e.g. ``gave_up``)
    is a failure (1)."""
    try:
        st = Status(status)
    except ValueError:
        return EXIT_FAIL
    if st is Status.FAILED and not compiled:
        return EXIT_USAGE
    return EXIT_CODES[st]


__all__ = ["EXIT_CODES", "EXIT_FAIL", "EXIT_INTERNAL", "EXIT_INTERRUPTED", "EXIT_OK", "EXIT_USAGE",
           "Status", "exit_code"]
