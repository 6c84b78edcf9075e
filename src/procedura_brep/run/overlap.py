"""The export step overlapped with the gates: written ahead, kept only if the gates pass.

A build gates its model, then exports it; on a machine with a second core the two can run at
once. :func:`start_export` forks a limited child (:class:`procedura_brep.limited.Limited`)
that writes the exports into a hidden folder inside the run's staging folder while the caller
tessellates the parts and runs the gates. If the gates pass (or the build exports a failing
model anyway), :meth:`Overlapped.finish` writes ``mates.json``, waits for the child and moves
the files into place: the same files, byte for byte, that the serial export writes. Otherwise
:meth:`Overlapped.discard` kills the child and removes the folder, so nothing of a failing
model is shipped.

Both sides need every part's mesh, and tessellating is the longest serial step left. The child
writes the STEP file first (it needs no mesh); meanwhile the caller tessellates every part and
hands the meshes over in one file (:data:`MESHES`, plain arrays, no pickle); the child adopts
them (:func:`procedura_brep.program.model.adopt_mesh`) and writes the other formats, in the
bundle's order (they share meshes and masses, which one process computes once), then draws
``sheet.png`` (:func:`~.steps.sheet`) with the same meshes.
``mates.json`` and its articulation evidence, which share nothing with the formats, are written
by the caller once its gates have passed, while the child finishes.

The child is forked before anything is meshed in either process, and meshes only serially; it
dies with its parent. A failure of the child is raised by :meth:`~Overlapped.finish` as the
same :class:`~procedura_brep.limited.ChildFailure` the serial export's failure would have been,
so the caller reports it the same way.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path
from typing import Any

from ..errors import ProceduraError
from ..limited import Limited
from ..program.model import CompiledModel
from . import steps
from .steps import Bundle, export_formats, export_mates

#: The hidden folder, inside the staging folder, the overlapped export writes into (a name
#: starting with "." is never swapped into the run directory).
FOLDER = ".export-overlap"
#: The file, inside :data:`FOLDER`, in which the caller hands its meshes to the child.
MESHES = "meshes.npz"


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
        """Fork the child, then tessellate every part and hand the meshes over."""
        self._child = Limited(self._formats, stage="export")
        t = time.perf_counter()
        try:
            meshes: dict[str, Any] = {}
            for part in self.model.parts:
                try:
                    meshes[part.digest] = part.mesh()
                except ProceduraError:  # a part over the mesh cap: the gates report it themselves
                    pass
            _write_meshes(self.folder / MESHES, meshes)
        except BaseException:  # out of memory, a full disk, Ctrl-C: the child goes too
            self.discard()
            raise
        self.tessellate_s = time.perf_counter() - t
        return self

    def _formats(self, send: Any) -> dict[str, Any]:
        """The child's work: the STEP file, then (with the caller's meshes) every other format
        into the folder; the files and the timings."""
        timings: dict[str, float] = {}
        first = tuple(f for f in self.formats if f == "step")
        written, _ = export_formats(self.model, self.folder, first, step_schema=self.step_schema,
                                    timings=timings) if first else ({}, None)
        rest = tuple(f for f in self.formats if f != "step")
        if rest:
            w = time.perf_counter()
            _adopt_meshes(self.folder / MESHES)
            timings["export_meshes_wait_s"] = time.perf_counter() - w
            more, _ = export_formats(self.model, self.folder, rest, step_schema=self.step_schema,
                                     timings=timings)
            written.update(more)
        files = sorted(written)
        if not steps.gl_in_use():  # the sheet too, while the gates run (else the build's parent draws it)
            files.append(steps.sheet(self.model, self.folder, timings=timings).name)
        return {"files": files, "timings": timings}

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
            t = time.perf_counter()
            out = self._child.collect()
            timings["export_wait_s"] = time.perf_counter() - t  # the child outlasting the gates
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


def _write_meshes(path: Path, meshes: dict[str, Any]) -> None:
    """The meshes, by part digest, as one ``.npz`` of plain arrays (written atomically)."""
    import io

    import numpy as np

    from ..paths import write_atomic
    arrays: dict[str, np.ndarray] = {"digests": np.array(list(meshes), dtype="<U64")}
    for i, mesh in enumerate(meshes.values()):
        arrays[f"v{i}"], arrays[f"f{i}"] = mesh.vertices, mesh.faces
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_atomic(path, buf.getvalue())


def _adopt_meshes(path: Path, *, poll_s: float = 0.002) -> None:
    """Wait for the caller's meshes (it always writes the file, or this process dies with it
    or is killed), then cache them by digest."""
    import numpy as np

    from .. import kernel
    from ..program.model import adopt_mesh
    while not path.exists():
        time.sleep(poll_s)
    with np.load(path, allow_pickle=False) as data:
        for i, digest in enumerate(data["digests"]):
            adopt_mesh(str(digest), kernel.Mesh(data[f"v{i}"], data[f"f{i}"]))


def start_export(model: CompiledModel, root: Path, *, formats: tuple[str, ...],
                 step_schema: str) -> Overlapped:
    """Start the export of ``model``'s ``formats`` into ``root/FOLDER`` beside the caller's
    gates; returns once the parts are tessellated and their meshes handed over (see the module
    doc). ``mates.json`` carries the evidence when more than one format is written, as in the
    serial export."""
    return Overlapped(model, root, formats, step_schema).start()


__all__ = ["FOLDER", "Overlapped", "start_export"]
