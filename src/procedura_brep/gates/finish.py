"""Finish gate: ``finish(ok)`` is refused while the recompiled program has visible floaters.

The caller passes the model compiled from the committed program (or the source, which is then
recompiled here) so the gate grades the mesh the user receives. ``give_up`` is never gated.
"""

from __future__ import annotations

from ..findings import blocking
from ..program.model import CompiledModel, Finding
from .connectivity import analyse, floater_findings
from .policy import GateResult, result

#: How many worst offenders (largest span fraction first) the refusal names.
WORST: int = 3


def finish_gate(model: CompiledModel | None = None, *, source: str | None = None,
                top: int = WORST) -> tuple[list[Finding], GateResult]:
    """Refuse ``ok`` while N_vis > 0, naming the ``top`` worst floaters with their boxes.

    Args:
        model: the compiled final program; omit it and pass ``source`` to recompile here.
        source: program text, compiled with :func:`procedura_brep.program.compile_source`
            when ``model`` is None.
        top: how many offenders to name.

    Returns:
        (findings, result); ``result.measured`` has ``n_vis`` and the named ``offenders``.
    """
    if model is None:
        if source is None:
            raise ValueError("finish_gate needs a compiled model or the program source; got neither")
        from ..errors import CompileError
        from ..program import compile_source
        try:
            model = compile_source(source)
        except CompileError as exc:  # killed, timed out or crashed: a refusal, not an exception
            fs = exc.findings or [Finding("compile", str(exc))]
            refusal = Finding("finish-refused", f"the final program did not compile: {exc}")
            return [refusal, *fs], result("finish", [refusal, *fs], {"n_vis": None, "offenders": []})
    if not model.ok:
        errs = blocking(model.findings)
        refusal = Finding("finish-refused", f"the final program does not compile cleanly "
                          f"({len(errs)} error(s)); fix them before finish(ok)")
        return [refusal, *errs], result("finish", [refusal, *errs], {"n_vis": None, "offenders": []})
    conn = analyse(model)
    findings = floater_findings(conn, top=top)
    if conn.n_vis:
        worst = "; ".join(f"{', '.join(c.parts)} (span {c.rho:.1%})" for c in conn.floaters[:top])
        findings.insert(0, Finding("finish-refused", f"finish(ok) refused: {conn.n_vis} visible "
                                   f"floater(s); worst: {worst}", value=float(conn.n_vis), limit=0.0))
    return findings, result("finish", findings, {"n_vis": conn.n_vis,
                                                 "offenders": [c.as_dict() for c in conn.floaters[:top]]})
