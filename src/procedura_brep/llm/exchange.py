"""``exchange:DIR`` — a person or an external agent plays the model through files.

For each request the provider writes ``NNNN-<role>.request.md`` and its images
``NNNN-<role>-K.png`` into DIR, then waits for ``NNNN-<role>.reply.md``. The whole content of
the reply file is the model's reply. Numbering continues after the highest number already in
DIR, so a directory can serve several runs. See ``docs/providers.md``.
"""

from __future__ import annotations

import logging
import os
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import Literal, overload

from .base import Provider
from .errors import ConfigError, ExchangeTimeout, MalformedReplyError
from .messages import Image, Reply, Request, Usage

__all__ = ["DEFAULT_EXCHANGE_TIMEOUT_S", "ExchangeProvider", "render_request"]

log = logging.getLogger(__name__)

#: A person may take a while; one hour per reply unless told otherwise.
DEFAULT_EXCHANGE_TIMEOUT_S = 3600.0
_NUMBERED = re.compile(r"^(\d{4,})-")
_ROLE_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")

README = """\
# Exchange directory

A procedura-brep run is using this directory as its model. For each request it writes
`NNNN-ROLE.request.md` (plus `NNNN-ROLE-K.png` images) and waits for `NNNN-ROLE.reply.md`.
Read the request, look at the images, and write your whole answer into the reply file
(save it under another name and rename it, or write it in one go). The file content is the reply.
"""


def render_request(request: Request, *, stem: str, image_names: list[str]) -> str:
    """The markdown text of a request file.

    Args:
        request: The request.
        stem: ``NNNN-role``; the reply goes to ``{stem}.reply.md``.
        image_names: File names of the request's images, in order.

    Returns:
        Markdown.
    """
    s = request.settings
    if s.output == "image":
        lines = [
            f"# Request {stem} (role: {request.role}, step: {request.step}): an image",
            "",
            (f"Write one PNG image of {s.image_size} pixels to `{stem}.reply.png` in this "
             f"directory (save it under another name, then rename it)."),
        ]
    else:
        lines = [
            f"# Request {stem} (role: {request.role}, step: {request.step})",
            "",
            f"Write your reply to `{stem}.reply.md` in this directory. The whole file is the reply.",
            (f"Settings: max_tokens={s.max_tokens}, temperature={s.temperature}, "
             f"json_mode={s.json_mode}."),
        ]
    if s.json_mode:
        lines.append("Reply with a single JSON object and nothing else.")
    lines += ["", "## System", "", request.system or "(none)", ""]
    names = iter(image_names)
    for i, m in enumerate(request.messages, start=1):
        lines += [f"## Message {i} ({m.role})", "", m.text, ""]
        for k, _ in enumerate(m.images, start=1):
            name = next(names)
            lines += [f"![image {k}]({name})", ""]
    return "\n".join(lines)


class ExchangeProvider(Provider):
    """Writes requests to a directory and waits for reply files.

    Args:
        model: The exchange directory (created if needed).
        timeout_s: Seconds to wait for each reply file.
        poll_s: Seconds between checks for the reply file.
        progress_every_s: Seconds between progress lines while waiting.
        progress: Called with each progress line (default: ``logging`` at INFO).
    """

    prefix = "exchange"
    vision = True
    json_mode = True
    prompt_caching = False
    network = False
    image_output = True

    def __init__(
        self,
        model: str,
        *,
        base_url: str | None = None,
        timeout_s: float | None = None,
        max_retries: int | None = None,
        poll_s: float = 0.5,
        progress_every_s: float = 30.0,
        progress: Callable[[str], None] | None = None,
    ) -> None:
        super().__init__(model)
        del base_url, max_retries
        if not model:
            raise ConfigError("exchange: no directory; write exchange:DIR")
        self.dir = Path(model)
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(f"exchange: cannot create directory {self.dir}: {exc}") from None
        self.endpoint = str(self.dir)
        self.timeout_s = float(timeout_s or DEFAULT_EXCHANGE_TIMEOUT_S)
        self.poll_s = poll_s
        self.progress_every_s = progress_every_s
        self.progress = progress or (lambda line: log.info("%s", line))
        numbers = [int(m.group(1)) for p in self.dir.iterdir() if (m := _NUMBERED.match(p.name))]
        self._next = max(numbers, default=0) + 1
        readme = self.dir / "README.md"
        if not readme.exists():
            readme.write_text(README, encoding="utf-8")

    def write_request(self, request: Request) -> Path:
        """Write the request file and images; return the path of the awaited reply file."""
        stem = f"{self._next:04d}-{_ROLE_SAFE.sub('_', request.role) or 'call'}"
        self._next += 1
        names = []
        for k, img in enumerate(request.images, start=1):
            name = f"{stem}-{k}.png"
            (self.dir / name).write_bytes(img.png)
            names.append(name)
        tmp = self.dir / f".{stem}.request.md.tmp"
        tmp.write_text(render_request(request, stem=stem, image_names=names), encoding="utf-8")
        os.replace(tmp, self.dir / f"{stem}.request.md")
        return self.dir / f"{stem}.reply.md"

    @overload
    def wait_for(self, reply_path: Path, *, binary: Literal[False] = False) -> str: ...

    @overload
    def wait_for(self, reply_path: Path, *, binary: Literal[True]) -> bytes: ...

    def wait_for(self, reply_path: Path, *, binary: bool = False) -> str | bytes:
        """Wait until ``reply_path`` exists, is non-empty and stops changing; return its text
        (or its bytes, ``binary``).

        Raises:
            ExchangeTimeout: Nothing usable within the timeout.
        """
        start = time.monotonic()
        last_progress = start
        seen: tuple[int, int] | None = None
        self.progress(f"exchange: waiting for {reply_path} (timeout {self.timeout_s:g} s)")
        while True:
            now = time.monotonic()
            try:
                st = reply_path.stat()
                sig = (st.st_size, st.st_mtime_ns)
                if st.st_size > 0 and sig == seen:
                    if binary:
                        return reply_path.read_bytes()
                    return reply_path.read_text(encoding="utf-8").strip()
                seen = sig
            except FileNotFoundError:
                seen = None
            if now - start >= self.timeout_s:
                raise ExchangeTimeout(
                    f"exchange: no reply file {reply_path} after {self.timeout_s:g} s; write it "
                    f"and rerun, or raise the timeout"
                )
            if now - last_progress >= self.progress_every_s:
                last_progress = now
                self.progress(
                    f"exchange: still waiting for {reply_path.name} "
                    f"({now - start:.0f} s of {self.timeout_s:g} s)"
                )
            time.sleep(self.poll_s)

    def complete(self, request: Request) -> Reply:
        """Write the request and wait for the reply file; see :class:`Provider`.

        An image request (``Settings(output="image")``) waits for ``NNNN-ROLE.reply.png``."""
        start = time.monotonic()
        reply_path = self.write_request(request)
        if request.settings.output == "image":
            png_path = reply_path.with_name(reply_path.name.removesuffix(".md") + ".png")
            png = self.wait_for(png_path, binary=True)
            if not png.startswith(b"\x89PNG\r\n\x1a\n"):
                raise MalformedReplyError(f"exchange: {png_path} is not a PNG file")
            return Reply("", Usage(), time.monotonic() - start, self.name,
                         images=(Image(png, png_path.name),))
        text = self.wait_for(reply_path)
        return Reply(text, Usage(), time.monotonic() - start, self.name)
