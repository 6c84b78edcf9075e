"""The staged run's directory state: written atomically after every commit, read on resume.

``state.json`` holds what a killed run needs to continue without losing or redoing a committed
part: the prompt, the next model-call step, the stage, the plan, every committed part (as it was
spliced), the parts skipped and why, the running N_vis baseline, and the program. ``program.py``
is the latest committed program and ``history/NNN-<part>.py`` the program after each commit.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ProceduraError
from ..paths import write_atomic
from .context import CommittedPart
from .stages import STAGE_NAMES

#: A value of ``state.stage``: a row of :data:`.stages.STAGES`, or ``done``.
Stage = str
STATE_VERSION = 1


class ResumeError(ProceduraError):
    """``--resume DIR`` names a directory without a resumable staged run."""


@dataclass
class RunState:
    """Everything a staged run has committed so far."""

    prompt: str
    step: int = 0
    stage: Stage = "plan"
    plan: dict[str, Any] | None = None
    repairs: list[str] = field(default_factory=list)
    committed: list[CommittedPart] = field(default_factory=list)
    skipped: list[dict[str, str]] = field(default_factory=list)
    baseline: int = 0
    source: str = ""
    per_part_s: dict[str, float] = field(default_factory=dict)
    materials: dict[str, Any] = field(default_factory=dict)  # the materials stage's report
    refine: dict[str, Any] = field(default_factory=dict)  # the refine stage's report
    articulation: dict[str, Any] = field(default_factory=dict)  # the articulation stage's report

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["version"] = STATE_VERSION
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RunState:
        d = dict(d)
        if d.pop("version", None) != STATE_VERSION:
            raise ResumeError("state.json is from another version of the tool; start a new run")
        d["committed"] = [CommittedPart(**c) for c in d.get("committed", [])]
        if d.get("stage", "plan") not in STAGE_NAMES:
            raise ResumeError(f"state.json names the stage {d.get('stage')!r}, which this version "
                              f"does not have ({', '.join(STAGE_NAMES)}); start a new run")
        return cls(**d)


def history_path(out_dir: Path, label: str) -> Path:
    """``history/NNN-<label>.py`` with the next free number: one numbering for every stage that
    writes the program back (commits, refine, materials, articulation, revise), so no two
    entries share a number."""
    folder = out_dir / "history"
    taken = [int(p.name[:3]) for p in folder.glob("[0-9][0-9][0-9]-*") if p.name[:3].isdigit()] \
        if folder.is_dir() else []
    return folder / f"{max(taken, default=0) + 1:03d}-{label}.py"


class RunDir:
    """Atomic writes of a staged run's files."""

    def __init__(self, root: Path) -> None:
        self.root = root

    @property
    def state_path(self) -> Path:
        return self.root / "state.json"

    def save(self, state: RunState) -> None:
        """Write program.py, then state.json (so a state never names a program not on disk)."""
        if state.source:
            write_atomic(self.root / "program.py", state.source)
        write_atomic(self.state_path, json.dumps(state.as_dict(), indent=1, ensure_ascii=False) + "\n")

    def commit(self, state: RunState, part: str) -> None:
        """Record one committed part: its history file, then the state."""
        k = len(state.committed)
        write_atomic(self.root / "history" / f"{k:03d}-{part}.py", state.source)
        self.save(state)

    def attempt(self, state: RunState, part: str, attempt: int, text: str) -> None:
        """Why an attempt at a part failed (history/NNN-<part>.attempt-K.txt)."""
        k = len(state.committed) + 1
        write_atomic(self.root / "history" / f"{k:03d}-{part}.attempt-{attempt}.txt", text)

    def load(self) -> RunState:
        if not self.state_path.is_file():
            raise ResumeError(f"cannot resume {self.root}: no state.json (not a staged run directory)")
        try:
            return RunState.from_dict(json.loads(self.state_path.read_text(encoding="utf-8")))
        except (ValueError, TypeError, KeyError) as exc:
            raise ResumeError(f"cannot resume {self.root}: state.json is unreadable ({exc})") from None
