"""One case x variant into ``DIR/runs/<case>/<variant>/``, resumable.

A run is *finished* when its ``report.json`` was written by the agent at the end of the run (it
carries ``mode`` and ``status``); a finished run is never rerun. An unfinished staged run (a
``state.json`` without a final report) resumes from its state; an unfinished one-shot run starts
again in an emptied directory. The bench's own record of a run is ``bench_run.json`` next to the
report: what it cost (:mod:`.measure`), and for a one-shot run the MuJoCo battery the one-shot
path does not run itself.

:func:`run_task` is the unit every executor (:mod:`.scale`) runs: it takes and returns plain
data, so it can cross a process or a Ray task boundary.
"""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path
from typing import Any

from ..errors import ProceduraError
from ..llm import LLMError
from ..paths import write_atomic
from .cases import VARIANTS
from .measure import Meter

log = logging.getLogger(__name__)
RUN_RECORD = "bench_run.json"
FINISHED_MODES = ("staged", "oneshot")


def run_dir(out: Path, case: str, variant: str) -> Path:
    """Where case ``case`` of ``variant`` runs."""
    return Path(out) / "runs" / case / variant


def read_json(path: Path) -> dict[str, Any] | None:
    """A JSON object file, or None when missing or unreadable."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def finished(rdir: Path) -> bool:
    """Whether the agent finished this run (its final ``report.json`` is there)."""
    report = read_json(rdir / "report.json")
    return bool(report) and report.get("mode") in FINISHED_MODES and "status" in report


def case_model(model: str, case: str, variant: str) -> str:
    """The model for one run: ``replay:DIR`` with DIR a directory of tapes (no
    ``transcript.jsonl`` in it) plays ``DIR/<case>/<variant>.jsonl``; anything else as given."""
    if model.startswith("replay:"):
        root = Path(model.split(":", 1)[1])
        if root.is_dir() and not (root / "transcript.jsonl").is_file():
            return f"replay:{root / case / f'{variant}.jsonl'}"
    return model


def _generate(task: dict[str, Any], rdir: Path) -> str:
    """Run the agent for one task; returns its status."""
    variant = VARIANTS[task["variant"]]
    model = case_model(task["model"], task["case"], task["variant"])
    formats = tuple(task["formats"]) if task.get("formats") else None
    if variant.mode == "oneshot":
        if rdir.exists():
            shutil.rmtree(rdir)  # an unfinished one-shot run starts again
        from ..agent.oneshot import generate
        res = generate(task["prompt"], rdir, model=model, base_url=task.get("base_url"),
                       max_cost_usd=task.get("max_cost_usd"), formats=formats)
        return res.status
    from ..agent.staged import StagedOptions, generate_staged
    opts = StagedOptions(plan=variant.plan, review=variant.review, feedback=variant.feedback,
                         refine=variant.refine, simulate=bool(task.get("simulate", True)),
                         formats=formats)
    resume = (rdir / "state.json").is_file()
    sres = generate_staged(None if resume else task["prompt"], rdir, model=model,
                           base_url=task.get("base_url"), options=opts,
                           max_cost_usd=task.get("max_cost_usd"), resume=resume)
    return sres.status


def _oneshot_battery(rdir: Path) -> dict[str, Any] | None:
    """The MuJoCo battery over a one-shot run's bundle (the staged path runs it itself)."""
    report = read_json(rdir / "report.json") or {}
    if "battery" in report or not (rdir / "program.py").is_file() or not (rdir / "model.xml").is_file():
        return None
    from ..sim import run_battery
    return run_battery(rdir, frames=False).as_dict()


def run_task(task: dict[str, Any]) -> dict[str, Any]:
    """Run one case x variant unless it is finished; never raises for a failing run.

    Args:
        task: ``case``, ``variant``, ``prompt``, ``out`` (the bench directory), ``model`` and
            optionally ``base_url``, ``simulate``, ``formats``, ``max_cost_usd``.

    Returns:
        The run record (also written to ``bench_run.json``): ``case``, ``variant``, ``status``
        (the agent's, or ``error``), ``resumed`` (true when nothing was run), ``error`` and the
        cost figures.
    """
    rdir = run_dir(Path(task["out"]), task["case"], task["variant"])
    if finished(rdir):
        rec = read_json(rdir / RUN_RECORD) or {}
        return {**rec, "case": task["case"], "variant": task["variant"],
                "status": (read_json(rdir / "report.json") or {}).get("status"), "resumed": True}
    rec: dict[str, Any] = {"case": task["case"], "variant": task["variant"], "resumed": False,
                           "error": None}
    with Meter() as meter:
        try:
            rec["status"] = _generate(task, rdir)
            if VARIANTS[task["variant"]].mode == "oneshot" and task.get("simulate", True):
                rec["battery"] = _oneshot_battery(rdir)
        except (ProceduraError, LLMError, OSError) as exc:
            rec["status"], rec["error"] = "error", f"{type(exc).__name__}: {exc}"
            log.warning("%s/%s: %s", task["case"], task["variant"], rec["error"])
        except Exception as exc:  # noqa: BLE001 - one broken run must not end a 216-run bench
            rec["status"], rec["error"] = "error", f"internal {type(exc).__name__}: {exc}"
            log.warning("%s/%s: %s", task["case"], task["variant"], rec["error"], exc_info=True)
    rec.update(meter.cost.as_dict())
    rdir.mkdir(parents=True, exist_ok=True)
    write_atomic(rdir / RUN_RECORD, json.dumps(rec, indent=2, default=str) + "\n")
    return rec
