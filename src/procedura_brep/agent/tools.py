"""The deterministic side of the staged agent: compile, gate one part, render, final build.

:class:`Tools` is what the stages call between model calls, on the run layer's steps
(:mod:`procedura_brep.run`): compile and gate write nothing; the final build composes every
step into the run directory. It has no model in it; tests use the real one (small programs
compile in a fraction of a second in the warm worker).
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import CompileError
from ..findings import blocks
from ..gates.origin import CODE as ORIGIN_CODE
from ..llm import Image
from ..program.model import CompiledModel, Finding

#: Finding codes that block an agent attempt although ``check`` and ``build`` only warn about
#: them: the program is valid but badly structured, and the model can fix it now, while it is
#: writing the part (``part-origin``: a part drawn at its assembly position, docs/gates.md).
AGENT_BLOCKING: frozenset[str] = frozenset({ORIGIN_CODE})


def attempt_blocks(finding: Finding) -> bool:
    """The agent's policy for one finding about the part it gates: the build's policy
    (:func:`procedura_brep.findings.blocks`) plus the codes of :data:`AGENT_BLOCKING`. Every
    agent gate (a build attempt, a refine edit, a sub-part rewrite or paint) decides here."""
    return blocks(finding) or finding.code in AGENT_BLOCKING


@dataclass
class PartVerdict:
    """What the gates say about one newly added (or edited) part.

    Attributes:
        compiled: the part is in the compiled model.
        errors: the findings about the part that block the attempt (:func:`attempt_blocks`).
        warnings: the other findings about it.
        n_vis: the model's visible floaters.
        model: the compiled model (None when the program did not compile).
    """

    compiled: bool
    errors: list[Finding] = field(default_factory=list)
    warnings: list[Finding] = field(default_factory=list)
    n_vis: int = 0
    model: CompiledModel | None = None

    @property
    def ok(self) -> bool:
        return self.compiled and not self.errors


def involves(f: Finding, part: str, own_mates: set[str]) -> bool:
    """Whether a finding concerns ``part``: it names it, one of its mates, or (interference and
    other pair findings) mentions it by name in its message."""
    if f.part == part or (f.mate is not None and f.mate in own_mates):
        return True
    if f.part is None and f.mate is None:
        return True  # a program-wide problem (a compile error without a part)
    return bool(re.search(rf"(?<![a-z0-9_]){re.escape(part)}(?![a-z0-9_])", f.message))


class Tools:
    """Compile in the warm sandbox worker, gate, render in memory, build the run directory."""

    def __init__(self, *, render_size: int = 384) -> None:
        self.render_size = render_size

    def compile_model(self, source: str, name: str = "model") -> CompiledModel:
        """The run layer's compile step (raises CompileError for a program that does not
        compile)."""
        from ..run import compile_model
        return compile_model(source, name=name)

    def gate_part(self, source: str, part: str, *, baseline: int, name: str = "model") -> PartVerdict:
        """Compile, then the gates on ``part``: its compile findings, its mates, pair findings
        naming it, its origin, and connectivity relative to the running ``baseline`` N_vis; the
        findings that block are decided by :func:`attempt_blocks`."""
        try:
            model = self.compile_model(source, name)
        except CompileError as exc:
            return PartVerdict(False, exc.findings or [Finding("compile", str(exc))])
        if not model.parts:
            return PartVerdict(False, [f for f in model.findings if attempt_blocks(f)]
                               or [Finding("compile", "the program compiled to no parts")], model=model)
        from ..run import gate
        verdict = gate(model, source, baseline=baseline)
        own = {m.name for m in model.mates if m.child == part}
        compiled = part in {p.name for p in model.parts}
        # a rise of N_vis over the baseline fails whichever part floats; otherwise what names it
        mine = [f for f in verdict.findings
                if f.code in ("floater", "floater-increase") or involves(f, part, own)]
        errors = [f for f in mine if attempt_blocks(f)]
        warnings = [f for f in mine if not attempt_blocks(f)]
        n_vis = int(verdict.report["connectivity"].get("n_vis") or 0)
        return PartVerdict(compiled, errors, warnings, n_vis, model)

    def render(self, model: CompiledModel, views: list[str] | None = None, *,
               close_up: str | None = None, frames_of: tuple[str, ...] = ()) -> tuple[list[Image], str]:
        """Parts-colour views as PNG images, and the colour legend as text.

        Args:
            model: the compiled model.
            views: view names (None: the 12 defaults).
            close_up: a part or mate to show alone.
            frames_of: parts whose origin and frames are drawn as axes (X red, Y green, Z blue).
        """
        from ..render.api import legend_of, render_images
        imgs = render_images(model, views, mode="parts", size=self.render_size, focus=close_up,
                             frames_of=frames_of)
        out = []
        for view, img in imgs.items():
            buf = io.BytesIO()
            img.save(buf, format="PNG")
            out.append(Image(buf.getvalue(), view))
        legend = ", ".join(f"{name} #{r:02x}{g:02x}{b:02x}" for name, (r, g, b) in legend_of(model))
        return out, legend

    def final_build(self, source: str, out_dir: Path, *, simulate: bool = True,
                    formats: tuple[str, ...] | None = None,
                    progress: Callable[[str], None] | None = None) -> Any:
        """Build the run directory's models and reports from the final program (exported even
        when a gate fails, so the work is kept: status ``gates_failed``); ``progress`` gets the
        build's stage lines (gates, exports, sheet, battery), so a long build is never silent."""
        from ..run.build import build
        return build(out_dir / "program.py", out_dir, source=source, simulate=simulate, formats=formats,
                     export_failed=True, progress=progress)

