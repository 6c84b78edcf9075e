"""A tube keyed in a ring's bore. Hand-written test program (procedura-brep format)."""
from procedura_brep.program import *

# === params ===
tube_r = 15.0   # mm
ring_t = 8.0    # mm, ring wall
key_w = 4.0     # mm, the key: the nominal of the tube's key mate

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="a ring, axis along X")
def ring():
    return Rot(0, 90, 0) * (Cylinder(tube_r + ring_t, 20) - Cylinder(tube_r, 20))

@part(detail="major", material="steel", description="a tube in the ring")
def tube():
    # the tube's axis along X, 15 mm above its mounting frame (on its underside)
    return Pos(0, 0, tube_r) * Rot(0, 90, 0) * Cylinder(tube_r, 120)

# === frames ===
frames("ring", bore=Location((0, 0, -tube_r), (0, 0, 90)))
frames("tube", seat=Location((0, 0, 0), (0, 0, 90)))

# === assembly ===
mate("tube.seat", "ring.bore", "key", nominal="key_w", fit="location", length=12)
