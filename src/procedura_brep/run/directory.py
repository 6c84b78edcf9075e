"""A run directory that is always consistent: build in a staging folder, then swap it in.

``build`` writes everything it produces (program.py, mates.json, the exports, battery frames,
report.json) into ``DIR/.staging-<pid>-<random>/`` and only then moves it into ``DIR``, inside an
:func:`~procedura_brep.interrupt.critical` section (Ctrl-C waits for it): the old report.json goes
first, the new one last, and every build output the new build did not produce (a stale
``model.glb`` from an earlier ``--formats``) is removed. Files the build does not own
(``transcript.jsonl``, ``history/``, ``renders/`` other than ``renders/sim``) are kept.

Policy when a build fails or is interrupted (see README "Outputs"):

* ``DIR`` holds a *complete* earlier build (its report says ``ok`` or ``gates_failed``, or it
  is itself a kept one): that build stays exactly as it was (program.py and every model), and
  only report.json is replaced by the failure report: ``status`` ``failed`` or
  ``interrupted``, its findings, ``kept_previous: true`` and ``previous`` = the report of the
  build whose files are still there.
* otherwise: the new program.py and its failure report are swapped in and every stale model is
  removed.

Never a mix of a new program with old models.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

from .. import interrupt
from ..errors import OutputError
from ..paths import write_atomic

#: Everything a build owns in a run directory (relative paths); the rest is left alone.
BUILD_OUTPUTS: tuple[str, ...] = (
    "program.py", "mates.json", "model.step", "model.obj", "model.mtl", "model.glb",
    "model.usda", "model.xml", "urdf", "viewer.html", "viewer", "renders/sim", "sheet.png",
    "summary.md", "report.json")  # report.json last
#: Statuses whose build always writes every file it was asked for (a ``gates_failed`` build
#: does only when asked to export anyway: its report then says ``"complete": true``).
COMPLETE: frozenset[str] = frozenset({"ok", "battery_failed"})
STAGING_PREFIX = ".staging-"


def output_reason(exc: OSError, path: Path) -> str:
    """Why ``path`` cannot be written, in words (no errno numbers)."""
    if isinstance(exc, FileExistsError) or (_exists(path) and not path.is_dir()):
        return "it exists and is not a directory"
    if isinstance(exc, NotADirectoryError):
        for parent in path.parents:
            if _exists(parent):
                if not parent.is_dir():
                    return f"{parent} is a file, not a directory"
                break
        return "a parent is not a directory"
    if exc.errno == errno.EROFS:
        return "read-only file system"
    if isinstance(exc, PermissionError):
        return "permission denied"
    if exc.errno == errno.ENOSPC:
        return "no space left on the device"
    return (exc.strerror or str(exc)).lower()


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except OSError:  # EACCES on a parent: it cannot be used either way
        return False


def ensure_dir(path: Path) -> Path:
    """Create ``path`` (and parents) as a writable directory, or raise :class:`OutputError`."""
    try:
        if path.exists() and not path.is_dir():
            raise OutputError(path, "it exists and is not a directory")
        path.mkdir(parents=True, exist_ok=True)
        probe = tempfile.mkstemp(prefix=".probe-", dir=path)
        os.close(probe[0])
        os.unlink(probe[1])
    except OSError as exc:
        raise OutputError(path, output_reason(exc, path)) from None
    return path


class Staging:
    """One build's staging folder inside the run directory ``out``."""

    def __init__(self, out: Path) -> None:
        self.out = ensure_dir(out)
        _remove_dead_stagings(out)
        try:
            self.dir = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{os.getpid()}-", dir=out))
        except OSError as exc:
            raise OutputError(out, output_reason(exc, out)) from None

    def write(self, rel: str, data: bytes | str) -> Path:
        """Write one file of the build (atomically) into the staging folder."""
        try:
            return write_atomic(self.dir / rel, data)
        except OSError as exc:
            raise OutputError(self.out, output_reason(exc, self.dir / rel)) from None

    def commit(self, only: tuple[str, ...] | None = None) -> None:
        """Swap the staged build into ``out``: every staged output (or only those named in
        ``only``) replaces its old version; every other build output in ``out`` is removed."""
        with interrupt.critical():
            trash = Path(tempfile.mkdtemp(prefix=".trash-", dir=self.out))
            try:
                tops = {r.split("/")[0] for r in BUILD_OUTPUTS}
                extra = [p.name for p in self.dir.iterdir()
                         if p.name not in tops and not p.name.startswith(".")]
                staged = [rel for rel in (*BUILD_OUTPUTS, *extra) if (self.dir / rel).exists()
                          and (only is None or rel in only)]
                _move_aside(self.out, "report.json", trash)
                for rel in (*BUILD_OUTPUTS[:-1], *extra):
                    _move_aside(self.out, rel, trash)
                    if rel in staged:
                        (self.out / rel).parent.mkdir(parents=True, exist_ok=True)
                        os.replace(self.dir / rel, self.out / rel)
                if "report.json" in staged:
                    os.replace(self.dir / "report.json", self.out / "report.json")
            except OSError as exc:
                raise OutputError(self.out, output_reason(exc, self.out)) from None
            finally:
                shutil.rmtree(trash, ignore_errors=True)
                self.discard()

    def finish_failed(self, report: dict[str, Any], dump: Any) -> dict[str, Any]:
        """Apply the failure policy for ``report`` (a failed or interrupted build's report);
        returns the report as written to ``out/report.json``."""
        previous = complete_report(self.out)
        if previous is None:  # the new program and its report; no models, old or partial
            self.write("report.json", dump(report))
            self.commit(only=("program.py", "report.json"))
            return report
        report = {**report, "kept_previous": True, "previous": previous}
        with interrupt.critical():
            try:
                write_atomic(self.out / "report.json", dump(report))
            except OSError as exc:
                raise OutputError(self.out, output_reason(exc, self.out)) from None
            finally:
                self.discard()
        return report

    def discard(self) -> None:
        shutil.rmtree(self.dir, ignore_errors=True)


def complete_report(out: Path) -> dict[str, Any] | None:
    """The report of the complete build whose files ``out`` holds, if it holds one."""
    try:
        report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(report, dict):
        return None
    previous = report.get("previous")
    if report.get("kept_previous") and isinstance(previous, dict):
        return previous
    complete = report.get("complete") is True or report.get("status") in COMPLETE
    return report if complete else None


def _move_aside(out: Path, rel: str, trash: Path) -> None:
    path = out / rel
    if path.exists() or path.is_symlink():
        dest = trash / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        os.replace(path, dest)


def _remove_dead_stagings(out: Path) -> None:
    """Remove staging folders left by builds whose process no longer runs (a SIGKILL)."""
    for p in out.glob(f"{STAGING_PREFIX}*"):
        try:
            pid = int(p.name[len(STAGING_PREFIX):].split("-")[0])
            os.kill(pid, 0)
        except ProcessLookupError:
            shutil.rmtree(p, ignore_errors=True)
        except (ValueError, OSError):
            continue
    for p in out.glob(".trash-*"):
        shutil.rmtree(p, ignore_errors=True)


__all__ = ["BUILD_OUTPUTS", "COMPLETE", "Staging", "complete_report", "ensure_dir", "output_reason"]
