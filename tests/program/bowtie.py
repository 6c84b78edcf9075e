"""Bowtie. Hand-written test program (procedura-brep format)."""
from procedura_brep.program import *

# === params ===
plate_t = 5.0  # mm

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="a plate")
def plate():
    return Box(60, 40, plate_t, align=(Align.CENTER, Align.CENTER, Align.MAX))

@part(detail="major", material="steel", description="a block with a bad wing")
def block():
    body = Box(30, 30, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))
    wing = extrude(Face(Wire.make_polygon([(0, 0), (10, 10), (10, 0), (0, 30)], close=True)), 5)
    return body + Pos(20, 0, 0) * wing

# === frames ===
frames("plate", top=Location((0, 0, 0)))
frames("block", foot=Location((0, 0, 0)))

# === assembly ===
mate("block.foot", "plate.top", "seat_face", nominal="plate_t", features=False)
