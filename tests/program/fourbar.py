"""A parallelogram four-bar: a crank and a rocker on a ground plate, a coupler joining their
tips; the coupler's pin in the rocker closes the loop (the cut joint). Couplings' test program."""
from procedura_brep.program import *

# === params ===
ground_l = 260.0  # mm, ground plate length (X)
ground_t = 10.0  # mm, ground plate thickness
span = 160.0  # mm, pivot distance on the ground = coupler length
arm_l = 90.0  # mm, crank and rocker length
bar_w = 16.0  # mm, bar width
bar_t = 8.0  # mm, bar thickness
pin_d = 6.0  # mm, hinge pins: the nominal of every revolute

# === helpers ===
def bar(length):
    """A flat bar from its origin along +Y (rounded ends), bar_t thick above z = 0."""
    body = Box(bar_w, length, bar_t, align=(Align.CENTER, Align.MIN, Align.MIN))
    ends = [Pos(0, y, 0) * Cylinder(bar_w / 2, bar_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
            for y in (0, length)]
    return body + ends[0] + ends[1]

# === parts ===
@part(detail="silhouette", material="steel", description="ground plate under both pivots")
def ground():
    return Box(ground_l, 60, ground_t, align=(Align.MIN, Align.CENTER, Align.MAX))

@part(detail="major", material="aluminium", description="crank, arm_l long, on the left pivot")
def crank():
    return bar(arm_l)

@part(detail="major", material="aluminium", description="rocker, arm_l long, on the right pivot")
def rocker():
    return bar(arm_l)

@part(detail="major", material="aluminium", description="coupler along X from the crank tip to the rocker tip")
def coupler():
    return Rot(0, 0, -90) * bar(span)

# === frames ===
frames("ground", a_pivot=Location((50, 0, 0)), d_pivot=Location((50 + span, 0, 0)))
frames("crank", base=Location((0, 0, 0)), tip=Location((0, arm_l, bar_t)))
frames("rocker", base=Location((0, 0, 0)), tip=Location((0, arm_l, bar_t)))
frames("coupler", b_end=Location((0, 0, 0)), c_end=Location((span, 0, 0)))

# === assembly ===
mate("crank.base", "ground.a_pivot", "revolute", nominal="pin_d", limits=(-50, 50))
mate("rocker.base", "ground.d_pivot", "revolute", nominal="pin_d", limits=(-60, 60))
mate("coupler.b_end", "crank.tip", "revolute", nominal="pin_d", limits=(-90, 90))
mate("coupler.c_end", "rocker.tip", "revolute", nominal="pin_d", limits=(-90, 90), name="loop_pin")
couple("rocker_base", "crank_base", "linkage", closes="loop_pin")
