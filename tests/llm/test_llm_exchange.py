"""exchange:DIR — request files out, reply files in."""

from __future__ import annotations

import threading
import time

import pytest

from procedura_brep.llm import ExchangeTimeout, Image, Message, Request, Settings, get_provider
from procedura_brep.llm.exchange import ExchangeProvider


def test_reply_file_is_the_reply(tmp_path, png):
    xdir = tmp_path / "xchg"
    provider = get_provider(f"exchange:{xdir}", timeout_s=10, poll_s=0.02)

    def agent() -> None:
        deadline = time.monotonic() + 10
        while not (xdir / "0001-build.request.md").exists() and time.monotonic() < deadline:
            time.sleep(0.02)
        (xdir / "0001-build.reply.md").write_text("```python\nbox()\n```\n")

    t = threading.Thread(target=agent)
    t.start()
    request = Request("build", 3, "You write code.", (Message.user("a box", Image(png, "iso")),), Settings(json_mode=True))
    reply = provider.complete(request)
    t.join()
    assert reply.text == "```python\nbox()\n```"
    assert reply.model == f"exchange:{xdir}"
    md = (xdir / "0001-build.request.md").read_text()
    assert "role: build, step: 3" in md and "`0001-build.reply.md`" in md
    assert "You write code." in md and "a box" in md and "![image 1](0001-build-1.png)" in md
    assert "single JSON object" in md
    assert (xdir / "0001-build-1.png").read_bytes() == png
    assert (xdir / "README.md").exists()


def test_timeout_names_the_reply_file_and_reports_progress(tmp_path):
    lines: list[str] = []
    provider = ExchangeProvider(str(tmp_path), timeout_s=0.3, poll_s=0.02, progress_every_s=0.1, progress=lines.append)
    start = time.monotonic()
    with pytest.raises(ExchangeTimeout, match="0001-plan.reply.md") as info:
        provider.complete(Request("plan", 0, "", (Message.user("x"),)))
    assert isinstance(info.value, TimeoutError) and time.monotonic() - start < 2
    assert lines[0].startswith("exchange: waiting for") and any("still waiting" in x for x in lines)


def test_numbering_continues_and_existing_reply_is_used(tmp_path):
    (tmp_path / "0007-plan.request.md").write_text("old")
    provider = ExchangeProvider(str(tmp_path), timeout_s=5, poll_s=0.02)
    (tmp_path / "0008-plan.reply.md").write_text("ready before asked\n")
    assert provider.complete(Request("plan", 0, "", (Message.user("x"),))).text == "ready before asked"
    assert (tmp_path / "0008-plan.request.md").exists()
