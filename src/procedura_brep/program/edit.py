"""Parametric edits: rewrite exactly the named param lines, keeping comments and formatting.

``set_params(source, {"wheel_d": 140})`` replaces the value expression on the ``wheel_d = ...``
line of the params section and nothing else; every other byte of the program is unchanged.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

from ..errors import EditError, ProgramFormatError
from ..text import did_you_mean
from .sections import Sections, parse_sections

VALUE_RE = re.compile(r"[+-]?(\d+(\.\d*)?|\.\d+)([eE][+-]?\d+)?")
#: A param whose name ends in a size word (diameter, radius, width, height, thickness, length,
#: depth ...) and whose unit comment says mm must stay > 0: a zero or negative size would only
#: fail later inside the CAD kernel with an unexplained ``Standard_ConstructionError``.
SIZE_NAME_RE = re.compile(r"(?:.*_)?(?:d|r|w|h|t|l|len|dia|diam|diameter|radius|width|height|"
                          r"thick|thickness|length|depth|size|side|wall)\d*")
MM_COMMENT_RE = re.compile(r"#\s*mm\b")


def is_size_param(name: str, comment: str) -> bool:
    """True for a param that names a length in mm that must stay positive (see SIZE_NAME_RE)."""
    return bool(SIZE_NAME_RE.fullmatch(name)) and bool(MM_COMMENT_RE.match(comment))


def parse_assignment(text: str) -> tuple[str, float | int | bool]:
    """``"NAME=VALUE"`` from the command line -> (name, number or bool)."""
    if "=" not in text:
        raise EditError(f"--set takes NAME=VALUE, got {text!r}")
    name, _, raw = text.partition("=")
    name, raw = name.strip(), raw.strip()
    return name, parse_value(name, raw)


def parse_value(name: str, raw: str) -> float | int | bool:
    if raw in ("True", "False", "true", "false"):
        return raw.lower() == "true"
    if not VALUE_RE.fullmatch(raw):
        raise EditError(f"value for {name} must be a number, got {raw!r}")
    value: float | int = int(raw) if re.fullmatch(r"[+-]?\d+", raw) else float(raw)
    if not math.isfinite(value):
        raise EditError(f"value for {name} must be finite, got {raw!r}")
    return value


def _literal(value: float | int | bool) -> str:
    if isinstance(value, bool) or isinstance(value, int):
        return repr(value)
    text = repr(float(value))
    return text


def set_params(source: str, values: Mapping[str, float | int | bool]) -> str:
    """Return ``source`` with each named param's value replaced.

    Raises:
        EditError: a name is not a param (the message lists the params), or the program's
            sections cannot be parsed.
    """
    try:
        sec = parse_sections(source)
    except ProgramFormatError as exc:
        raise EditError(f"cannot edit: {exc}") from None
    unknown = [n for n in values if n not in sec.params]
    if unknown:
        hint = did_you_mean(unknown[0], sec.params)
        raise EditError(f"unknown param(s) {', '.join(unknown)}{hint}; params: {', '.join(sec.params)}")
    for name, value in values.items():
        p = sec.params[name]
        if (is_size_param(name, p.comment) and not isinstance(value, bool) and value <= 0
                and _current(sec, name) > 0):
            raise EditError(f"{name} = {value:g} mm: {name} is a size ({p.comment.lstrip('# ')}) "
                            f"and must stay > 0 (it is {_current(sec, name):g} now)")
    lines = source.splitlines(keepends=True)
    for name, value in values.items():
        p = sec.params[name]
        if isinstance(value, int) and not isinstance(value, bool) and "." in p.expr:
            value = float(value)
        text = lines[p.line - 1]
        head_m = re.match(rf"\s*{re.escape(name)}\s*=", text)
        if head_m is None:  # the parser's line numbering and ours disagree: never guess
            raise EditError(f"cannot edit {name}: line {p.line} is not its assignment")
        start = head_m.end()
        head = text[:start]
        rest = text[start:]
        idx = rest.index(p.expr)
        lines[p.line - 1] = head + rest[:idx] + _literal(value) + rest[idx + len(p.expr):]
    return "".join(lines)


def _current(sec: Sections, name: str) -> float:
    """The param's value when its expression is a plain number literal, else +inf (unknown)."""
    expr = sec.params[name].expr.strip()
    return float(expr) if VALUE_RE.fullmatch(expr) else math.inf
