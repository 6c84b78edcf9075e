"""The export step overlapped with the gates: written ahead, kept only if the gates pass.

A build gates its model, then exports it; on a machine with a second core the two can run at
once. :func:`start_export` first tessellates every part (the one tessellation gates and
exports share), then forks a limited child (:class:`procedura_brep.isolate.Limited`) that
writes the exports into a hidden folder inside the run's staging folder while the caller runs
the gates. If the gates pass (or the build exports a failing model anyway),
:meth:`Overlapped.finish` writes ``mates.json``, waits for the child and moves the files into
place: the same files, byte for byte, that the serial export writes.
Otherwise :meth:`Overlapped.discard` kills the child and removes the folder, so nothing of a
failing model is shipped.

The child writes the formats, in the bundle's order (the formats share meshes and masses,
which one process computes once); ``mates.json`` and its articulation evidence, which share
nothing with them, are written by the caller once its gates have passed, while the child
finishes.

The child is forked after the parts are tessellated, never after OCCT's parallel mesher (the
gates and exports mesh serially), and dies with its parent. A failure of the child is raised
by :meth:`~Overlapped.finish` as the same :class:`~procedura_brep.isolate.ChildFailure` the
serial export's failure would have been, so the caller reports it the same way.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path
from typing import Any

from ..errors import ProceduraError
from ..isolate import Limited
from ..program.model import CompiledModel
from .steps import Bundle, export_formats, export_mates

#: The hidden folder, inside the staging folder, the overlapped export writes into (a name
#: starting with "." is never swapped into the run directory).
FOLDER = ".export-overlap"


class Overlapped:
    """An export running in a forked child beside the gates (see the module doc)."""

    def __init__(self, model: CompiledModel, root: Path, formats: tuple[str, ...],
                 step_schema: str) -> None:
        self.model, self.root, self.folder = model, root, root / FOLDER
        self.formats, self.step_schema = formats, step_schema
        shutil.rmtree(self.folder, ignore_errors=True)
        self.folder.mkdir(parents=True)
        self.tessellate_s = 0.0
        self._child: Limited | None = None

    def start(self) -> "Overlapped":
        """Tessellate every part, then fork the child that writes the formats."""
        t = time.perf_counter()
        for part in self.model.parts:
            try:
                part.mesh()
            except ProceduraError:  # a part over the mesh cap: the gates report it themselves
                pass
        self.tessellate_s = time.perf_counter() - t
        self._child = Limited(self._formats, stage="export")
        return self

    def _formats(self, send: Any) -> dict[str, Any]:
        """The child's work: every format into the folder; the files and the timings."""
        timings: dict[str, float] = {}
        t = time.perf_counter()
        written, _ = export_formats(self.model, self.folder, self.formats,
                                    step_schema=self.step_schema, timings=timings)
        timings["export_s"] = time.perf_counter() - t - timings.get("articulate_s", 0.0)
        return {"files": sorted(written), "timings": timings}

    def finish(self) -> Bundle:
        """Write ``mates.json`` here, wait for the child and move every file into ``root``; the
        bundle as :func:`~.steps.export` returns it (its articulation is not carried over: the
        battery builds its own).

        Raises:
            ChildFailure: the export's child failed (``kind == "error"`` carries the exception
                type, and whether it was an OSError or one of ours), ran out of memory or time.
            OSError, ProceduraError: writing ``mates.json`` failed, as in the serial export.
        """
        assert self._child is not None, "start() first"
        timings: dict[str, float] = {}
        try:
            export_mates(self.model, self.folder, evidence=len(self.formats) > 1, timings=timings)
            out = self._child.collect()
            files = [*map(str, out["files"]), "mates.json"]
            for top in dict.fromkeys(rel.split("/")[0] for rel in files):
                os.replace(self.folder / top, self.root / top)
        finally:
            self.discard()
        timings.update({str(k): float(v) for k, v in out["timings"].items()})
        return Bundle(self.root, {rel: self.root / rel for rel in files}, timings)

    def discard(self) -> None:
        """Kill the child if it still runs and remove the folder."""
        if self._child is not None:
            self._child.close()
        shutil.rmtree(self.folder, ignore_errors=True)


def start_export(model: CompiledModel, root: Path, *, formats: tuple[str, ...],
                 step_schema: str) -> Overlapped:
    """Start the export of ``model``'s ``formats`` into ``root/FOLDER`` beside the caller's
    gates; returns at once (see the module doc). ``mates.json`` carries the evidence when more
    than one format is written, as in the serial export."""
    return Overlapped(model, root, formats, step_schema).start()


__all__ = ["FOLDER", "Overlapped", "start_export"]
