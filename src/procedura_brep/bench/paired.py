"""Paired comparison of two variants over the same cases: mean difference with a t interval,
wins / losses / ties, and a two-sided sign test (``scipy.stats.binomtest``), as the paper's
paired gain over the base model."""

from __future__ import annotations

import math
from typing import Any

from scipy import stats

from .settings import BENCH

PAIRED_COLUMNS: tuple[str, ...] = ("overall", "geo", "aes", "sem", "clip")


def compare(rows: list[dict[str, Any]], a: str, b: str, column: str) -> dict[str, Any]:
    """``a`` minus ``b`` on ``column``, over the cases where both have a value."""
    by = {(r["case"], r["variant"]): r for r in rows}
    cases = sorted({r["case"] for r in rows})
    diffs = [by[(c, a)][column] - by[(c, b)][column] for c in cases
             if (c, a) in by and (c, b) in by
             and by[(c, a)].get(column) is not None and by[(c, b)].get(column) is not None]
    n = len(diffs)
    wins, losses = sum(d > 0 for d in diffs), sum(d < 0 for d in diffs)
    out: dict[str, Any] = {"a": a, "b": b, "column": column, "n": n, "wins": wins, "losses": losses,
                           "ties": n - wins - losses, "mean_diff": None, "ci_low": None, "ci_high": None,
                           "sign_p": None, "level": BENCH.interval_level}
    if n == 0:
        return out
    mean = sum(diffs) / n
    out["mean_diff"] = round(mean, 6)
    if n >= 2:
        sd = math.sqrt(sum((d - mean) ** 2 for d in diffs) / (n - 1))
        half = float(stats.t.ppf(0.5 + BENCH.interval_level / 2, n - 1)) * sd / math.sqrt(n)
        out["ci_low"], out["ci_high"] = round(mean - half, 6), round(mean + half, 6)
    if wins + losses:
        out["sign_p"] = round(float(stats.binomtest(wins, wins + losses, 0.5).pvalue), 6)
    return out


def pairs_of(variants: tuple[str, ...], pairs: tuple[tuple[str, str], ...] | None) -> tuple[tuple[str, str], ...]:
    """The pairs to compare: as given, else every other variant against the first."""
    if pairs:
        return pairs
    return tuple((variants[0], v) for v in variants[1:])


def paired_table(rows: list[dict[str, Any]], pairs: tuple[tuple[str, str], ...]) -> list[dict[str, Any]]:
    """Every pair on every paired column that has values."""
    out = []
    for a, b in pairs:
        for col in PAIRED_COLUMNS:
            res = compare(rows, a, b, col)
            if res["n"]:
                out.append(res)
    return out
