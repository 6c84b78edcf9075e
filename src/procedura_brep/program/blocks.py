"""Colour blocks: ``@paint(part, material=...)`` regions cut out of a part (runs in the sandbox
child, after the mate features and the placement).

For each declaration, in program order, with ``S`` the painted part's solid so far (its mate
features applied) and ``R`` the region the function returns (part-local coordinates)::

    block = S & R        part = S - R

The block is a compiled part of its own (:class:`~procedura_brep.program.model.CompiledPart`
with ``block_of`` set): the painted part's placement, detail and (derived) description, its own
material, no frames, no mates. Findings (code ``paint``, naming the block; the block is then
left out): an unknown part or material, a name that is also a part's, a region function that
raises or returns no solid, a region that misses the part or leaves it empty, a region that
reaches into one of the part's mate features (the male half added to it or the female half cut
from it, so the mate gate keeps measuring what the mate built), and (``paint-volume``) blocks
plus rest that do not add up to the unpainted part within ``config.MATERIAL.paint_volume_rtol``.

The part cache stores the *unpainted* solid (:attr:`CompiledPart.unpainted`): the paint is cut
again on every compile, so a changed region never reads a stale block.
"""

from __future__ import annotations

import contextvars
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..config import MATERIAL
from .model import CompiledPart
from .registry import PaintDecl, Registry

if TYPE_CHECKING:
    from .runtime import _Build


@dataclass
class Block:
    """One cut block: its declaration and its solid (part-local)."""

    decl: PaintDecl
    solid: Any


@dataclass
class Painted:
    """What painting did to one part: its unpainted solid and its solid count before."""

    unpainted: Any
    solids_before: int
    blocks: list[Block]
    data: bytes = b""


def _count(solid: Any) -> int:
    from .. import kernel
    return len(kernel.solids(solid.wrapped))


def _volume(shape: Any) -> float:
    """Volume of a build123d shape, mm^3; 0 for an empty result (a boolean that kept nothing)."""
    from .. import kernel
    try:
        wrapped = shape.wrapped
    except AssertionError:  # build123d asserts on an empty compound's wrapped shape
        return 0.0
    return kernel.volume(wrapped) if wrapped is not None and not wrapped.IsNull() else 0.0


def _from_brep(data: bytes) -> Any:
    from build123d import Compound, Solid

    from .. import kernel
    shape = kernel.read_brep(data)
    return Compound(shape) if shape.ShapeType().name == "TopAbs_COMPOUND" else Solid(shape)


def _canonical(shape: Any) -> Any:
    """``shape`` with its solids in a fixed order (by centre of mass, then volume, rounded to
    1e-6). OCCT returns the solids of a boolean against a region of several pieces in either
    order from one compile to the next, so the same cut wrote different bytes: the block's
    digest changed, and a later paint elsewhere was refused as "the splice changed the shape of"
    that block."""
    from build123d import Compound
    solids = shape.solids()
    if len(solids) <= 1:
        return shape
    return Compound(sorted(solids, key=lambda s: (*(round(c, 6) for c in s.center()),
                                                  round(s.volume, 6))))


def _region(b: _Build, decl: PaintDecl) -> Any:
    """The region the paint function returns, as a solid (raises on anything else)."""
    from . import guards
    from .values import as_solid as _as_solid
    region = _as_solid(decl.fn())
    if guards.builder_open():
        raise ValueError("the region function left a builder context open")
    return region


def _feature_tools(b: _Build, reg: Registry, mates: list[dict[str, Any]], part: str) -> list[tuple[str, Any]]:
    """(mate name, feature solid in the part's local coordinates) for each mate half that the
    compiler added to or cut from ``part``."""
    from ..mates import features
    out: list[tuple[str, Any]] = []
    for m in mates:
        decl = m["decl"]
        if part not in (decl.child, decl.parent):
            continue
        to_male, to_female = features.sides(decl.child, decl.parent, m["options"])
        frame = decl.child_frame if part == decl.child else decl.parent_frame
        try:
            male, female = features.build(m["type"].name, m["d"], m["fit"], m["options"])
        except Exception:  # noqa: BLE001 - the features pass already reported this mate
            continue
        loc = reg.frames[part][frame]
        for half, side in ((male, to_male), (female, to_female)):
            if half is not None and side == part:
                out.append((decl.name, loc * half))
    return out


