"""Text that came from a program or a model, made safe to print on a terminal.

An exception message, a part or mate name, or a model's reply can carry escape sequences (erase
the line, move the cursor to forge a ``built 3 parts`` line, an OSC 52 clipboard write, a window
title), bare control characters (``\\r`` overwrites the line), bidirectional overrides, rich markup
(``[red]``, ``[link=...]``) or simply 50 MB of text. :func:`terminal_safe` removes the escape
sequences and controls and caps the length; :func:`markup_safe` also escapes rich markup for
text printed through a ``rich`` console. Apply one of them to everything untrusted before it is
printed; files (report.json) keep the full text.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from .config import TERMINAL

#: Complete escape sequences: CSI (7- and 8-bit), OSC/DCS/SOS/PM/APC strings up to their
#: terminator (BEL or ST) or the end of the text, and two-character escapes.
ESCAPE_RE = re.compile(
    r"(?:\x1b\[|\x9b)[0-?]*[ -/]*[@-~]?"
    r"|(?:\x1b[\]PX^_]|[\x90\x98\x9d\x9e\x9f])[^\x07\x1b\x9c]*(?:\x07|\x1b\\|\x9c)?"
    r"|\x1b[ -~]?")
#: C0 and C1 controls, DEL, and the Unicode bidi embeddings/overrides/isolates.
CONTROL_RE = re.compile(r"[\x00-\x1f\x7f-\x9f\u200e\u200f\u202a-\u202e\u2066-\u2069]")
#: Cut at most this many times the limit before cleaning, so huge texts cost little.
_PRE_CUT = 4


def terminal_safe(text: object, *, limit: int | None = None, one_line: bool = True) -> str:
    """``text`` without escape sequences or control characters, at most ``limit`` characters.

    Args:
        text: anything; ``str()`` is applied.
        limit: the most characters kept (default ``config.TERMINAL.message_chars``); a longer
            text ends in ``... [N more characters]``.
        one_line: newlines and tabs become spaces (an error is one line); otherwise newlines
            are kept and tabs become spaces.

    Example:
        >>> terminal_safe("bad\\x1b[2K\\rbuilt 3 parts\\x1b]52;c;aGk=\\x07!")
        'badbuilt 3 parts!'
    """
    raw = str(text)
    cap = TERMINAL.message_chars if limit is None else limit
    head = raw[: cap * _PRE_CUT + 64]
    keep = "\n" if not one_line else ""
    clean = ESCAPE_RE.sub("", head)
    clean = re.sub(r"[\t\n]" if one_line else r"\t", " ", clean)
    clean = CONTROL_RE.sub(lambda m: m.group(0) if m.group(0) == keep else "", clean)
    dropped = len(raw) - len(head)
    if len(clean) > cap:
        dropped += len(clean) - cap
        clean = clean[:cap]
    return f"{clean}... [{dropped} more characters]" if dropped > 0 else clean


def markup_safe(text: object, *, limit: int | None = None) -> str:
    """:func:`terminal_safe` text with rich markup escaped (for ``rich`` tables and prints)."""
    from rich.markup import escape
    return escape(terminal_safe(text, limit=limit))


__all__ = ["terminal_safe", "markup_safe"]


def did_you_mean(name: object, choices: Iterable[str]) -> str:
    """``" (did you mean 'wheel_fl'?)"`` for the closest of ``choices`` to a mistyped ``name``
    (difflib's ratio 0.6 or better), or ``""`` when none is close."""
    import difflib
    best = difflib.get_close_matches(str(name), list(choices), n=1, cutoff=0.6)
    return f" (did you mean {best[0]!r}?)" if best else ""
