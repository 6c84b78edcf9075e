"""A left-hand lead screw driving a carriage (``couple(..., "screw", lead=...)``: a positive
turn moves it +X, off its lower limit at the compiled pose) for B2's coupled sweep
(hand-written test program, not model output): a block bolted on the carriage's side runs into
a stop post standing on the base at ``stop_x``; optionally a collar fixed on the screw stands in
the carriage's own path (a part on the turning screw against one on the sliding carriage)."""

from __future__ import annotations


def meets_mm(stop_x: float) -> float:
    """Carriage travel (mm) at which the block's front face meets the stop's back face, for a
    stop at ``stop_x``: the block spans x = -65..-55 at rest, the stop ``stop_x`` +- 5."""
    return stop_x - 5.0 + 55.0


TEMPLATE = '''"""A lead screw drives a carriage along X; a block on the carriage, a stop post on the base. Hand-written test program."""
from procedura_brep.program import *

# === params ===
screw_d = 10.0  # mm, lead screw diameter: nominal of its revolute
screw_l = 200.0  # mm, lead screw length
screw_lead = 4.0  # mm per turn
guide_w = 10.0  # mm, nominal of the carriage's slide
peg_d = 6.0  # mm, nominal of the static mates
stop_x = {stop_x}  # mm, stop post centre along X
travel = 100.0  # mm, carriage travel

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base plate")
def base():
    return Box(300, 100, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="lead screw, along its frame's Z")
def screw():
    return Cylinder(screw_d / 2, screw_l, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="carriage: the nut block, the screw through its bore")
def carriage():
    return Box(20, 40, 40) - Rot(0, 90, 0) * Cylinder(screw_d / 2, 20)

@part(detail="sub", material="steel", description="block bolted on the carriage's +Y side")
def block():
    return Box(10, 10, 10, align=(Align.CENTER, Align.MIN, Align.CENTER))

@part(detail="sub", material="steel", description="stop post on the base, in the block's path")
def stop():
    return Box(10, 8, 70, align=(Align.CENTER, Align.CENTER, Align.MIN))
{collar_part}
# === frames ===
frames("base", s_axis=Location((-100, 0, 40), (0, 90, 0)), c_rail=Location((-60, 0, 40), (0, 90, 0)),
       stop=Location((stop_x, 26, 10)))
frames("screw", hub=Location((0, 0, 0)){collar_frame})
frames("carriage", slide=Location((0, 0, 0), (0, 90, 0)), side=Location((0, 20, 0)))
frames("block", foot=Location((0, 0, 0)))
frames("stop", foot=Location((0, 0, 0)))
{collar_frames}
# === assembly ===
mate("screw.hub", "base.s_axis", "revolute", nominal="screw_d", features=False)
mate("carriage.slide", "base.c_rail", "prismatic", nominal="guide_w", limits=(0, travel), features=False)
mate("block.foot", "carriage.side", "peg_socket", nominal="peg_d", fit="location", features=False)
mate("stop.foot", "base.stop", "peg_socket", nominal="peg_d", fit="location", features=False)
{collar_mate}couple("carriage_slide", "screw_hub", "screw", lead="screw_lead", hand="left")
'''

COLLAR_PART = '''
@part(detail="sub", material="steel", description="collar fixed on the screw")
def collar():
    return Cylinder(14, 6, align=(Align.CENTER, Align.CENTER, Align.MIN)) - Cylinder(screw_d / 2, 6, align=(Align.CENTER, Align.CENTER, Align.MIN))
'''


def program(stop_x: float, *, collar_z: float | None = None) -> str:
    """The program with the stop post at ``stop_x`` (mm); with ``collar_z``, a collar (outer
    radius 14 mm, 6 mm long) fixed on the screw ``collar_z`` mm from its start (the carriage
    spans 30..50 mm of the screw at rest)."""
    c = collar_z is not None
    return TEMPLATE.format(
        stop_x=stop_x, collar_part=COLLAR_PART if c else "",
        collar_frame=f", collar=Location((0, 0, {collar_z}))" if c else "",
        collar_frames='frames("collar", seat=Location((0, 0, 0)))\n' if c else "",
        collar_mate=('mate("collar.seat", "screw.collar", "peg_socket", nominal="screw_d", '
                     'fit="location", features=False)\n') if c else "")
