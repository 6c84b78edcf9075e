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
{fin_part}
# === frames ===
frames("base", top=Location((0, 0, 0)))
frames("post", foot=Location((0, 0, 0)), head=Location((0, 0, post_h)))
frames("blade", pivot=Location((0, 0, 0)))
{fin_frames}
# === assembly ===
mate("post.foot", "base.top", "peg_socket", nominal="post_d", fit="location", features=False)
mate("blade.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-60, 60), features=False)
{fin_mate}'''

FIN_PART = '''
@part(detail="sub", material="steel", description="thin fin standing in the blade's path")
def fin():
    a = math.radians(fin_deg)
    return Pos(120 * math.cos(a), 120 * math.sin(a), 6) * Rot(0, 0, fin_deg) * Box(40, fin_t, 30)
'''
FIN_FRAMES = 'frames("fin", foot=Location((0, 0, 0)))'
FIN_MATE = 'mate("fin.foot", "post.head", "peg_socket", nominal="post_d", fit="location", features=False)\n'


def program(fin_deg: float | None) -> str:
    """The program with a fin at ``fin_deg`` degrees about the post axis, or without one."""
    with_fin = fin_deg is not None
    return TEMPLATE.format(fin_deg=fin_deg if with_fin else 0.0,
                           fin_part=FIN_PART if with_fin else "",
                           fin_frames=FIN_FRAMES if with_fin else "",
                           fin_mate=FIN_MATE if with_fin else "")
