"""The bench: generate every case x variant (resumable, on any executor), judge blind, tabulate.

``DIR/bench.json`` records the protocol (prompt set, variants, salt, models, settings); a later
call on the same DIR keeps its salt, so item ids (and a judge transcript) stay valid.
:func:`rebuild` (``--from DIR``) never calls the generating model: it re-judges the stored runs
(with the judge model, or replaying ``DIR/judge/transcript.jsonl``) and rewrites the tables.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import secrets
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..llm import Client, Ledger, LLMError, Transcript, preflight
from ..paths import write_atomic
from .cases import BenchError, Case, PromptSet, load_cases
from .clip import ClipScorer, clip_setting
from .judge import Item, item_id, judge_items
from .paired import paired_table, pairs_of
from .rows import make_row, shipped
from .runner import read_json, run_dir
from .scale import execute
from .settings import BENCH
from .tables import summarise, write_tables

log = logging.getLogger(__name__)
Say = Callable[[str], None]


@dataclass(frozen=True)
class BenchOptions:
    """What a bench runs and how (see ``procedura-brep bench --help``)."""

    model: str
    prompts: Path | None = None
    variants: tuple[str, ...] = ("full", "one-shot")
    cases: tuple[str, ...] | None = None  # a subset of case ids (None: all)
    judge_model: str | None = None  # None: the generating model
    base_url: str | None = None
    judge_base_url: str | None = None
    jobs: int = 1
    ray: bool = False
    ray_address: str | None = None
    simulate: bool = True
    formats: tuple[str, ...] | None = None
    max_cost_usd: float | None = None  # per run
    salt: str | None = None  # None: DIR's, else a fresh random one
    clip_weights: str | None = None
    pairs: tuple[tuple[str, str], ...] | None = None


@dataclass
class BenchResult:
    """Where the tables are and what they say."""

    out: Path
    tables: dict[str, Path] = field(default_factory=dict)
    summary: list[dict[str, Any]] = field(default_factory=list)
    paired: list[dict[str, Any]] = field(default_factory=list)
    rows: list[dict[str, Any]] = field(default_factory=list)
    records: list[dict[str, Any]] = field(default_factory=list)
    judge_errors: int = 0

    @property
    def run_errors(self) -> list[dict[str, Any]]:
        """Records of runs that ended in an error (retried by the next call)."""
        return [r for r in self.records if r.get("status") == "error"]


def _meta_path(out: Path) -> Path:
    return Path(out) / "bench.json"


def _select(pset: PromptSet, ids: tuple[str, ...] | None) -> tuple[Case, ...]:
    if not ids:
        return pset.cases
    known = {c.id: c for c in pset.cases}
    bad = [i for i in ids if i not in known]
    if bad:
        raise BenchError(f"unknown case id(s) {', '.join(bad)} in {pset.path}; "
                         f"ids: {', '.join(list(known)[:8])}{' ...' if len(known) > 8 else ''}")
    return tuple(known[i] for i in ids)


def _check(opts: BenchOptions) -> None:
    if not 1 <= opts.jobs <= BENCH.max_jobs:
        raise BenchError(f"--jobs {opts.jobs} is outside [1, {BENCH.max_jobs}]")
    if opts.ray and opts.jobs > 1:
        raise BenchError("give --jobs N or --ray, not both (Ray sizes its own workers)")
    for a, b in opts.pairs or ():
        for v in (a, b):
            if v not in opts.variants:
                raise BenchError(f"--pair {a},{b}: {v} is not among the variants run "
                                 f"({', '.join(opts.variants)})")


def _protocol(out: Path, pset: PromptSet, cases: tuple[Case, ...], opts: BenchOptions) -> dict[str, Any]:
    """bench.json: kept salt and the union of cases and variants run into this DIR so far."""
    old = read_json(_meta_path(out)) or {}
    salt = opts.salt or old.get("salt") or secrets.token_hex(8)
    if opts.salt and old.get("salt") and old["salt"] != opts.salt:
        raise BenchError(f"{out} was judged with another salt; --salt must be {old['salt']!r} "
                         "or omitted (a different salt renames every judged item)")
    known = {c["id"]: c for c in old.get("cases", [])}
    known.update({c.id: dataclasses.asdict(c) for c in cases})
    variants = list(dict.fromkeys([*old.get("variants", []), *opts.variants]))
    meta = {"name": pset.name, "prompts": pset.path, "salt": salt, "cases": list(known.values()),
            "variants": variants, "model": opts.model, "judge_model": opts.judge_model or opts.model,
            "simulate": opts.simulate, "settings": dataclasses.asdict(BENCH)}
    Path(out).mkdir(parents=True, exist_ok=True)
    write_atomic(_meta_path(out), json.dumps(meta, indent=2, ensure_ascii=False) + "\n")
    return meta


def run_bench(out: Path, opts: BenchOptions, *, say: Say | None = None) -> BenchResult:
    """Generate (skipping finished runs), judge and tabulate into ``out``.

    Raises:
        BenchError: bad prompts file, variant, case id, option or Ray setup (one line).
        ConfigError: the model names an unknown provider or lacks a key (checked before any run).
    """
    tell = say or (lambda line: log.info("%s", line))
    _check(opts)
    pset = load_cases(opts.prompts)
    cases = _select(pset, opts.cases)
    clip = clip_setting(opts.clip_weights)  # a bad setting fails before any run
    from .runner import case_model
    if case_model(opts.model, "-", "-") == opts.model:  # one model for every run: check it once
        preflight(opts.model, base_url=opts.base_url)
    meta = _protocol(out, pset, cases, opts)
    tasks = [{"case": c.id, "variant": v, "prompt": c.prompt, "cpus": c.cpus, "out": str(Path(out).resolve()),
              "model": opts.model, "base_url": opts.base_url, "simulate": opts.simulate,
              "formats": list(opts.formats) if opts.formats else None, "max_cost_usd": opts.max_cost_usd}
             for c in cases for v in opts.variants]
    todo = sum(1 for t in tasks if not _finished(out, t))
    mode = "ray" if opts.ray else f"{opts.jobs} process(es)" if opts.jobs > 1 else "this process"
    tell(f"{len(tasks)} run(s), {len(tasks) - todo} finished already, {todo} to run on {mode}")

    def done(rec: dict[str, Any]) -> None:
        what = "finished earlier" if rec.get("resumed") else f"{rec.get('status')} in {rec.get('wall_s', 0):.1f} s"
        tell(f"{rec['case']}/{rec['variant']}: {what}" + (f" ({rec['error']})" if rec.get("error") else ""))

    records = execute(tasks, jobs=opts.jobs, ray=opts.ray, address=opts.ray_address, done=done)
    res = _judge_and_tabulate(out, meta, cases, opts.variants, judge_model=opts.judge_model or opts.model,
                              base_url=opts.judge_base_url or opts.base_url, clip=clip,
                              pairs=opts.pairs, say=tell)
    res.records = records
    return res


def _finished(out: Path, task: dict[str, Any]) -> bool:
    from .runner import finished
    return finished(run_dir(out, task["case"], task["variant"]))


def rebuild(out: Path, *, judge_model: str | None = None, base_url: str | None = None,
            clip_weights: str | None = None, pairs: tuple[tuple[str, str], ...] | None = None,
            say: Say | None = None) -> BenchResult:
    """``--from DIR``: the tables again from the stored runs, without the generating model.

    ``judge_model`` None replays ``DIR/judge/transcript.jsonl`` (the judge calls recorded the
    last time); otherwise that model judges again.

    Raises:
        BenchError: DIR holds no bench (no ``bench.json``) or no judge transcript to replay.
    """
    meta = read_json(_meta_path(out))
    if meta is None:
        raise BenchError(f"{out} holds no bench (no bench.json); run procedura-brep bench -o {out} first")
    cases = tuple(Case(**c) for c in meta["cases"])
    variants = tuple(meta["variants"])
    if judge_model is None:
        tape = Path(out) / "judge" / "transcript.jsonl"
        if not tape.is_file():
            raise BenchError(f"no judge transcript {tape} to replay; give --judge-model to judge again")
        judge_model = f"replay:{tape}"
    if pairs:
        _check(BenchOptions(model="-", variants=variants, pairs=pairs))
    return _judge_and_tabulate(out, meta, cases, variants, judge_model=judge_model, base_url=base_url,
                               clip=clip_setting(clip_weights), pairs=pairs, say=say or (lambda line: None))


def _items(out: Path, meta: dict[str, Any], cases: tuple[Case, ...], variants: tuple[str, ...]) -> list[Item]:
    items = []
    for c in cases:
        for v in variants:
            rdir = run_dir(out, c.id, v)
            if shipped(rdir):
                items.append(Item(item_id(meta["salt"], c.id, v), c.id, v, c.prompt, rdir / "program.py"))
    return items


def _judge(out: Path, items: list[Item], judge_model: str,
           base_url: str | None) -> tuple[dict[str, Any], dict[str, Any]]:
    """Judge the items; the transcript goes to ``DIR/judge/transcript.jsonl`` (replaced at the
    end, so a replay of the old one can read it while the new one is written)."""
    jdir = Path(out) / "judge"
    jdir.mkdir(parents=True, exist_ok=True)
    replay = judge_model.startswith("replay:")
    if replay:
        root = Path(judge_model.split(":", 1)[1])
        if root.is_dir() and not (root / "transcript.jsonl").is_file():
            judge_model = f"replay:{root / 'judge.jsonl'}"  # a directory of tapes: its judge tape
    cached = None if replay else (read_json(jdir / "scores.json") or {}).get("items")
    provider = preflight(judge_model, base_url=base_url)
    tmp = jdir / "transcript.jsonl.new"
    tmp.unlink(missing_ok=True)
    client = Client(provider, ledger=Ledger(), transcript=Transcript(tmp))
    try:
        results = judge_items(items, client, jdir / "images", cached=cached)
    finally:
        try:
            client.close()
        except LLMError as exc:
            raise BenchError(f"judge: {exc}") from None
    if tmp.exists():
        os.replace(tmp, jdir / "transcript.jsonl")
    usage = client.ledger.summary()
    write_atomic(jdir / "scores.json", json.dumps({"judge_model": judge_model, "items": results,
                                                   "usage": usage}, indent=2, ensure_ascii=False) + "\n")
    key = {i.id: {"case": i.case, "variant": i.variant} for i in items}
    write_atomic(jdir / "key.json", json.dumps(key, indent=2, sort_keys=True) + "\n")  # never sent
    return results, usage


def _judge_and_tabulate(out: Path, meta: dict[str, Any], cases: tuple[Case, ...], variants: tuple[str, ...], *,
                        judge_model: str, base_url: str | None, clip: Any,
                        pairs: tuple[tuple[str, str], ...] | None, say: Say) -> BenchResult:
    items = _items(out, meta, cases, variants)
    say(f"judging {len(items)} shipped model(s) blind with {judge_model}")
    results, usage = _judge(out, items, judge_model, base_url)
    scorer = ClipScorer(clip) if clip and items else None
    by_key = {(i.case, i.variant): i for i in items}
    rows = []
    for c in cases:
        for v in variants:
            item = by_key.get((c.id, v))
            scores = (results.get(item.id) or {}).get("scores") if item else None
            clip_v = None
            if scorer is not None:
                clip_v = scorer.score(c.prompt, sorted((Path(out) / "judge" / "images").glob(f"{item.id}_*.png"))) \
                    if item else 0.0
            rows.append(make_row(out, c.id, v, scores=scores, clip=clip_v))
    summary = summarise(rows, variants)
    paired = paired_table(rows, pairs_of(variants, pairs)) if len(variants) > 1 else []
    title = f"{meta.get('name', 'bench')}: {len(cases)} case(s) x {len(variants)} variant(s)"
    judge_errors = sum(1 for r in results.values() if r.get("error"))
    tables = write_tables(out, title=title, rows=rows, summary=summary, paired=paired,
                          meta={"model": meta.get("model"), "judge_model": judge_model,
                                "judge_usage": usage.get("total"), "judge_errors": judge_errors,
                                "clip": "computed" if scorer else "not computed"})
    say(f"tables -> {Path(out) / 'tables'}")
    return BenchResult(Path(out), tables, summary, paired, rows, judge_errors=judge_errors)
