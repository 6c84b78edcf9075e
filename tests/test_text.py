"""The terminal sanitiser: escape sequences, controls, bidi overrides, markup, huge texts."""

from __future__ import annotations

import pytest

from procedura_brep.config import TERMINAL
from procedura_brep.text import markup_safe, terminal_safe

HOSTILE = {
    "erase line + carriage return": "x\x1b[2K\rbuilt 3 parts, 2 mates",
    "cursor up": "x\x1b[1A\x1b[999Dforged",
    "OSC 52 clipboard (BEL)": "x\x1b]52;c;Y3VybCBldmlsLnNoIHwgc2g=\x07y",
    "window title (ST)": "x\x1b]0;pwned\x1b\\y",
    "8-bit CSI": "x\x9b31my",
    "8-bit OSC": "x\x9d0;pwned\x9cy",
    "DCS": "x\x1bP1$r0m\x1b\\y",
    "unterminated OSC": "x\x1b]52;c;" + "A" * 100,
    "lone ESC": "x\x1b",
    "backspaces and BEL": "x\b\b\b\x07y",
    "bidi override": "x\u202eevil\u202cy",
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_no_escape_or_control_survives(name):
    out = terminal_safe(HOSTILE[name])
    assert not any(ord(c) < 0x20 or 0x7f <= ord(c) <= 0x9f for c in out), repr(out)
    assert "\u202e" not in out and "\u202c" not in out
    assert out.startswith("x")
    assert "pwned" not in out and "Y3Vyb" not in out


def test_plain_text_is_unchanged_and_newlines_fold():
    assert terminal_safe("part arm: ValueError: width must be > 0 (µm ok)") == \
        "part arm: ValueError: width must be > 0 (µm ok)"
    assert terminal_safe("a\nb\tc") == "a b c"
    assert terminal_safe("a\nb\tc", one_line=False) == "a\nb c"


def test_huge_message_is_capped():
    text = "A" * 50_000_000
    out = terminal_safe(text)
    assert len(out) < TERMINAL.message_chars + 40
    assert out.endswith(f"... [{50_000_000 - TERMINAL.message_chars} more characters]")


def test_markup_is_escaped_for_rich():
    from rich.console import Console
    con = Console(record=True, width=200, color_system=None)
    con.print(markup_safe("[red]x[/red] [link=https://evil.example]click[/link] [bold]"))
    assert con.export_text().strip() == "[red]x[/red] [link=https://evil.example]click[/link] [bold]"
    con = Console(record=True, width=200, color_system=None)
    con.print(f"{markup_safe('trailing backslash ' + chr(92))}[dim]kept[/]")
    assert "kept" in con.export_text()
