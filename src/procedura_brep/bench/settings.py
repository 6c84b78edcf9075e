"""The fixed settings of the bench protocol (one documented object, like ``config.TOL``).

These are protocol choices, not geometric tolerances: changing one changes every judged row, so
they live in one place and are recorded in ``DIR/bench.json``.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BenchSettings:
    """Bench protocol settings.

    Attributes:
        judge_views: the one fixed view set every shipped model is re-rendered from for the judge
            (catalog names of :mod:`procedura_brep.render.views`).
        judge_size: side of each grey-clay judge image, pixels.
        judge_max_tokens: reply budget of one judge call.
        score_low: lowest judge score (maps to 0 by clamp((v - low) / (high - low))).
        score_high: highest judge score (maps to 1).
        interval_level: confidence level of the paired-difference interval.
        hash_chars: length of the opaque hex id a judged model is named by.
        default_cpus: CPUs one case asks for (``--ray`` ``num_cpus``) when its prompt entry says
            nothing: the agent's process; its compile worker mostly waits on it.
        max_jobs: the largest ``--jobs``.
    """

    judge_views: tuple[str, ...] = ("iso_se", "iso_nw", "front", "right", "top")
    judge_size: int = 512
    judge_max_tokens: int = 800
    score_low: float = 1.0
    score_high: float = 10.0
    interval_level: float = 0.95
    hash_chars: int = 16
    default_cpus: float = 1.0
    max_jobs: int = 64


BENCH = BenchSettings()
