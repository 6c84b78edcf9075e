"""Markdown, CSV and JSON tables: one summary row per variant (means over every case; a case
that shipped nothing counts as 0), the per-case rows, and the paired comparisons."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from ..paths import write_atomic
from .rows import COLUMNS

HEADERS: dict[str, str] = {
    "geo": "Geo", "aes": "Aes", "sem": "Sem", "overall": "Overall", "clip": "CLIP",
    "shrp60": "Shrp60", "dih95": "Dih95", "parts": "parts", "n_vis": "N_vis",
    "mate_pass": "mate pass", "interference": "interf.", "battery": "battery pass",
    "tokens": "tokens", "cost_usd": "cost $", "wall_s": "wall s", "cpu_s": "CPU s",
    "peak_rss_mb": "peak MB"}
SUM_COLUMNS: tuple[str, ...] = ("tokens", "cost_usd")
"""Summed over the cases (the rest are means)."""
DIGITS = 4


def _r(v: Any) -> Any:
    return round(v, DIGITS) if isinstance(v, float) else v


def summarise(rows: list[dict[str, Any]], variants: tuple[str, ...]) -> list[dict[str, Any]]:
    """One row per variant: the mean of every column over the cases that have a value (the sum
    for tokens and cost), how many cases, shipped and judged."""
    out = []
    for v in variants:
        mine = [r for r in rows if r["variant"] == v]
        s: dict[str, Any] = {"variant": v, "cases": len(mine), "shipped": sum(r["shipped"] for r in mine),
                             "judged": sum(r["judged"] for r in mine)}
        for col in COLUMNS:
            vals = [r[col] for r in mine if r.get(col) is not None]
            if not vals:
                s[col] = None
            elif col in SUM_COLUMNS:
                s[col] = _r(float(sum(vals)))
            else:
                s[col] = _r(sum(vals) / len(vals))
        out.append(s)
    return out


def _cell(v: Any) -> str:
    if v is None:
        return "n/c"  # not computed
    if isinstance(v, float):
        return f"{v:.{DIGITS}g}" if abs(v) >= 1000 else f"{v:.3f}"
    return str(v)


def markdown(title: str, summary: list[dict[str, Any]], paired: list[dict[str, Any]]) -> str:
    """The summary table and the paired comparisons as markdown."""
    cols = ["variant", "cases", "shipped", "judged", *COLUMNS]
    lines = [f"# {title}", "", "| " + " | ".join(HEADERS.get(c, c) for c in cols) + " |",
             "|" + "---|" * len(cols)]
    lines += ["| " + " | ".join(_cell(s.get(c)) for c in cols) + " |" for s in summary]
    lines += ["", "n/c: not computed (CLIP without configured weights, a column with no value).", ""]
    if paired:
        lines += ["## Paired comparison (a - b per case; sign test, t interval)", "",
                  "| a | b | column | n | mean diff | interval | wins | losses | ties | sign p |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for p in paired:
            ci = (f"[{p['ci_low']:.3f}, {p['ci_high']:.3f}] ({p['level']:.0%})"
                  if p["ci_low"] is not None else "n/c")
            lines.append(f"| {p['a']} | {p['b']} | {p['column']} | {p['n']} | {_cell(p['mean_diff'])} | "
                         f"{ci} | {p['wins']} | {p['losses']} | {p['ties']} | {_cell(p['sign_p'])} |")
        lines.append("")
    return "\n".join(lines)


def to_csv(rows: list[dict[str, Any]], fields: list[str]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else _r(r.get(k))) for k in fields})
    return buf.getvalue()


def write_tables(out: Path, *, title: str, rows: list[dict[str, Any]], summary: list[dict[str, Any]],
                 paired: list[dict[str, Any]], meta: dict[str, Any]) -> dict[str, Path]:
    """Write ``DIR/tables/`` (summary.md/.csv/.json, cases.csv, paired.csv); returns the paths."""
    tdir = Path(out) / "tables"
    files = {
        "summary.md": markdown(title, summary, paired),
        "summary.csv": to_csv(summary, ["variant", "cases", "shipped", "judged", *COLUMNS]),
        "cases.csv": to_csv(rows, ["case", "variant", "status", "shipped", "judged", *COLUMNS]),
        "paired.csv": to_csv(paired, ["a", "b", "column", "n", "mean_diff", "ci_low", "ci_high",
                                      "level", "wins", "losses", "ties", "sign_p"]),
        "summary.json": json.dumps({"title": title, **meta, "summary": summary, "paired": paired,
                                    "cases": [{k: _r(v) for k, v in r.items()} for r in rows]},
                                   indent=2, ensure_ascii=False) + "\n",
    }
    paths = {}
    for name, text in files.items():
        paths[name] = write_atomic(tdir / name, text)
    return paths
