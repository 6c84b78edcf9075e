"""A two-part program drawn two ways, for the origin gate (``gates/origin.py``) and its users.

:func:`block_on_base` is a base plate (the root) with a 40 mm block seated on it by a
``peg_socket``, ``offset`` mm along +Y from the base's origin. With ``world=False`` the block is
modelled around its own origin with its mounting frame there and the mate places it; with
``world=True`` it is drawn at its assembly position with its mounting frame out there (the
mistake the origin gate finds). Both compile to the same placed world geometry.
"""

from __future__ import annotations

from .programs import program_text

#: The block's side, mm.
BLOCK: float = 40.0


def block_body(*, world: bool) -> str:
    """The block's ``@part`` function (drawn at its assembly position when ``world``)."""
    at = "Pos(0, block_y + block_w / 2, 0) * " if world else ""
    return ('@part(detail="major", material="aluminium", description="40 mm block on the base")\n'
            "def block():\n"
            f"    return {at}Box(block_w, block_w, block_w, align=(Align.CENTER, Align.CENTER, Align.MIN))\n")


def block_frames(*, world: bool) -> str:
    """The block's frames: its mounting frame at its origin, or out there at its body."""
    at = "(0, block_y + block_w / 2, 0)" if world else "(0, 0, 0)"
    return f'frames("block", foot=Location({at}))'


BASE_BODY = ('@part(detail="silhouette", material="steel", description="base plate, top face at z = 0")\n'
             "def base():\n"
             "    return Box(120, 2 * block_y + 120, 10, align=(Align.CENTER, Align.CENTER, Align.MAX))\n")
BASE_FRAMES = 'frames("base", top=Location((0, block_y + block_w / 2, 0)))'
BLOCK_MATE = 'mate("block.foot", "base.top", "peg_socket", nominal="peg_d", fit="location")'


def block_on_base(*, world: bool, offset: float = 300.0) -> str:
    """The program: the block's near face ``offset`` mm from the base's origin along +Y, so a
    block drawn in world coordinates lies exactly ``offset`` mm from its own origin."""
    return program_text(
        doc=("A base plate and a block seated on it, the block drawn "
             + ("at its assembly position (world coordinates)." if world else "around its own origin.")),
        params=(f"block_y = {offset:.1f}  # mm, from the base's origin to the block's near face",
                f"block_w = {BLOCK:.1f}  # mm, block side",
                "peg_d = 10.0  # mm, the block's peg: the nominal of its peg_socket"),
        parts=(BASE_BODY, block_body(world=world)),
        frames=(BASE_FRAMES, block_frames(world=world)),
        mates=(BLOCK_MATE,))


__all__ = ["BLOCK", "BASE_BODY", "BASE_FRAMES", "BLOCK_MATE", "block_body", "block_frames",
           "block_on_base"]
