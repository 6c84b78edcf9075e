"""Which operation of a part made its solid invalid (BRepCheck), and at which program line.

A part whose returned solid fails BRepCheck is run once more, in the same sandboxed child, with
the build123d operations a part uses traced: the booleans (``+ - &``, ``fuse``, ``cut``,
``intersect``), ``fillet`` and ``chamfer`` (methods and functions), and the operation functions
``extrude``, ``revolve``, ``loft``, ``sweep``, ``offset``, ``split``, ``mirror``, ``thicken``,
``section``, ``make_face``, ``make_hull``. The first traced call whose result is an invalid
B-rep is the culprit: its name, the program line that called it, and whether one of its own
shape arguments was already invalid (a self-intersecting or open profile built by an untraced
constructor). Only failing parts pay for it, and the checks are capped
(:data:`MAX_CHECKS`): a part that makes more shapes than that is named without an operation.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from types import FrameType
from typing import Any

#: BRepCheck calls one diagnosis may make (each costs about a millisecond on a simple shape).
MAX_CHECKS = 400
#: Shape methods traced, as (attribute, what the message calls it).
_METHODS: tuple[tuple[str, str], ...] = (
    ("__add__", "a fuse (+)"), ("__sub__", "a cut (-)"), ("__and__", "an intersect (&)"),
    ("fuse", "fuse"), ("cut", "cut"), ("intersect", "intersect"))
_SOLID_METHODS: tuple[str, ...] = ("fillet", "chamfer")
#: Operation functions traced where the program's namespace has them.
_FUNCTIONS: tuple[str, ...] = ("extrude", "revolve", "loft", "sweep", "fillet", "chamfer", "offset",
                               "split", "mirror", "thicken", "section", "make_face", "make_hull")


@dataclass(frozen=True)
class InvalidOrigin:
    """The first traced operation that returned an invalid B-rep."""

    operation: str
    line: int | None
    input_invalid: bool

    def text(self) -> str:
        where = f" at line {self.line}" if self.line else ""
        if self.input_invalid:
            return (f"{self.operation}{where} was given a shape that is already not a valid B-rep "
                    "(a self-intersecting or open profile?) and returned an invalid solid")
        return (f"{self.operation}{where} returned an invalid solid from valid shapes (try a "
                "smaller fillet or chamfer, or shapes that do not just touch along an edge)")


def _program_line() -> int | None:
    """The innermost line of the program (the sandbox compiles it as ``<program>``) on the stack."""
    f: FrameType | None = sys._getframe(2)
    while f is not None:
        if f.f_code.co_filename == "<program>":
            return f.f_lineno
        f = f.f_back
    return None


def invalid_origin(run: Callable[[], Any], glb: dict[str, Any]) -> InvalidOrigin | None:
    """Run ``run`` (the part function) again with the operations traced; the first that
    returned an invalid shape, or None (none did, or the checks ran out)."""
    import build123d as bd
    from build123d.topology.three_d import Mixin3D

    from .. import kernel
    found: list[InvalidOrigin] = []
    checks = [0]

    def bad(obj: Any) -> bool:
        w = getattr(obj, "wrapped", None)
        if w is None or checks[0] >= MAX_CHECKS:
            return False
        checks[0] += 1
        try:
            return not kernel.is_valid(w)
        except Exception:  # noqa: BLE001 - a shape BRepCheck cannot read tells us nothing
            return False

    def traced(orig: Callable[..., Any], label: str) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            out = orig(*args, **kwargs)
            if not found and bad(out):
                given = [a for a in (*args, *kwargs.values()) if hasattr(a, "wrapped")]
                found.append(InvalidOrigin(label, _program_line(), any(bad(a) for a in given)))
            return out
        return call

    undo: list[Callable[[], None]] = []
    try:
        for owner, names in ((bd.Shape, _METHODS), (Mixin3D, tuple((n, n) for n in _SOLID_METHODS))):
            for attr, label in names:
                orig = owner.__dict__.get(attr)
                if orig is None:
                    continue
                setattr(owner, attr, traced(orig, label))
                undo.append(partial(setattr, owner, attr, orig))
        for name in _FUNCTIONS:
            if callable(glb.get(name)):
                orig_fn = glb[name]
                glb[name] = traced(orig_fn, name)
                undo.append(partial(glb.__setitem__, name, orig_fn))
        try:
            run()
        except Exception:  # noqa: BLE001 - the first run already reported what it raised
            pass
    finally:
        for restore in reversed(undo):
            restore()
    return found[0] if found else None
