"""The prompts file and the variants a bench compares.

A prompts file is TOML: an optional ``name`` and one ``[[case]]`` table per case with ``id``
(snake_case, unique), ``prompt`` (one sentence) and optionally ``source`` and ``cpus``. The
bundled set is MechBench-36 (reconstructed): :func:`default_prompts`.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Literal

from ..errors import ProceduraError
from .settings import BENCH

ID_RE = re.compile(r"^[a-z][a-z0-9_]{0,63}$")
Mode = Literal["staged", "oneshot"]


class BenchError(ProceduraError):
    """A bench input a user can fix: the prompts file, a variant name, an option, an output dir."""


@dataclass(frozen=True)
class Variant:
    """One row of the comparison: how ``generate`` is called (the paper's Table 3 switches)."""

    name: str
    mode: Mode = "staged"
    plan: bool = True
    review: bool = True
    feedback: bool = True
    refine: bool = True


VARIANTS: dict[str, Variant] = {v.name: v for v in (
    Variant("full"),
    Variant("one-shot", mode="oneshot"),
    Variant("no-refine", refine=False),
    Variant("no-plan", plan=False),
    Variant("no-review", review=False),
    Variant("no-feedback", feedback=False),
)}


def parse_variants(text: str) -> tuple[str, ...]:
    """``"full,one-shot"`` -> the names, checked (order kept, duplicates dropped).

    Raises:
        BenchError: an unknown name or an empty list.
    """
    names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    bad = [n for n in names if n not in VARIANTS]
    if bad:
        raise BenchError(f"unknown variant(s) {', '.join(bad)}; variants: {', '.join(VARIANTS)}")
    if not names:
        raise BenchError(f"no variants given; variants: {', '.join(VARIANTS)}")
    return names


@dataclass(frozen=True)
class Case:
    """One benchmark prompt."""

    id: str
    prompt: str
    source: str = ""
    cpus: float = BENCH.default_cpus


@dataclass(frozen=True)
class PromptSet:
    """A prompts file: its name, its cases in file order, and where it came from."""

    name: str
    cases: tuple[Case, ...]
    path: str


def default_prompts() -> Path:
    """The bundled MechBench-36 (reconstructed) prompts file."""
    return Path(str(resources.files(__package__) / "prompts" / "mechbench36.toml"))


def load_cases(path: Path | None = None) -> PromptSet:
    """Read and check a prompts file (``None``: the bundled MechBench-36).

    Raises:
        BenchError: unreadable file, not TOML, no cases, a bad or repeated id, an empty prompt,
            a ``cpus`` outside (0, 64].
    """
    p = Path(path) if path is not None else default_prompts()
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise BenchError(f"cannot read prompts file {p}: {(exc.strerror or str(exc)).lower()}") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise BenchError(f"prompts file {p} is not valid TOML: {exc}") from None
    rows = data.get("case")
    if not isinstance(rows, list) or not rows:
        raise BenchError(f"prompts file {p} has no cases: add [[case]] tables with id and prompt")
    cases: list[Case] = []
    seen: set[str] = set()
    for n, row in enumerate(rows, start=1):
        cid = row.get("id") if isinstance(row, dict) else None
        if not isinstance(cid, str) or not ID_RE.match(cid):
            raise BenchError(f"prompts file {p} case {n}: id {cid!r} must be snake_case "
                             "(a-z, 0-9, _; starting with a letter; at most 64 characters)")
        if cid in seen:
            raise BenchError(f"prompts file {p} case {n}: id {cid!r} is used twice")
        seen.add(cid)
        prompt = row.get("prompt")
        if not isinstance(prompt, str) or not prompt.strip():
            raise BenchError(f"prompts file {p} case {cid}: prompt must be a non-empty string")
        cpus = row.get("cpus", BENCH.default_cpus)
        if not isinstance(cpus, (int, float)) or isinstance(cpus, bool) or not 0 < cpus <= BENCH.max_jobs:
            raise BenchError(f"prompts file {p} case {cid}: cpus = {cpus!r} is outside (0, {BENCH.max_jobs}]")
        cases.append(Case(cid, " ".join(prompt.split()), str(row.get("source", "")), float(cpus)))
    return PromptSet(str(data.get("name", p.stem)), tuple(cases), str(p))
