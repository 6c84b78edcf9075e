"""``replay:PATH`` — deterministic playback of a transcript.

Requests are matched to recorded calls by ``(role, step)``; several calls with the same role and
step are played in recorded order. A request with no recorded reply raises
:class:`~procedura_brep.llm.errors.ReplayMismatch` naming it; :meth:`ReplayProvider.close` (and
:func:`procedura_brep.llm.testing.tape_guard` in tests) fails when recorded calls are left over.
"""

from __future__ import annotations

import logging
from collections import deque
from pathlib import Path

from .base import Provider
from .errors import ReplayMismatch, TapeNotConsumed
from .messages import Reply, Request
from .transcript import TapeEntry, read_tape, request_digest

__all__ = ["ReplayProvider"]

log = logging.getLogger(__name__)

# Guards opened by procedura_brep.llm.testing.tape_guard; each collects providers built inside.
_GUARDS: list[list[ReplayProvider]] = []


class ReplayProvider(Provider):
    """Plays back a tape.

    Args:
        model: Path of the tape (a ``transcript.jsonl`` or a run directory holding one).
        strict: Also require the request text and images to equal the recorded ones.
    """

    prefix = "replay"
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
        strict: bool = False,
    ) -> None:
        super().__init__(model)
        del base_url, timeout_s, max_retries  # meaningless for a tape
        self.path = Path(model)
        self.endpoint = str(self.path)
        self.strict = strict
        self._queues: dict[tuple[str, int], deque[TapeEntry]] = {}
        for entry in read_tape(self.path):
            self._queues.setdefault((entry.role, entry.step), deque()).append(entry)
        if _GUARDS:  # the innermost open guard owns this tape
            _GUARDS[-1].append(self)

    def complete(self, request: Request) -> Reply:
        """Return the next recorded reply for ``(request.role, request.step)``.

        Raises:
            ReplayMismatch: Nothing recorded (left) for this role and step, or, when strict,
                the request differs from the recorded one.
        """
        queue = self._queues.get((request.role, request.step))
        if not queue:
            left = ", ".join(self.unconsumed()[:8]) or "nothing"
            raise ReplayMismatch(
                f"replay {self.path}: no recorded reply for role={request.role!r} "
                f"step={request.step}; unplayed calls: {left}"
            )
        entry = queue.popleft()
        if entry.request_sha256 and entry.request_sha256 != request_digest(request):
            msg = (
                f"replay {self.path}: request role={request.role!r} step={request.step} differs "
                f"from the one recorded on line {entry.line}"
            )
            if self.strict:
                raise ReplayMismatch(msg)
            log.debug("%s (playing the recorded reply anyway)", msg)
        return Reply(entry.text, entry.usage, 0.0, self.name, images=entry.images)

    def skip_before(self, step: int) -> int:
        """Drop the recorded calls of steps before ``step`` (a resumed run played them already).

        Returns:
            How many recorded calls were dropped.
        """
        dropped = 0
        for key in [k for k in self._queues if k[1] < step]:
            dropped += len(self._queues.pop(key))
        return dropped

    def unconsumed(self) -> list[str]:
        """Labels ``role#step (line N)`` of recorded calls not played yet, in file order."""
        left = sorted((e for q in self._queues.values() for e in q), key=lambda e: e.line)
        return [f"{e.role}#{e.step} (line {e.line})" for e in left]

    def assert_consumed(self) -> None:
        """Raise :class:`TapeNotConsumed` when recorded calls are left over."""
        left = self.unconsumed()
        if left:
            shown = ", ".join(left[:8]) + (" ..." if len(left) > 8 else "")
            raise TapeNotConsumed(
                f"replay {self.path}: {len(left)} recorded call(s) never requested: {shown}"
            )

    def close(self) -> None:
        """End of run: the tape must be fully consumed."""
        self.assert_consumed()
