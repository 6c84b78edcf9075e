"""The export step overlapped with the gates: written ahead, kept only if the gates pass.

A build gates its model, then exports it; on a machine with a second core the two can run at
once. :func:`start_export` first tessellates every part (the one tessellation gates and
exports share), then forks a limited child (:class:`procedura_brep.isolate.Limited`) that runs
:func:`procedura_brep.run.steps.export` into a hidden folder inside the run's staging folder,
while the caller runs the gates. If the gates pass (or the build exports a failing model
anyway), :meth:`Overlapped.finish` waits for the child and moves its files into place: the
same files, byte for byte, that the serial export writes. Otherwise :meth:`Overlapped.discard`
kills the child and removes the folder, so nothing of a failing model is shipped.

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
from .steps import Bundle, export

#: The hidden folder, inside the staging folder, the overlapped export writes into (a name
#: starting with "." is never swapped into the run directory).
FOLDER = ".export-overlap"


class Overlapped:
    """An export running in a forked child beside the gates (see the module doc)."""

    def __init__(self, child: Limited, root: Path, folder: Path, tessellate_s: float) -> None:
        self._child, self.root, self.folder = child, root, folder
        self.tessellate_s = tessellate_s

    def finish(self) -> Bundle:
        """Wait for the export, move its files into ``root``; the bundle as :func:`export`
        returns it (its articulation is not carried over: the battery rebuilds it).

        Raises:
            ChildFailure: the export failed (``kind == "error"`` carries the exception type,
                and whether it was an OSError or one of ours), ran out of memory or time.
        """
        try:
            out = self._child.collect()
            files = [str(rel) for rel in out["files"]]
            for top in dict.fromkeys(rel.split("/")[0] for rel in files):
                os.replace(self.folder / top, self.root / top)
        finally:
            self.discard()
        timings = {str(k): float(v) for k, v in out["timings"].items()}
        return Bundle(self.root, {rel: self.root / rel for rel in files}, timings)

    def discard(self) -> None:
        """Kill the child if it still runs and remove its folder."""
        self._child.close()
        shutil.rmtree(self.folder, ignore_errors=True)


def start_export(model: CompiledModel, root: Path, *, formats: tuple[str, ...],
                 step_schema: str) -> Overlapped:
    """Tessellate ``model``'s parts, then start its export into ``root/FOLDER`` in a forked,
    limited child; returns at once (see the module doc)."""
    t = time.perf_counter()
    for part in model.parts:
        try:
            part.mesh()
        except ProceduraError:  # a part over the mesh cap: the gates report it themselves
            pass
    tessellate_s = time.perf_counter() - t
    folder = root / FOLDER
    shutil.rmtree(folder, ignore_errors=True)

    def run(send: Any) -> dict[str, Any]:
        bundle = export(model, folder, formats=formats, step_schema=step_schema)  # type: ignore[arg-type]
        return {"files": sorted(bundle.files), "timings": bundle.timings}

    return Overlapped(Limited(run, stage="export"), root, folder, tessellate_s)


__all__ = ["FOLDER", "Overlapped", "start_export"]
