"""A small box with a hinged lid and a knob. Hand-written test program (procedura-brep format)."""
from procedura_brep.program import *

# === params ===
case_w = 100.0  # mm, case width (X)
case_d = 70.0   # mm, case depth (Y)
case_h = 40.0   # mm, case height
wall_t = 4.0    # mm, case wall
lid_t = 8.0     # mm, lid thickness
barrel_r = 6.0  # mm, hinge barrel radius
hinge_d = 6.0   # mm, hinge pin: the nominal of the lid's revolute mate
knob_peg_d = 5.0  # mm, knob peg: the nominal of its peg_socket mate

# === helpers ===
def barrel(x0, length):
    """A hinge barrel along +X from x0, on the hinge axis (local origin on the axis)."""
    return Pos(x0 + length / 2, 0, 0) * Rot(0, 90, 0) * Cylinder(barrel_r, length)

# === parts ===
@part(detail="silhouette", material="painted_steel", description="open box 100 x 70 x 40 mm with a hinge barrel at the back")
def case():
    body = Box(case_w, case_d, case_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    body -= Pos(0, 0, wall_t) * Box(case_w - 2 * wall_t, case_d - 2 * wall_t, case_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    axis = Pos(0, case_d / 2 + barrel_r, case_h)
    web = Pos(0, case_d / 2 + barrel_r / 2 - 1, case_h - barrel_r / 2) * Box(30, barrel_r + 2, barrel_r)
    return body + web + axis * barrel(-15, 30)

@part(detail="major", material="painted_steel", description="flat lid 100 x 76 x 8 mm hinged at the back edge")
def lid():
    plate = Pos(-15, -(case_d + barrel_r) / 2, lid_t / 2) * Box(case_w, case_d + barrel_r, lid_t)
    plate -= Pos(-15.25, 0, 0) * Rot(0, 90, 0) * Cylinder(barrel_r + 0.5, 30.5)
    return plate + barrel(0, 12)

@part(detail="sub", material="black_oxide_steel", description="round knob 16 mm on the lid front")
def knob():
    return Cylinder(8, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("case", hinge=Location((15, case_d / 2 + barrel_r, case_h), (0, 90, 0)))
frames("lid", hinge=Location((0, 0, 0), (0, 90, 0)), knob=Location((-15, -case_d, lid_t)))
frames("knob", foot=Location((0, 0, 0)))

# === assembly ===
mate("lid.hinge", "case.hinge", "revolute", nominal="hinge_d", fit="clearance", limits=(-75, 0), depth=12)
mate("knob.foot", "lid.knob", "peg_socket", nominal="knob_peg_d", fit="location")
