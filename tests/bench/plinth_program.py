"""A plinth with a column and a cap. Hand-written test program (procedura-brep format) for the
CI bench: three parts, static mates only."""
from procedura_brep.program import *

# === params ===
plinth_w = 80.0  # mm, square plinth side
plinth_t = 10.0  # mm, plinth thickness
col_d = 24.0     # mm, column diameter
col_h = 60.0     # mm, column height
col_peg_d = 10.0  # mm, peg under the column: the nominal of its peg_socket
cap_d = 36.0     # mm, cap diameter
cap_t = 8.0      # mm, cap thickness
cap_peg_d = 8.0  # mm, peg under the cap: the nominal of its peg_socket

# === helpers ===

# === parts ===
@part(detail="silhouette", material="cast_iron", description="square plinth 80 x 80 x 10 mm, chamfered")
def plinth():
    b = Box(plinth_w, plinth_w, plinth_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return chamfer(b.edges().group_by(Axis.Z)[-1], length=2.0)

@part(detail="major", material="brushed_steel", description="round column 24 mm on the plinth centre")
def column():
    return Cylinder(col_d / 2, col_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="sub", material="painted_aluminium", description="round cap 36 mm on the column top")
def cap():
    c = Cylinder(cap_d / 2, cap_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return fillet(c.edges().group_by(Axis.Z)[-1], radius=2.0)

# === frames ===
frames("plinth", top=Location((0, 0, plinth_t)))
frames("column", foot=Location((0, 0, 0)), head=Location((0, 0, col_h)))
frames("cap", foot=Location((0, 0, 0)))

# === assembly ===
mate("column.foot", "plinth.top", "peg_socket", nominal="col_peg_d", fit="location")
mate("cap.foot", "column.head", "peg_socket", nominal="cap_peg_d", fit="location")
