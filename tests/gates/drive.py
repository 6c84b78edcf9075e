"""Real teeth for the coupling gate: a pinion driving a wheel (gear) and a rack (rack and
pinion), a planet driving a ring gear (internal gear), and a lead screw driving its nut."""
from procedura_brep.program import *

# === params ===
base_t = 6.0        # mm, base plate thickness
pin_d = 5.0         # mm, gear pins: the nominal of the gear revolutes
guide_w = 8.0       # mm, the nominal of the slides
m = 1.5             # mm, module of every gear
z_pinion = 15       # teeth of the pinion
z_wheel = 30        # teeth of the wheel
z_planet = 12       # teeth of the planet
z_ring = 36         # teeth of the ring gear
pinion_w = 20.0     # mm, pinion width: the wheel meshes its upper half, the rack its lower half
gear_w = 8.0        # mm, wheel, rack, planet and ring width
wheel_phase = 0.5   # tooth pitches: the wheel's tooth count is even, so half a pitch
rack_phase = 0.25   # tooth pitches: a rack space under the pinion tooth nearest -Y
rack_len = 60.0     # mm
rack_h = 6.0        # mm, rack back face to pitch line
spread = 0.0        # mm, extra distance of the wheel axis (a fault when not 0)
rack_gap = 0.0      # mm, extra distance of the rack's pitch line (a fault when not 0)
nut_off = 0.0       # mm, the nut's slide axis off the screw axis (a fault when not 0)
screw_d = 10.0      # mm, lead screw major diameter
lead = 2.5          # mm per turn
screw_l = 40.0      # mm
nut_l = 10.0        # mm

# === helpers ===
def wheel_x():
    """The wheel axis: the pitch circles touch (plus the planted spread)."""
    return m * (z_pinion + z_wheel) / 2 + spread


def ring_x():
    """The ring's axis, left of the planet by (z_ring - z_planet) m / 2."""
    return -70 - m * (z_ring - z_planet) / 2


# === parts ===
@part(detail="silhouette", material="aluminium", description="base plate under every gear")
def base():
    return Box(230, 130, base_t, align=(Align.CENTER, Align.CENTER, Align.MAX))


@part(detail="major", material="steel", description="15-tooth pinion, 20 mm wide")
def pinion():
    return Pos(0, 0, pinion_w / 2) * spur_gear(m, z_pinion, pinion_w)


@part(detail="major", material="steel", description="30-tooth wheel meshing the pinion's upper half")
def wheel():
    return Pos(0, 0, gear_w / 2) * spur_gear(m, z_wheel, gear_w, phase=wheel_phase)


@part(detail="major", material="steel", description="rack under the pinion, meshing its lower half")
def rack_bar():
    return rack(m, rack_len, gear_w, rack_h, phase=rack_phase)


@part(detail="major", material="steel", description="12-tooth planet inside the ring")
def planet():
    return Pos(0, 0, gear_w / 2) * spur_gear(m, z_planet, gear_w)


@part(detail="major", material="steel", description="36-tooth ring gear around the planet")
def ring():
    return Pos(0, 0, gear_w / 2) * ring_gear(m, z_ring, gear_w)


@part(detail="major", material="steel", description="lead screw along X")
def screw():
    return lead_screw(screw_d, lead, screw_l)


@part(detail="major", material="brass", description="nut on the screw")
def nut():
    return lead_nut(screw_d, lead, nut_l)


# === frames ===
frames("base", p_axis=Location((0, 0, 1)), w_axis=Location((wheel_x(), 0, 12)),
       rail=Location((0, -m * z_pinion / 2 - rack_gap, 1 + gear_w / 2), (0, 90, 0)),
       q_axis=Location((-70, 0, 1)), r_axis=Location((ring_x(), 0, 1)),
       s_axis=Location((-40, 50, 15), (0, 90, 0)),
       n_rail=Location((-40 + 6 * lead, 50, 15 + nut_off), (0, 90, 0)))
frames("pinion", hub=Location((0, 0, 0)))
frames("wheel", hub=Location((0, 0, 0)))
frames("rack_bar", slide=Location((0, 0, 0), (0, 90, 0)))
frames("planet", hub=Location((0, 0, 0)))
frames("ring", hub=Location((0, 0, 0)))
frames("screw", hub=Location((0, 0, 0)))
frames("nut", slide=Location((0, 0, 0)))

# === assembly ===
mate("pinion.hub", "base.p_axis", "revolute", nominal="pin_d", features=False)
mate("wheel.hub", "base.w_axis", "revolute", nominal="pin_d", features=False)
mate("rack_bar.slide", "base.rail", "prismatic", nominal="guide_w", limits=(-20, 20), features=False)
mate("planet.hub", "base.q_axis", "revolute", nominal="pin_d", features=False)
mate("ring.hub", "base.r_axis", "revolute", nominal="pin_d", features=False)
mate("screw.hub", "base.s_axis", "revolute", nominal="screw_d", features=False)
mate("nut.slide", "base.n_rail", "prismatic", nominal="guide_w", limits=(-10, 10), features=False)
couple("wheel_hub", "pinion_hub", "gear", driver_teeth="z_pinion", driven_teeth="z_wheel")
couple("rack_bar_slide", "pinion_hub", "rack_pinion", pinion_teeth="z_pinion", module="m")
couple("ring_hub", "planet_hub", "gear", driver_teeth="z_planet", driven_teeth="z_ring", internal=True)
couple("nut_slide", "screw_hub", "screw", lead="lead", hand="right")
