"""Progress lines: plain lines off a terminal, a rich spinner on one, nothing when quiet."""

from __future__ import annotations

import io

from procedura_brep.progress import Progress


class FakeTTY(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_plain_lines_when_not_a_tty():
    buf = io.StringIO()
    with Progress(stream=buf) as p:
        p("compiling lamp")
        p("running the gates\x1b]0;title\x07")
    lines = buf.getvalue().splitlines()
    assert [l.split(" s  ", 1)[1] for l in lines] == ["compiling lamp", "running the gates"]


def test_spinner_on_a_tty_leaves_one_line_per_finished_stage():
    buf = FakeTTY()
    with Progress(stream=buf) as p:
        p("compiling [red]lamp")
        p("running the gates")
    text = buf.getvalue()
    assert "compiling [red]lamp (" in text and "running the gates (" in text  # markup shown as text
    assert "\x1b]0;" not in text


def test_quiet_prints_nothing():
    buf = FakeTTY()
    with Progress(stream=buf, quiet=True) as p:
        p("compiling lamp")
        p.note("attempt 1/3: built")
    assert buf.getvalue() == ""
