"""One row per case x variant, read from the run directory and the judge's scores.

A run *shipped* when the agent finished it and its bundle holds a mesh (``model.step`` and the
report's parts). A case that shipped nothing scores 0 on every judge axis, Shrp60, Dih95, parts,
mate-gate pass rate and battery, and stays in the mean (the paper's rule); its N_vis and
interference count are not defined (null).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .runner import RUN_RECORD, finished, read_json, run_dir

COLUMNS: tuple[str, ...] = (
    "geo", "aes", "sem", "overall", "clip", "shrp60", "dih95", "parts", "n_vis", "mate_pass",
    "interference", "battery", "tokens", "cost_usd", "wall_s", "cpu_s", "peak_rss_mb")
"""Numeric columns of a row, in table order."""
TIMING_COLUMNS: tuple[str, ...] = ("wall_s", "cpu_s", "peak_rss_mb")
"""Measured per machine: excluded when two benches are compared for equality."""
ZERO_WHEN_EMPTY: tuple[str, ...] = ("geo", "aes", "sem", "overall", "shrp60", "dih95", "parts",
                                    "mate_pass", "battery")


def shipped(rdir: Path) -> bool:
    """The agent finished and the bundle holds a mesh of at least one part."""
    report = read_json(rdir / "report.json") or {}
    return (finished(rdir) and bool(report.get("parts")) and (rdir / "program.py").is_file()
            and (rdir / "model.step").is_file())


def _mate_pass(gates: dict[str, Any]) -> float | None:
    mates = gates.get("mates") or {}
    if not mates:
        return None
    return sum(1 for m in mates.values() if m.get("passed")) / len(mates)


def _battery(report: dict[str, Any], record: dict[str, Any]) -> float | None:
    bat = report.get("battery") or record.get("battery")
    if not isinstance(bat, dict) or "passed" not in bat:
        return None
    return 1.0 if bat["passed"] else 0.0


def make_row(out: Path, case: str, variant: str, *, scores: dict[str, Any] | None,
             clip: float | None) -> dict[str, Any]:
    """The row of one case x variant (``scores``: the judge's 0-1 scores or None)."""
    rdir = run_dir(out, case, variant)
    report = read_json(rdir / "report.json") or {}
    record = read_json(rdir / RUN_RECORD) or {}
    usage = ((report.get("usage") or {}).get("total") or {})
    row: dict[str, Any] = {"case": case, "variant": variant,
                           "status": report.get("status") if finished(rdir) else record.get("status", "missing"),
                           "shipped": shipped(rdir), "judged": scores is not None}
    tokens = (usage.get("input_tokens") or 0) + (usage.get("output_tokens") or 0) if usage else None
    row.update({"tokens": tokens, "cost_usd": usage.get("cost_usd"),
                "wall_s": record.get("wall_s"), "cpu_s": record.get("cpu_s"),
                "peak_rss_mb": record.get("peak_rss_mb"), "clip": clip})
    if not row["shipped"]:
        row.update({k: 0.0 for k in ZERO_WHEN_EMPTY})
        row.update({"n_vis": None, "interference": None})
        row["clip"] = 0.0 if clip is not None else None
        return row
    gates = report.get("gates") or {}
    metrics = gates.get("metrics") or {}
    s = scores or {}
    geo, aes, sem = s.get("geometry"), s.get("aesthetics"), s.get("semantic")
    row.update({
        "geo": geo, "aes": aes, "sem": sem,
        "overall": (geo + aes + sem) / 3 if None not in (geo, aes, sem) else None,
        "shrp60": metrics.get("shrp60_per_span"), "dih95": metrics.get("dih95_deg"),
        "parts": float(len(report.get("parts") or [])),
        "n_vis": gates.get("n_vis"),
        "mate_pass": _mate_pass(gates),
        "interference": float(len((gates.get("interference") or {}).get("pairs") or [])),
        "battery": _battery(report, record),
    })
    return row
