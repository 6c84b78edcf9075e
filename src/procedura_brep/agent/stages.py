"""The staged run as data: its stages in order, and what a stage needs from the run.

:data:`STAGES` is the one table of the staged agent's stages: each row names the stage (the
value ``state.json`` keeps while the stage is next or under way), the :class:`StagedRun
<procedura_brep.agent.staged.StagedRun>` method that runs it, and what it reads and writes. The
run executes the rows from its current stage on and moves to the next row when a stage returns
(:meth:`StagedRun.run <procedura_brep.agent.staged.StagedRun.run>`), so ``--resume`` starts at
the row a killed run had reached; adding a stage is one row here and its method. A stage that is
switched off (``--no-refine``) returns at once.

:class:`StageHost` is what a stage module (refine, materials, articulation) may use of the run
that hosts it: one protocol, public names only. ``revise`` hosts the refine loop with a smaller
run of its own that has the same shape.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from ..llm import Image, Message


@dataclass(frozen=True)
class Stage:
    """One row of the table."""

    name: str
    method: str  # the StagedRun method that runs it
    reads: str
    writes: str


STAGES: tuple[Stage, ...] = (
    Stage("plan", "stage_plan", "the prompt and the reference image",
          "state.plan, state.repairs"),
    Stage("review", "stage_review", "state.plan", "state.plan, state.repairs"),
    Stage("build", "stage_build", "state.plan, the committed parts",
          "state.committed, state.skipped, state.source, history/ after each part"),
    Stage("refine", "stage_refine", "state.source, state.plan",
          "state.source, state.refine (and state.plan, state.committed for parts it adds)"),
    Stage("materials", "stage_materials", "state.source", "state.source, state.materials"),
    Stage("articulation", "stage_articulation", "state.source",
          "state.source, state.articulation, the run directory's build"),
    Stage("finish", "stage_finish", "state.source and every stage's report",
          "the run directory (exports, gates, battery) and report.json"),
)
#: Every value ``state.stage`` may hold: the rows, then ``done``.
STAGE_NAMES: tuple[str, ...] = (*(s.name for s in STAGES), "done")


def next_stage(name: str) -> str:
    """The stage after ``name`` (``done`` after the last row)."""
    return STAGE_NAMES[STAGE_NAMES.index(name) + 1]


class StageHost(Protocol):
    """What a stage may use of the run that hosts it."""

    tools: Any
    options: Any
    state: Any
    out_dir: Path
    name: str
    prompt: str

    def call(self, role: str, system: str, messages: list[Message], *, max_tokens: int = ...) -> str:
        """One model call with this role (numbered by the run's step)."""
        ...

    def refs(self) -> list[Image]:
        """The reference images every request of the run carries."""
        ...

    def progress(self, stage: str, text: str) -> None:
        """One line of progress."""
        ...
