"""What a part function returned, and an exception's text: the small helpers the compile
(:mod:`.runtime`) and the paint blocks (:mod:`.blocks`) share, so neither reaches into the
other's private names."""

from __future__ import annotations

from typing import Any

from ..config import SANDBOX
from ..errors import ProgramFormatError
from .model import cap_text


def as_solid(value: Any) -> Any:
    """The build123d solid a part (or block) function returned: a ``BuildPart``'s part, a list
    as one compound; anything else is a :class:`ProgramFormatError`."""
    from build123d import BuildPart, Compound, Part, Solid
    if isinstance(value, BuildPart):
        value = value.part
    if isinstance(value, (list, tuple)) and value:
        value = Compound(children=list(value)) if len(value) > 1 else value[0]
    if not isinstance(value, (Part, Solid, Compound)):
        raise ProgramFormatError(f"a part must return a build123d solid (Part, Solid or Compound), "
                                 f"got {type(value).__name__}")
    return value


def exc_text(exc: BaseException) -> str:
    """``Type: first line`` of an exception, cut (a hostile ``__str__`` gives the type only)."""
    try:
        raw = str(exc)
    except Exception:  # noqa: BLE001 - a hostile __str__
        raw = ""
    raw = raw[:SANDBOX.message_chars * 2].strip()
    first = raw.splitlines()[0] if raw else ""
    return cap_text(f"{type(exc).__name__}: {first}".rstrip(": "))
