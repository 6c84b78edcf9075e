"""A saddle on a round tube: curved contact. Hand-written test program (procedura-brep format)."""
from procedura_brep.program import *

# === params ===
tube_r = 20.0   # mm
tube_l = 200.0  # mm
seat_d = 40.0   # mm, the saddle seat: the nominal of its seat mate

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="a round tube lying along X")
def tube():
    return Rot(0, 90, 0) * Cylinder(tube_r, tube_l)

@part(detail="major", material="steel", description="a saddle clamped on the tube's top")
def saddle():
    block = Box(40, 30, 18, align=(Align.CENTER, Align.CENTER, Align.MIN))
    block = Pos(0, 0, -8) * block
    return block - Pos(0, 0, -tube_r) * Rot(0, 90, 0) * Cylinder(tube_r, 60)

# === frames ===
frames("tube", top=Location((0, 0, tube_r)))
frames("saddle", seat=Location((0, 0, 0)))

# === assembly ===
mate("saddle.seat", "tube.top", "seat_face", nominal="seat_d", features=False)
