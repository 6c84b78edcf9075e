"""The lamp of tests/program/lamp.py with colour blocks painted on its arm (shared by the tests
of ``@paint`` in program/, export/, gates/ and articulation/).

The arm is ``Box(90, 14, 10)`` from x = 0 to 90 in its local coordinates (pivot pin at x = 7),
so a region ``x >= x0`` that spans y and z takes a block of exactly ``(90 - x0) * 14 * 10`` mm^3.
"""

from __future__ import annotations

from pathlib import Path

LAMP = (Path(__file__).parent / "lamp.py").read_text()
ARM_SECTION = 14.0 * 10.0  # mm^2, the arm's cross-section


def tip_region(x0: float = 70.0) -> str:
    """A region function body: everything of the arm at x >= ``x0`` (local coordinates)."""
    return f"Pos({x0!r}, 0, 0) * Box(60, 30, 30, align=(Align.MIN, Align.CENTER, Align.CENTER))"


def paint_decl(name: str, region: str, *, part: str = "arm", material: str = "rubber") -> str:
    return f'@paint("{part}", material="{material}")\ndef {name}():\n    return {region}\n\n'


def painted_lamp(*decls: str) -> str:
    """The lamp with ``decls`` (``@paint`` functions) after its parts; default: the arm's tip
    (x >= 70) painted rubber as block ``arm_tip``."""
    body = "".join(decls) or paint_decl("arm_tip", tip_region())
    return LAMP.replace("# === frames ===", body + "# === frames ===")
