"""Prompts are data: markdown templates next to this module, plus a reference generated from
the program API and the mate vocabulary (so the model sees exactly what the compiler accepts)."""

from __future__ import annotations

import inspect
from functools import lru_cache
from pathlib import Path

PROMPTS = Path(__file__).parent / "prompts"


def template(name: str) -> str:
    return (PROMPTS / f"{name}.md").read_text(encoding="utf-8")


@lru_cache(maxsize=1)
def reference() -> str:
    """The program API reference: docstrings of part/frames/mate, mate types, materials."""
    from .. import materials
    from ..mates import TYPES
    from ..program import api
    out = ["## The program API", inspect.cleandoc(api.__doc__ or "")]
    for fn in (api.part, api.frames, api.mate):
        out.append(f"### {fn.__name__}{inspect.signature(fn)}\n{inspect.cleandoc(fn.__doc__ or '')}")
    out.append("## Mate types (type: DOF; fits, default first; options)")
    for t in TYPES.values():
        opts = ", ".join(f"{k}={o.default!r}" for k, o in t.options.items())
        fits = ", ".join([t.default_fit] + [f for f in t.fits if f != t.default_fit])
        out.append(f"- {t.name} ({t.kind}, {t.dof.count} DOF): {t.doc}. fits: {fits}. options: {opts}")
    out.append("## Materials\n" + ", ".join(materials.MATERIALS))
    return "\n\n".join(out)


def system_prompt() -> str:
    return template("oneshot_system").replace("{reference}", reference())
