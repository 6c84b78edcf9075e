"""Exception types shared by every layer.

User mistakes (a malformed program, a bad ``--set``) and kernel failures are different types,
so the CLI can choose its exit code and message. Every message is one line that names what was
wrong, the value, and (where there is one) the allowed range or the fix.
"""

from __future__ import annotations

from typing import Any


class ProceduraError(Exception):
    """Base class for every error this package raises on purpose."""


class ProgramFormatError(ProceduraError):
    """The program text breaks the format: sections, markers, params (a user/model mistake)."""

    def __init__(self, message: str, *, line: int | None = None) -> None:
        self.line = line
        super().__init__(f"line {line}: {message}" if line is not None else message)


class MateError(ProceduraError):
    """A mate cannot be built: a missing frame, a literal nominal, an out-of-range option."""

    def __init__(self, mate: str, message: str) -> None:
        self.mate = mate
        super().__init__(f"mate {mate}: {message}")


class RangeError(ProceduraError, ValueError):
    """A value outside its allowed range (joint positions, fit sizes, options)."""

    def __init__(self, what: str, value: float, low: float, high: float, *, unit: str = "") -> None:
        self.what, self.value, self.low, self.high = what, value, low, high
        u = f" {unit}" if unit else ""
        super().__init__(f"{what} = {value:g}{u} is outside the allowed range [{low:g}, {high:g}]{u}")


class CompileError(ProceduraError):
    """The sandboxed compile failed; ``findings`` holds one entry per problem."""

    # ``findings``: findings.Finding objects (Any: the base of the layers imports nothing)
    def __init__(self, message: str, findings: list[Any] | None = None) -> None:
        self.findings = list(findings or [])
        super().__init__(message)


class KernelError(ProceduraError):
    """An OCCT operation failed; raised at the kernel boundary with the operation named."""


class EditError(ProceduraError):
    """``edit --set`` was given an unknown param or an unusable value."""


class InputError(ProceduraError):
    """An input file cannot be used: missing, unreadable, a directory, or not UTF-8 text."""


class OutputError(ProceduraError):
    """An output path cannot be written: it is a file, under a file, read-only or not permitted.

    The message is ``cannot write output PATH: reason``.
    """

    def __init__(self, path: object, reason: str) -> None:
        self.path, self.reason = path, reason
        super().__init__(f"cannot write output {path}: {reason}")
