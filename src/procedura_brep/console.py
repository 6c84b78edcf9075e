"""What the CLI prints: one-line errors, and the ``check`` and ``simulate`` tables.

Part, mate and check names, measured values and messages come from a program (or a model), so
every cell goes through :func:`procedura_brep.text.markup_safe` (no escape sequences, no
control characters, rich markup escaped, length capped) before ``rich`` sees it.
"""

from __future__ import annotations

import sys
from typing import Any

import typer

from .findings import blocking, blocks
from .text import markup_safe, terminal_safe

#: Cells in the tables are cut to this many characters (full values are in the JSON).
CELL_CHARS = 60


def err(msg: str) -> None:
    """``error: MSG`` on stderr, as one safe line."""
    typer.echo(f"error: {terminal_safe(msg)}", err=True)


def more(lines: list[str]) -> None:
    """Further error lines (``-v``), indented, on stderr."""
    for line in lines:
        typer.echo(f"  also: {terminal_safe(line)}", err=True)


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return markup_safe(v, limit=CELL_CHARS)


def _num(v: Any) -> str:
    return f"{v:.3g}" if isinstance(v, (int, float)) else markup_safe(v, limit=CELL_CHARS)


#: Unit suffixes of the battery's measured keys, longest first, and how a cell writes them.
_UNITS: tuple[tuple[str, str], ...] = (
    ("_mm3", "mm^3"), ("_mm2", "mm^2"), ("_mps", "m/s"), ("_rad", "rad"), ("_deg", "deg"),
    ("_mm", "mm"), ("_Nm", "N m"), ("_m", "m"), ("_s", "s"), ("_N", "N"), ("_kg", "kg"))


def _quantity(key: str, value: Any) -> str:
    """One measured value in words: ``anchor err 0 m``, ``joints: 3 (per joint in --json)``."""
    name, unit = key, ""
    for suffix, word in _UNITS:
        if key.endswith(suffix):
            name, unit = key[: -len(suffix)], word
            break
    name = name.replace("_", " ")
    if isinstance(value, bool):
        return f"{name}: {'yes' if value else 'no'}"
    if isinstance(value, (int, float)):
        return f"{name} {_num(value)}" + (f" {unit}" if unit else "")
    if isinstance(value, (dict, list, tuple)):
        return f"{name}: {len(value)} (each in --json)"
    return f"{name}: {markup_safe(value, limit=CELL_CHARS)}"


def _measured_cell(check: dict[str, Any]) -> str:
    """A check's measured values, one per line, each with its limit where it has one."""
    limits = check.get("limits") or {}
    rows = []
    for key, value in (check.get("measured") or {}).items():
        row = _quantity(key, value)
        if key in limits and not isinstance(limits[key], (dict, list)):
            lim = limits[key]
            row += f" (limit {'yes' if lim is True else 'no' if lim is False else _num(lim)})"
        rows.append(row)
    return "\n".join(rows)


def print_battery(data: dict[str, Any]) -> None:
    """The battery as a table: a row per check with its verdict, its measured values (with
    units, each beside its limit; per-joint and per-pair detail is in ``--json``) and its
    message."""
    from rich.console import Console
    from rich.table import Table
    t = Table(title="MuJoCo battery")
    t.add_column("check")
    t.add_column("name")
    t.add_column("verdict")
    t.add_column("measured (limit)", overflow="fold")
    t.add_column("message", overflow="fold", ratio=1)
    for c in data["checks"]:
        verdict = {"skip": "[yellow]skip[/]", "fail": "[red]FAIL[/]",
                   "not verified": "[yellow]not verified[/]"}.get(c["status"], "[green]pass[/]")
        t.add_row(_cell(c["id"]), _cell(c.get("name", "")), verdict, _measured_cell(c),
                  markup_safe(c.get("message", "")))
    con = Console(file=sys.stdout)
    con.print(t)
    for n in data.get("notes", []):
        con.print(f"note: {markup_safe(n)}")
    if not data["passed"]:
        con.print("[red]a check failed[/]")
    elif data.get("verified", True):
        con.print("[green]all checks pass[/]")
    else:
        con.print("[yellow]no check failed, but not everything was verified[/] (see the checks "
                  "marked not verified)")


def print_check(data: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table
    con = Console(file=sys.stdout)
    model = markup_safe(data["model"], limit=CELL_CHARS)
    tp = Table(title=f"parts: {model}")
    for col in ("part", "triangles", "errors", "verdict"):
        tp.add_column(col)
    for name, tris in data["triangles_per_part"].items():
        errs = [f for f in blocking(data["findings"]) if f.get("part") == name]
        tp.add_row(_cell(name), str(tris), markup_safe("; ".join(f.get("code", "") for f in errs)),
                   "[red]FAIL[/]" if errs else "[green]pass[/]")
    con.print(tp)
    t = Table(title=f"mate gate: {model}")
    for col in ("mate", "area mm^2", "limit", "penetration mm", "limit", "verdict"):
        t.add_column(col)
    for name, m in data["mates"].items():
        t.add_row(_cell(name), _num(m.get("area_mm2", float("nan"))),
                  _num(m.get("area_limit_mm2", float("nan"))), _num(m.get("penetration_mm", float("nan"))),
                  _num(m.get("penetration_limit_mm", float("nan"))),
                  "[green]pass[/]" if m.get("passed") else "[red]FAIL[/]")
    con.print(t)
    conn, met = data["connectivity"], data["metrics"]
    t2 = Table(title="connectivity and metrics")
    t2.add_column("measure")
    t2.add_column("value")
    for k, v in (("N_vis (tau = %g)" % conn.get("tau", 0.01), conn.get("n_vis")),
                 ("components", conn.get("components")), ("span mm", conn.get("span_mm")),
                 ("triangles", met.get("triangles")), ("Shrp60 mm", met.get("shrp60_mm")),
                 ("Shrp60 / span", met.get("shrp60_per_span")), ("Dih95 deg", met.get("dih95_deg"))):
        t2.add_row(k, markup_safe(v, limit=CELL_CHARS))
    con.print(t2)
    for f in data["findings"]:
        colour = "red" if blocks(f) else "yellow"
        con.print(f"[{colour}]{markup_safe(f.get('severity'))}[/] {markup_safe(f.get('code'))}: "
                  f"{markup_safe(f.get('message'))}")
    unverified = [f for f in data.get("findings", []) if f.get("code") == "not-verified"]
    if not data["passed"]:
        con.print("[red]a gate failed[/]")
    elif unverified:
        con.print(f"[yellow]no gate failed, but {len(unverified)} overlap(s) not verified[/] "
                  "(see the not-verified warnings)")
    else:
        con.print("[green]all gates pass[/]")


__all__ = ["err", "more", "print_battery", "print_check", "CELL_CHARS"]
