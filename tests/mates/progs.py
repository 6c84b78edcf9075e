"""Hand-written two-part test programs, one per mate type (not model output)."""

from __future__ import annotations

TEMPLATE = '''"""{mtype} test: a block on a base. Hand-written test program."""
from procedura_brep.program import *

# === params ===
nom = {nominal}  # mm, the mate's nominal
base_h = 40.0  # mm
block_h = 30.0  # mm

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base block")
def base():
    return Box(160, 160, base_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="aluminium", description="block seated on the base")
def block():
    return Box(90, 90, block_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("base", top=Location((7, -4, base_h), (0, 0, 30)))
frames("block", foot=Location((3, 2, 0), (0, 0, -15)))

# === assembly ===
mate("block.foot", "base.top", "{mtype}", nominal="nom", fit="{fit}"{options})
'''

#: (type, nominal, default fit, options source)
CASES = [
    ("bolt_pattern", 6.0, "clearance", ", count=4, pcd=40"),
    ("peg_socket", 10.0, "clearance", ""),
    ("seat_face", 30.0, "location", ""),
    ("flange", 40.0, "location", ""),
    ("tab_slot", 20.0, "location", ""),
    ("press_fit", 10.0, "press", ""),
    ("lip_rabbet", 50.0, "location", ""),
    ("snap_tab", 12.0, "snap", ""),
    ("key", 8.0, "location", ""),
    ("revolute", 10.0, "clearance", ", limits=(-45, 90)"),
    ("prismatic", 12.0, "clearance", ", limits=(-5, 20)"),
    ("spherical", 20.0, "clearance", ", cone=30"),
    ("cylindrical", 16.0, "clearance", ", limits=(-5, 20), angle_limits=(-90, 120), home=4, home_angle=30"),
]


def program(mtype: str, nominal: float, fit: str, options: str = "") -> str:
    return TEMPLATE.format(mtype=mtype, nominal=nominal, fit=fit, options=options)
