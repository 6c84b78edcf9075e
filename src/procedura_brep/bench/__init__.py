"""The evaluation harness (the paper's section 4.1): benchmark prompts, generation per case and
variant, blind judging of grey-clay renders, edge metrics, tables, paired tests, scale-out.

Layering: this package sits above the agent (it calls :mod:`procedura_brep.agent`), and the CLI's
``bench`` sub-command is a thin wrapper over :func:`run_bench`.

* :mod:`.cases`: the prompts file format and the variants (``full``, ``one-shot``, ablations).
* :mod:`.runner`: one case x variant into ``DIR/runs/<case>/<variant>/``, resumable.
* :mod:`.scale`: serial, ``--jobs N`` (spawned processes) and ``--ray`` executors.
* :mod:`.judge`: grey-clay renders named by an opaque hash, one shared judge prompt, scores.
* :mod:`.rows`, :mod:`.tables`, :mod:`.paired`, :mod:`.clip`: per-case rows, markdown/CSV/JSON
  tables, the sign test, the optional CLIP score.
* :mod:`.harness`: :func:`run_bench` and :func:`rebuild` (``--from DIR``).
"""

from __future__ import annotations

from .cases import VARIANTS, BenchError, Case, load_cases
from .harness import BenchOptions, BenchResult, rebuild, run_bench

__all__ = ["VARIANTS", "BenchError", "BenchOptions", "BenchResult", "Case", "load_cases", "rebuild",
           "run_bench"]
