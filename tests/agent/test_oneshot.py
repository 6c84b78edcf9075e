"""One-shot generation driven by a hand-written replay tape and by a scripted provider."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from procedura_brep.agent.oneshot import extract_program
from procedura_brep.cli import app
from procedura_brep.llm.errors import MalformedReplyError

TAPE = Path(__file__).parents[2] / "examples" / "tapes" / "lamp_oneshot.jsonl"


def test_replay_tape_builds_after_feedback(tmp_path, worker):
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["generate", "--one-shot", "a desk lamp with a swinging arm", "-o", str(out),
                                   "--model", f"replay:{TAPE}", "--formats", "step"])
    assert res.exit_code == 0, res.output
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "ok" and report["attempts"] == 2 and report["mode"] == "oneshot"
    assert [p["name"] for p in report["parts"]] == ["base", "post", "arm"]
    lines = (out / "transcript.jsonl").read_text().splitlines()
    assert len(lines) == 2
    second = json.loads(lines[1])["request"]
    # the feedback sent after attempt 1 names the mate and the literal nominal
    assert "param name" in json.dumps(second) and "post_foot" in json.dumps(second)
    assert sorted(p.name for p in (out / "history").iterdir()) == ["001.py", "002.py"]
    assert (out / "model.step").stat().st_size > 1000


def test_unreachable_endpoint_fails_fast_and_names_it(tmp_path):
    t = time.monotonic()
    res = CliRunner().invoke(app, ["generate", "--one-shot", "a lamp", "-o", str(tmp_path / "x"), "--model",
                                   "openai:some-model", "--base-url", "http://127.0.0.1:9/v1"])
    assert res.exit_code == 1
    assert "127.0.0.1:9" in res.output and "Traceback" not in res.output
    assert time.monotonic() - t < 15


def test_tape_with_no_reply_for_a_step_is_an_error(tmp_path):
    tape = tmp_path / "t.jsonl"
    tape.write_text(TAPE.read_text().splitlines()[0] + "\n")  # only the broken first reply
    res = CliRunner().invoke(app, ["generate", "--one-shot", "a lamp", "-o", str(tmp_path / "r"), "--model",
                                   f"replay:{tape}", "--formats", "step"])
    assert res.exit_code == 1
    assert "no recorded reply for role='oneshot' step=1" in res.output
    assert json.loads((tmp_path / "r" / "report.json").read_text())["status"] == "failed"


def test_extract_program():
    src = TAPE.read_text().splitlines()[1]
    text = json.loads(src)["reply"]["text"]
    assert extract_program(text).startswith('"""Desk lamp')
    with pytest.raises(MalformedReplyError, match="no program"):
        extract_program("I cannot do that.")


def test_exchange_provider_drives_generate(tmp_path, worker):
    """A 'person' (a thread) answers the request file; the run builds the program."""
    import threading

    xchg = tmp_path / "xchg"
    lamp = json.loads(TAPE.read_text().splitlines()[1])["reply"]["text"]

    def answer() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            reqs = sorted(xchg.glob("*-oneshot.request.md")) if xchg.exists() else []
            if reqs:
                assert "Object to model: a desk lamp" in reqs[0].read_text()
                tmp = xchg / "reply.tmp"
                tmp.write_text(lamp)
                tmp.rename(reqs[0].with_name(reqs[0].name.replace(".request.md", ".reply.md")))
                return
            time.sleep(0.1)

    t = threading.Thread(target=answer)
    t.start()
    res = CliRunner().invoke(app, ["generate", "--one-shot", "a desk lamp", "-o", str(tmp_path / "run"),
                                   "--model", f"exchange:{xchg}", "--formats", "step"])
    t.join()
    assert res.exit_code == 0, res.output
    assert json.loads((tmp_path / "run" / "report.json").read_text())["status"] == "ok"


def test_max_cost_stops_cleanly_and_keeps_the_work(tmp_path, worker, monkeypatch):
    """A priced scripted model: the first (broken) attempt spends $1, the cap is $0.5, so the
    second call is refused; the run ends cleanly with its history and report kept."""
    from procedura_brep.llm import ScriptedProvider, Usage
    from procedura_brep.llm import base as llm_base

    broken = json.loads(TAPE.read_text().splitlines()[0])["reply"]["text"]
    lamp = json.loads(TAPE.read_text().splitlines()[1])["reply"]["text"]

    class Pricey(ScriptedProvider):
        prefix = "pricey"

    monkeypatch.setitem(llm_base._REGISTRY, "pricey", lambda model, **kw: Pricey(
        model, replies=[broken, lamp], usage=Usage(input_tokens=1_000_000)))  # removed after the test
    prices = tmp_path / "prices.toml"
    prices.write_text('["pricey:m"]\ninput = 1.0\ncached_input = 0.5\noutput = 2.0\n')
    monkeypatch.setenv("PROCEDURA_BREP_PRICES", str(prices))
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["generate", "--one-shot", "a desk lamp", "-o", str(out), "--model", "pricey:m",
                                   "--max-cost", "0.5", "--formats", "step"])
    assert res.exit_code == 1 and "budget_exceeded" in res.output, res.output
    report = json.loads((out / "report.json").read_text())
    assert report["status"] == "budget_exceeded" and report["attempts"] == 2
    assert report["usage"]["total"]["cost_usd"] == pytest.approx(1.0)
    assert report["usage"]["max_cost_usd"] == 0.5
    assert (out / "history" / "001.py").exists() and (out / "program.py").exists()
