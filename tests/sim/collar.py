"""A table collar on a column: a cylindrical mate (slide along and turn about the column axis),
male on the parent so the column is not cut. Hand-written test program, not model output."""

from __future__ import annotations

SOURCE = '''"""Drill-press style table collar on a column. Hand-written test program."""
from procedura_brep.program import *

# === params ===
column_d = 40.0  # mm, the cylindrical mate's nominal
column_h = 400.0  # mm
collar_h = 50.0  # mm
arm_l = {arm_l}  # mm, table arm reaching out from the collar

# === helpers ===

# === parts ===
@part(detail="silhouette", material="cast_iron", description="floor base")
def base():
    return Box(300, 300, 20, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="round column")
def column():
    return Cylinder(column_d / 2, column_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="cast_iron", description="collar with a table arm")
def collar():
    ring = Cylinder(column_d / 2 + 15, collar_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return ring + Box(arm_l, 30, 20, align=(Align.MIN, Align.CENTER, Align.MIN))
{stop}
# === frames ===
frames("base", top=Location((0, 0, 0)))
frames("column", foot=Location((0, 0, 0)), seat=Location((0, 0, 200)))
frames("collar", bore=Location((0, 0, 0)))
{stop_frames}
# === assembly ===
mate("column.foot", "base.top", "peg_socket", nominal="column_d", fit="location", features=False)
mate("collar.bore", "column.seat", "cylindrical", nominal="column_d", fit="clearance",
     limits=(-100, 120), angle_limits={angle_limits}, male="parent", depth=collar_h)
{stop_mate}'''

STOP = '''
@part(detail="sub", material="steel", description="a stop bolted to the column, in the arm's way")
def stop():
    return Pos({x}, {y}, {z}) * Box(30, 30, 20)
'''
#: Where the stop stands (collar frame at home, mm): in the arm's way at +90 deg of turn, or
#: 60 mm below the arm (in the way of the slide).
STOPS = {"turn": (0, 150, 10), "slide": (100, 0, -60)}
STOP_FRAMES = 'frames("stop", foot=Location((0, 0, 0)))'
STOP_MATE = 'mate("stop.foot", "column.seat", "peg_socket", nominal="column_d", fit="location", features=False)\n'


def program(*, stop: str | None = None, angle_limits: str = "(-120, 120)", arm_l: float = 160.0) -> str:
    """The collar program; ``stop`` = "turn" or "slide" plants a stop in that motion's way."""
    x, y, z = STOPS[stop] if stop else (0, 0, 0)
    return SOURCE.format(arm_l=arm_l, angle_limits=angle_limits,
                         stop=STOP.format(x=x, y=y, z=z) if stop else "",
                         stop_frames=STOP_FRAMES if stop else "", stop_mate=STOP_MATE if stop else "")
