"""Fixtures for the model-layer tests: guards, a fake OpenAI-compatible server, a PNG."""

from __future__ import annotations

import json
import threading
import time
import zlib
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from procedura_brep.llm.testing import no_network, tape_guard


@pytest.fixture(autouse=True)
def _llm_guards() -> Iterator[None]:
    """No network model calls; replay tapes opened by a test must be fully consumed."""
    with no_network(), tape_guard():
        yield


def _png(width: int = 2, height: int = 2) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        body = kind + data
        return len(data).to_bytes(4, "big") + body + zlib.crc32(body).to_bytes(4, "big")

    raw = b"".join(b"\x00" + b"\xff\x00\x00" * width for _ in range(height))
    ihdr = width.to_bytes(4, "big") + height.to_bytes(4, "big") + bytes([8, 2, 0, 0, 0])
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


@pytest.fixture
def png() -> bytes:
    """A tiny valid PNG."""
    return _png()


def completion(text: str = "hello", *, prompt: int = 12, cached: int = 4, out: int = 3) -> dict[str, Any]:
    """A Chat Completions response body."""
    return {
        "id": "chatcmpl-1",
        "object": "chat.completion",
        "choices": [{"index": 0, "message": {"role": "assistant", "content": text}, "finish_reason": "stop"}],
        "usage": {
            "prompt_tokens": prompt,
            "completion_tokens": out,
            "total_tokens": prompt + out,
            "prompt_tokens_details": {"cached_tokens": cached},
        },
    }


@dataclass
class Behaviour:
    """One scripted answer of the fake server."""

    status: int = 200
    body: bytes | dict[str, Any] = field(default_factory=completion)
    headers: dict[str, str] = field(default_factory=dict)
    delay_s: float = 0.0


class FakeServer:
    """A threaded OpenAI-compatible server on 127.0.0.1 answering from a script."""

    Behaviour = Behaviour
    completion = staticmethod(completion)

    def __init__(self) -> None:
        self.script: deque[Behaviour] = deque()
        self.requests: list[dict[str, Any]] = []
        self.paths: list[str] = []
        self.headers: list[dict[str, str]] = []
        self.times: list[float] = []
        self.stop = threading.Event()
        server = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args: Any) -> None:  # keep test output quiet
                pass

            def _send(self, b: Behaviour) -> None:
                if b.delay_s and server.stop.wait(b.delay_s):
                    return
                data = json.dumps(b.body).encode() if isinstance(b.body, dict) else b.body
                try:
                    self.send_response(b.status)
                    self.send_header("Content-Type", "application/json")
                    self.send_header("Content-Length", str(len(data)))
                    for k, v in b.headers.items():
                        self.send_header(k, v)
                    self.end_headers()
                    self.wfile.write(data)
                except (BrokenPipeError, ConnectionResetError):
                    pass

            def do_GET(self) -> None:  # noqa: N802 - http.server's method name
                self._send(Behaviour(body={"object": "list", "data": []}))

            def do_POST(self) -> None:  # noqa: N802 - http.server's method name
                length = int(self.headers.get("Content-Length") or 0)
                server.times.append(time.monotonic())
                server.requests.append(json.loads(self.rfile.read(length) or b"{}"))
                server.paths.append(self.path)
                server.headers.append({k.lower(): v for k, v in self.headers.items()})
                b = server.script.popleft() if server.script else Behaviour(500, {"error": "script empty"})
                self._send(b)

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        self.thread.start()

    def push(self, *behaviours: Behaviour) -> None:
        """Queue answers."""
        self.script.extend(behaviours)

    def close(self) -> None:
        """Stop serving (cuts slow answers short)."""
        self.stop.set()
        self.httpd.shutdown()
        self.httpd.server_close()
        self.thread.join(timeout=5)


@pytest.fixture
def fake_server() -> Iterator[FakeServer]:
    """A fake OpenAI-compatible server, stopped after the test."""
    server = FakeServer()
    try:
        yield server
    finally:
        server.close()


@pytest.fixture
def closed_port_url() -> str:
    """A loopback URL on which nothing listens."""
    import socket

    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return f"http://127.0.0.1:{port}/v1"