def _paint_one(b: _Build, reg: Registry, mates: list[dict[str, Any]], decl: PaintDecl,
               painted: dict[str, Painted]) -> None:
    from .. import kernel
    from .values import exc_text as _exc_text
    where = f"block {decl.name} (painted on {decl.part})"

    def fail(message: str, code: str = "paint") -> None:
        b.fail(code, f"{where}: {message}", part=decl.name, line=decl.line)

    if decl.part not in reg.parts:
        blocks = [p.name for p in reg.paints]
        fail(f"no part named {decl.part!r}; parts: {', '.join(reg.parts)}"
             + (" (a block cannot be painted)" if decl.part in blocks else ""))
        return
    if decl.name in reg.parts:
        fail(f"the name {decl.name!r} is also a part's; give the block its own name")
        return
    if not isinstance(decl.material, str) or decl.material not in reg.library:
        from ..text import did_you_mean
        fail(f"unknown material {decl.material!r:.60}{did_you_mean(decl.material, reg.library)}; "
             f"use one of: {', '.join(reg.library)} "
             f"(or declare it with material(...))")
        return
    if decl.part not in b.solids:
        return  # the part failed: its own finding says why
    solid = b.solids[decl.part]
    try:
        region = contextvars.Context().run(_region, b, decl)
    except BaseException as exc:  # noqa: BLE001 - untrusted code: any failure is a finding
        if isinstance(exc, (KeyboardInterrupt, SystemExit)):
            raise
        fail(f"the region function raised {_exc_text(exc)}")
        return
    state = painted.get(decl.part)
    if state is None:
        # paint the solid exactly as the cache stores it (its BRep bytes read back), so a cold
        # compile and a cache hit cut the same blocks, byte for byte
        data = b.cached_bytes.get(decl.part) or kernel.write_brep(kernel.bake_location(solid.wrapped))
        solid = _from_brep(data)
        state = Painted(solid, _count(solid), [], data)
    v0 = _volume(state.unpainted)
    floor = MATERIAL.paint_min_fraction * v0
    try:
        block = _canonical(solid & region)
        rest = _canonical(solid - region)
        vb, vr = _volume(block), _volume(rest)
    except Exception as exc:  # noqa: BLE001 - an OCCT boolean failure is a finding
        fail(f"cutting the region failed: {_exc_text(exc)}")
        return
    if not vb > floor:
        fail(f"the region misses the part (common volume {vb:.6g} mm^3 of the part's "
             f"{v0:.6g} mm^3); give the region in {decl.part}'s local coordinates")
        return
    if not vr > floor:
        fail(f"the region covers the whole part (what is left: {vr:.6g} mm^3); paint the part "
             f"itself with @part(material=...) instead")
        return
    for mate_name, tool in _feature_tools(b, reg, mates, decl.part):
        try:
            vt = _volume(tool)
            cut = _volume(region & tool)
        except Exception:  # noqa: BLE001 - a failed probe is not a verdict
            continue
        if cut > MATERIAL.paint_min_fraction * max(vt, 1.0):
            fail(f"the region reaches into mate {mate_name}'s feature ({cut:.4g} of its "
                 f"{vt:.4g} mm^3); keep the region away from the mate's frame")
            return
    if not (kernel.is_valid(block.wrapped) and kernel.is_valid(rest.wrapped)):
        fail("cutting the region left an invalid B-rep (BRepCheck failed); simplify the region")
        return
    b.solids[decl.part] = rest
    state.blocks.append(Block(decl, block))
    painted[decl.part] = state
    total = vr + sum(_volume(k.solid) for k in state.blocks)
    rel = abs(total - v0) / v0 if v0 > 0 else 0.0
    if rel > MATERIAL.paint_volume_rtol:
        b.fail("paint-volume", f"{where}: the blocks and the rest of {decl.part} add up to "
                               f"{total:.6g} mm^3, not the unpainted {v0:.6g} mm^3 (relative "
                               f"error {rel:.3g} > config.MATERIAL.paint_volume_rtol "
                               f"{MATERIAL.paint_volume_rtol:g})",
               part=decl.name, line=decl.line, value=rel, limit=MATERIAL.paint_volume_rtol)


def apply_paint(b: _Build, reg: Registry, mates: list[dict[str, Any]]) -> dict[str, Painted]:
    """Cut every ``@paint`` block from its part (``b.solids`` is updated in place); returns the
    painted parts. A painted part's cached bytes are dropped (its serialised solid changes)."""
    painted: dict[str, Painted] = {}
    for decl in reg.paints:
        _paint_one(b, reg, mates, decl, painted)
    for name in painted:
        b.cached_bytes.pop(name, None)
    return painted


def with_blocks(b: _Build, parts: list[CompiledPart], painted: dict[str, Painted]) -> list[CompiledPart]:
    """``parts`` with each painted part's blocks right after it, and the painted part carrying
    its unpainted solid (for the cache) and the pieces its blocks split it into."""
    from .. import kernel
    out: list[CompiledPart] = []
    for p in parts:
        out.append(p)
        state = painted.get(p.name)
        if state is None:
            continue
        p.unpainted = state.data
        p.pieces = p.pieces + max(0, _count(b.solids[p.name]) - state.solids_before)
        for k in state.blocks:
            desc = k.decl.description or f"{k.decl.material} block of {p.name}"
            out.append(CompiledPart(
                name=k.decl.name, brep=kernel.write_brep(kernel.bake_location(k.solid.wrapped)),
                placement=p.placement, frames={}, material=k.decl.material, detail=p.detail,
                description=desc, lines=(k.decl.line, k.decl.end_line), reads=p.reads,
                cache_key="", pieces=_count(k.solid), block_of=p.name))
    return out
