"""Image output (a synthesised reference image): the OpenAI images endpoint, the transcript that
stores the PNG so a replay gives it back offline, exchange PNG replies, and providers that cannot."""

from __future__ import annotations

import base64
import json
import threading

import pytest

from procedura_brep.llm import (
    Client,
    ConfigError,
    Image,
    MalformedReplyError,
    Message,
    Provider,
    Reply,
    Request,
    Settings,
    Transcript,
    read_tape,
)
from procedura_brep.llm.exchange import ExchangeProvider
from procedura_brep.llm.openai_compat import OpenAIProvider
from procedura_brep.llm.replay import ReplayProvider


def image_request(step: int = 0) -> Request:
    return Request("reference_image", step, "A product photograph.",
                   (Message.user("a benchtop drill press"),), Settings(output="image", image_size="512x512"))


def test_openai_images_endpoint_round_trips_through_the_transcript(fake_server, png, tmp_path):
    fake_server.push(fake_server.Behaviour(body={"created": 1, "data": [{"b64_json": base64.b64encode(png).decode()}],
                                                 "usage": {"input_tokens": 20, "output_tokens": 1000}}))
    provider = OpenAIProvider("gpt-image-1", base_url=fake_server.url, api_key="k")
    tape = tmp_path / "transcript.jsonl"
    client = Client(provider, transcript=Transcript(tape))
    reply = client.complete(image_request())
    assert reply.images and reply.images[0].png == png
    assert reply.usage.input_tokens == 20 and reply.usage.output_tokens == 1000
    assert fake_server.paths == ["/v1/images/generations"]
    sent = fake_server.requests[0]
    assert sent["model"] == "gpt-image-1" and sent["size"] == "512x512" and sent["n"] == 1
    assert "drill press" in sent["prompt"] and "product photograph" in sent["prompt"]
    client.close()
    # the transcript keeps the PNG itself: a replay gives the same bytes without the server
    (entry,) = read_tape(tape)
    assert entry.images[0].png == png
    replay = ReplayProvider(str(tape))
    again = Client(replay).complete(image_request())
    assert again.images[0].png == png
    replay.close()


def test_a_tape_whose_image_does_not_match_its_digest_is_refused(tmp_path, png):
    rec = {"v": 1, "role": "reference_image", "step": 0, "model": "x",
           "reply": {"text": "", "images": [{"name": "r.png", "sha256": "0" * 64,
                                             "data_b64": base64.b64encode(png).decode()}]}}
    tape = tmp_path / "t.jsonl"
    tape.write_text(json.dumps(rec) + "\n")
    with pytest.raises(ConfigError, match="line 1 .*sha256"):
        read_tape(tape)


class _TextOnly(Provider):
    prefix = "textonly"

    def complete(self, request: Request) -> Reply:  # pragma: no cover - never reached
        raise AssertionError("an image request must not reach a text-only provider")


def test_a_provider_without_image_output_gets_a_clear_config_error():
    with pytest.raises(ConfigError, match="cannot generate images.*--image PNG"):
        Client(_TextOnly("m")).complete(image_request())


def test_an_image_request_answered_without_an_image_is_malformed(tmp_path):
    from procedura_brep.llm import ScriptedProvider
    client = Client(ScriptedProvider(replies=["here is a description instead"]),
                    transcript=Transcript(tmp_path / "t.jsonl"))
    with pytest.raises(MalformedReplyError, match="no image"):
        client.complete(image_request())
    assert "error" in json.loads((tmp_path / "t.jsonl").read_text().splitlines()[0])


def test_exchange_waits_for_a_png_reply_and_checks_it(tmp_path, png):
    provider = ExchangeProvider(str(tmp_path), timeout_s=10, poll_s=0.02)

    def answer(data: bytes) -> None:
        for _ in range(400):
            reqs = sorted(tmp_path.glob("*.request.md"))
            if reqs and not (tmp_path / reqs[-1].name.replace(".request.md", ".reply.png")).exists():
                text = reqs[-1].read_text()
                assert ".reply.png" in text and "512x512" in text
                tmp = tmp_path / "tmp.bin"
                tmp.write_bytes(data)
                tmp.replace(tmp_path / reqs[-1].name.replace(".request.md", ".reply.png"))
                return
            threading.Event().wait(0.02)

    t = threading.Thread(target=answer, args=(png,))
    t.start()
    reply = provider.complete(image_request())
    t.join()
    assert reply.images[0].png == png
    t = threading.Thread(target=answer, args=(b"not a png at all",))
    t.start()
    with pytest.raises(MalformedReplyError, match="not a PNG"):
        provider.complete(image_request(1))
    t.join()


def test_image_settings_appear_in_the_request_record_only_for_image_requests():
    assert "output" not in Settings().to_dict()
    assert Settings(output="image").to_dict()["output"] == "image"
    assert isinstance(Image(b"\x89PNG\r\n\x1a\n" + b"0" * 8).sha256, str)
