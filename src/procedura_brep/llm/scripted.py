"""``scripted:`` — the test double: a queue of replies, shipped in the library.

Each queued item is a reply text, a :class:`~procedura_brep.llm.messages.Reply`, an exception
to raise, or a callable ``(Request) -> str | Reply``. Requests are kept in
:attr:`ScriptedProvider.requests` for assertions.
"""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Union

from .base import Provider
from .errors import ConfigError, ReplayMismatch, TapeNotConsumed
from .messages import Reply, Request, Usage

__all__ = ["ScriptItem", "ScriptedProvider"]

ScriptItem = Union[str, Reply, BaseException, Callable[[Request], Union[str, Reply]]]


class ScriptedProvider(Provider):
    """Answers requests from a queue.

    Args:
        model: A label; if it names a ``.json`` file holding a list of strings, those are
            queued (``scripted:replies.json``).
        replies: Items to queue.
        usage: Usage reported for plain-text replies.
    """

    prefix = "scripted"
    vision = True
    json_mode = True
    prompt_caching = False
    network = False
    image_output = True

    def __init__(
        self,
        model: str = "test",
        *,
        replies: Iterable[ScriptItem] = (),
        usage: Usage | None = None,
        base_url: str | None = None,
        timeout_s: float | None = None,
        max_retries: int | None = None,
    ) -> None:
        super().__init__(model or "test")
        del base_url, timeout_s, max_retries
        self.endpoint = f"scripted:{self.model}"
        self.usage = usage or Usage()
        self.requests: list[Request] = []
        self._queue: deque[ScriptItem] = deque(replies)
        if self.model.endswith(".json"):
            path = Path(self.model)
            try:
                items = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                raise ConfigError(f"scripted: cannot read {path}: {exc}") from None
            if not isinstance(items, list) or not all(isinstance(i, str) for i in items):
                raise ConfigError(f"scripted: {path} must hold a JSON list of reply strings")
            self._queue.extend(items)

    def push(self, *items: ScriptItem) -> None:
        """Queue more items."""
        self._queue.extend(items)

    @property
    def remaining(self) -> int:
        """Number of queued items not used yet."""
        return len(self._queue)

    def complete(self, request: Request) -> Reply:
        """Pop the next item and answer with it.

        Raises:
            ReplayMismatch: The queue is empty.
        """
        self.requests.append(request)
        if not self._queue:
            raise ReplayMismatch(f"scripted: no reply queued for role={request.role!r} step={request.step}")
        item = self._queue.popleft()
        if isinstance(item, BaseException):
            raise item
        if callable(item) and not isinstance(item, Reply):
            item = item(request)
        if isinstance(item, Reply):
            return Reply(item.text, item.usage, item.latency_s, item.model or self.name,
                         images=item.images)
        return Reply(str(item), self.usage, 0.0, self.name)

    def assert_consumed(self) -> None:
        """Raise :class:`TapeNotConsumed` if queued items are left."""
        if self._queue:
            raise TapeNotConsumed(f"scripted: {len(self._queue)} queued reply(ies) never requested")
