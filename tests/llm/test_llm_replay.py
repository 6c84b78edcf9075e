"""Transcripts double as replay tapes."""

from __future__ import annotations

import json

import pytest

from procedura_brep.llm import (
    Client,
    ConfigError,
    Image,
    Message,
    ReplayMismatch,
    Request,
    ScriptedProvider,
    TapeNotConsumed,
    Transcript,
    Usage,
    get_provider,
    read_tape,
)
from procedura_brep.llm.testing import tape_guard


def requests(png: bytes) -> list[Request]:
    return [
        Request("plan", 0, "sys", (Message.user("make a hinge"),)),
        Request("build", 1, "sys", (Message.user("build it", Image(png, "iso")),)),
        Request("critic", 2, "sys", (Message.user("look", Image(png)),)),
        Request("build", 2, "sys", (Message.user("fix it"),)),
        Request("build", 2, "sys", (Message.user("fix it again"),)),
    ]


def record(tmp_path, png, *, store_images: bool = False):
    replies = ["PLAN", "BUILD1", "CRITIC", "BUILD2a", "BUILD2b"]
    provider = ScriptedProvider("rec", replies=replies, usage=Usage(10, 2, 5))
    path = tmp_path / "run" / "transcript.jsonl"
    client = Client(provider, transcript=Transcript(path, store_images=store_images))
    for r in requests(png):
        client.complete(r)
    provider.assert_consumed()
    return path, replies


def test_round_trip(tmp_path, png):
    path, replies = record(tmp_path, png)
    lines = [json.loads(x) for x in path.read_text().splitlines()]
    assert [(x["role"], x["step"]) for x in lines] == [("plan", 0), ("build", 1), ("critic", 2), ("build", 2), ("build", 2)]
    img = lines[1]["request"]["messages"][0]["images"][0]
    assert img["sha256"] == Image(png).sha256 and "data_b64" not in img and img["name"] == "iso"
    assert lines[0]["reply"]["usage"] == {"input_tokens": 10, "cached_input_tokens": 2, "output_tokens": 5}
    assert lines[0]["cost_usd"] == 0.0 and "latency_s" in lines[0] and lines[0]["model"] == "scripted:rec"

    replay = get_provider(f"replay:{path.parent}")  # a run directory works too
    got = [replay.complete(r).text for r in requests(png)]
    assert got == replies
    replay.close()


def test_replay_order_independent_across_keys(tmp_path, png):
    path, _ = record(tmp_path, png)
    replay = get_provider(f"replay:{path}")
    rs = requests(png)
    assert replay.complete(rs[2]).text == "CRITIC"
    assert replay.complete(rs[0]).text == "PLAN"
    for r in (rs[1], rs[3], rs[4]):
        replay.complete(r)


def test_store_images(tmp_path, png):
    path, _ = record(tmp_path, png, store_images=True)
    line = json.loads(path.read_text().splitlines()[1])
    assert line["request"]["messages"][0]["images"][0]["data_b64"].startswith("iVBORw0KGgo")
    replay = get_provider(f"replay:{path}")
    for r in requests(png):
        replay.complete(r)


def test_request_without_recorded_reply_names_it(tmp_path, png):
    path, _ = record(tmp_path, png)
    replay = get_provider(f"replay:{path}")
    with pytest.raises(ReplayMismatch, match=r"role='review' step=7"):
        replay.complete(Request("review", 7, "sys", (Message.user("?"),)))
    for r in requests(png):
        replay.complete(r)
    with pytest.raises(ReplayMismatch, match=r"role='build' step=2"):
        replay.complete(requests(png)[3])  # a third build#2 was never recorded


def test_unconsumed_tape_fails(tmp_path, png):
    path, _ = record(tmp_path, png)
    with pytest.raises(TapeNotConsumed, match=r"4 recorded call\(s\) never requested: build#1"):
        with tape_guard():
            replay = get_provider(f"replay:{path}")
            replay.complete(requests(png)[0])
    with pytest.raises(TapeNotConsumed):
        replay.close()


def test_strict_replay_checks_request(tmp_path, png):
    path, _ = record(tmp_path, png)
    replay = get_provider(f"replay:{path}", strict=True)
    with pytest.raises(ReplayMismatch, match="differs"):
        replay.complete(Request("plan", 0, "sys", (Message.user("a different prompt"),)))
    for r in requests(png)[1:]:
        replay.complete(r)


def test_error_lines_are_skipped_and_bad_tapes_rejected(tmp_path):
    tape = tmp_path / "t.jsonl"
    tape.write_text(
        json.dumps({"role": "plan", "step": 0, "error": "ProviderError: down"}) + "\n\n"
        + json.dumps({"role": "plan", "step": 0, "reply": {"text": "ok"}}) + "\n"
    )
    entries = read_tape(tape)
    assert len(entries) == 1 and entries[0].line == 3 and entries[0].text == "ok"
    replay = get_provider(f"replay:{tape}")
    assert replay.complete(Request("plan", 0, "", (Message.user("x"),))).text == "ok"
    with pytest.raises(ConfigError, match="does not exist"):
        get_provider(f"replay:{tmp_path / 'missing.jsonl'}")
    tape.write_text("not json\n")
    with pytest.raises(ConfigError, match="line 1"):
        get_provider(f"replay:{tape}")


def test_failed_calls_are_written_to_the_transcript(tmp_path):
    from procedura_brep.llm import ProviderError

    provider = ScriptedProvider(replies=[ProviderError("http://x: down", endpoint="http://x")])
    path = tmp_path / "transcript.jsonl"
    client = Client(provider, transcript=Transcript(path))
    with pytest.raises(ProviderError):
        client.ask("plan", 0, "sys", "hi")
    assert json.loads(path.read_text())["error"] == "ProviderError: http://x: down"
    assert read_tape(path) == []
