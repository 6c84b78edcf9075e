"""A base with a pinion driving a wheel (gear) and a rack (rack and pinion), and a lead screw
driving a nut (screw): plain cylinders and boxes, the couplings' test program. The rack and the
nut slide on the base, the screw lies in the nut's bore: every part touches (the gates pass)."""
from procedura_brep.program import *

# === params ===
base_w = 300.0  # mm, base length (X)
base_d = 200.0  # mm, base depth (Y)
base_t = 10.0  # mm, base thickness
shaft_d = 8.0  # mm, hinge pin: the nominal of the gear mates
guide_w = 10.0  # mm, the nominal of the slides
gear_m = 2.0  # mm, module
z_pinion = 12  # teeth of the pinion
z_wheel = 36  # teeth of the wheel
gear_w = 10.0  # mm, wheel width
pinion_w = 30.0  # mm, pinion width
screw_d = 10.0  # mm, lead screw diameter
screw_l = 160.0  # mm, lead screw length
screw_lead = 4.0  # mm per turn

# === helpers ===

# === parts ===
@part(detail="silhouette", material="steel", description="base plate")
def base():
    return Box(base_w, base_d, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="pinion, a disc 1 mm inside its pitch circle")
def pinion():
    return Cylinder(gear_m * z_pinion / 2 - 1, pinion_w, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="wheel, a disc 1 mm inside its pitch circle")
def wheel():
    return Cylinder(gear_m * z_wheel / 2 - 1, gear_w, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="rack along X, origin on its pitch line")
def rack():
    return Box(120, 10, 10, align=(Align.CENTER, Align.MAX, Align.MIN))

@part(detail="major", material="steel", description="lead screw along X")
def screw():
    return Cylinder(screw_d / 2, screw_l, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="nut block on the base, the screw through its bore")
def nut():
    return Box(20, 20, 20) - Cylinder(screw_d / 2, 20)

# === frames ===
frames("base", p_axis=Location((-24, 0, base_t + 1)),
       w_axis=Location((-24, gear_m * (z_pinion + z_wheel) / 2, base_t + 1)),
       rail=Location((-24, -gear_m * z_pinion / 2, base_t), (0, 90, 0)),
       s_axis=Location((-screw_l / 2, -70, base_t + 10), (0, 90, 0)),
       n_rail=Location((0, -70, base_t + 10), (0, 90, 0)))
frames("pinion", hub=Location((0, 0, 0)))
frames("wheel", hub=Location((0, 0, 0)))
frames("rack", slide=Location((0, 0, 0), (0, 90, 0)))
frames("screw", hub=Location((0, 0, 0)))
frames("nut", slide=Location((0, 0, 0)))

# === assembly ===
mate("pinion.hub", "base.p_axis", "revolute", nominal="shaft_d", limits=(-180, 180))
mate("wheel.hub", "base.w_axis", "revolute", nominal="shaft_d", limits=(-180, 180))
mate("rack.slide", "base.rail", "prismatic", nominal="guide_w", limits=(-40, 40), features=False)
mate("screw.hub", "base.s_axis", "revolute", nominal="screw_d", features=False)
mate("nut.slide", "base.n_rail", "prismatic", nominal="guide_w", limits=(-40, 40), features=False)
couple("wheel_hub", "pinion_hub", "gear", driver_teeth="z_pinion", driven_teeth="z_wheel")
couple("rack_slide", "pinion_hub", "rack_pinion", pinion_teeth="z_pinion", module="gear_m")
couple("nut_slide", "screw_hub", "screw", lead="screw_lead", hand="right")
