"""A thin blade swinging over a post, with an optional 1 mm fin in its path (hand-written test
program, not model output): the sweep must hit the fin wherever it stands."""

from __future__ import annotations

TEMPLATE = '''"""Blade over a post, fin at {fin_deg} deg. Hand-written test program."""
from procedura_brep.program import *

# === params ===
post_d = 20.0  # mm
post_h = 100.0  # mm
pin_d = 6.0  # mm, the revolute's nominal
blade_l = 160.0  # mm
blade_t = 2.0  # mm, blade thickness in the swing plane
fin_t = 1.0  # mm, fin thickness
fin_deg = {fin_deg}  # deg, where the fin stands

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base plate")
def base():
    return Box(200, 200, 10, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="post")
def post():
    return Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="aluminium", description="thin blade swinging about the post axis")
def blade():
    return Pos(-10, 0, 0) * Box(blade_l, blade_t, 12, align=(Align.MIN, Align.CENTER, Align.MIN))
{fin_part}{tip_part}
# === frames ===
frames("base", top=Location((0, 0, 0)))
frames("post", foot=Location((0, 0, 0)), head=Location((0, 0, post_h)))
frames("blade", pivot=Location((0, 0, 0)))
{fin_frames}
{tip_frames}
# === assembly ===
mate("post.foot", "base.top", "peg_socket", nominal="post_d", fit="location", features=False)
mate("blade.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-60, 60), features=False)
{fin_mate}{tip_mate}'''

FIN_PART = '''
@part(detail="sub", material="steel", description="thin fin standing in the blade's path")
def fin():
    a = math.radians(fin_deg)
    return Pos(120 * math.cos(a), 120 * math.sin(a), {fin_z}) * Rot(0, 0, fin_deg) * Box(40, fin_t, 30)
'''
#: A weight bolted on the blade's tip, standing above it (z 12 to 30): a second part of the
#: moved link.
TIP_PART = '''
@part(detail="sub", material="steel", description="weight on top of the blade tip")
def tip():
    return Box(30, blade_t, 18, align=(Align.MIN, Align.CENTER, Align.MIN))
'''
TIP_FRAMES = 'frames("blade", pivot=Location((0, 0, 0)), top=Location((115, 0, 12)))\nframes("tip", foot=Location((0, 0, 0)))'
TIP_MATE = 'mate("tip.foot", "blade.top", "peg_socket", nominal="pin_d", fit="location", features=False)\n'
FIN_FRAMES = 'frames("fin", foot=Location((0, 0, 0)))'
FIN_MATE = 'mate("fin.foot", "post.head", "peg_socket", nominal="post_d", fit="location", features=False)\n'


def program(fin_deg: float | None, *, fin_z: float = 6.0, tip: bool = False) -> str:
    """The program with a fin at ``fin_deg`` degrees about the post axis (its centre
    ``fin_z`` mm up), or without one; ``tip`` adds a second part to the blade's link."""
    with_fin = fin_deg is not None
    src = TEMPLATE.format(fin_deg=fin_deg if with_fin else 0.0,
                          fin_part=FIN_PART.format(fin_z=fin_z) if with_fin else "",
                          fin_frames=FIN_FRAMES if with_fin else "",
                          fin_mate=FIN_MATE if with_fin else "",
                          tip_part=TIP_PART if tip else "", tip_frames=TIP_FRAMES if tip else "",
                          tip_mate=TIP_MATE if tip else "")
    if tip:  # the blade's frames are declared with the tip's
        src = src.replace('frames("blade", pivot=Location((0, 0, 0)))\n', "", 1)
    return src
