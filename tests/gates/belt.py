"""Belts for the coupling gate: a timing belt from a 20-tooth pulley on a shaft (one part) to a
24-tooth pulley, and a flat belt from a 20 mm roller bolted on a shaft (its rigid link) to a
40 mm roller."""
# ruff: noqa: F403, F405 (the program format binds its API with a star import)
from procedura_brep.program import *

# === params ===
base_t = 6.0        # mm, base plate thickness
shaft_d = 6.0       # mm, shafts: the nominal of the revolutes
shaft_l = 40.0      # mm
belt_w = 6.0        # mm, belt width (both pairs)
belt_z = 20.0       # mm, height of the belt's middle above the shafts' feet
z_drive = 20        # teeth of the drive pulley
z_follow = 24       # teeth of the driven pulley
d_small = 20.0      # mm, small roller diameter (its belt seat)
d_big = 40.0        # mm, big roller diameter
pd_drive = 12.732   # mm, the drive pulley's pitch diameter, z_drive x 2 mm / pi (GT2)
pd_follow = 15.279  # mm, the driven pulley's, z_follow x 2 mm / pi
follow_shift = 0.0  # mm, the driven timing pulley moved along its axis (a fault when > belt_w)

# === helpers ===
def at_belt(shape):
    """``shape`` lifted to the belt's height above a shaft's foot."""
    return Pos(0, 0, belt_z) * shape


# === parts ===
@part(detail="silhouette", material="aluminium", description="base plate under both belts")
def base():
    return Box(160, 140, base_t, align=(Align.CENTER, Align.CENTER, Align.MAX))


@part(detail="major", material="steel", description="drive shaft with its 20-tooth pulley")
def drive_shaft():
    shaft = Cylinder(shaft_d / 2, shaft_l, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return shaft + at_belt(pulley(belt_w, teeth=z_drive, bore=shaft_d))


@part(detail="major", material="aluminium", description="24-tooth driven pulley")
def follow_pulley():
    return pulley(belt_w, teeth=z_follow, bore=shaft_d)


@part(detail="major", material="steel", description="shaft under the small roller")
def roller_shaft():
    return Cylinder(shaft_d / 2, shaft_l, align=(Align.CENTER, Align.CENTER, Align.MIN))


@part(detail="major", material="aluminium", description="20 mm roller on the roller shaft")
def small_roller():
    return pulley(belt_w, diameter=d_small, bore=shaft_d)


@part(detail="major", material="aluminium", description="40 mm driven roller")
def big_roller():
    return pulley(belt_w, diameter=d_big, bore=shaft_d)


# === frames ===
frames("base", drive_axis=Location((-50, -35, 1)),
       follow_axis=Location((10, -35, 1 + belt_z + follow_shift)),
       roller_axis=Location((-50, 35, 1)), big_axis=Location((20, 35, 1 + belt_z)))
frames("drive_shaft", hub=Location((0, 0, 0)))
frames("follow_pulley", hub=Location((0, 0, 0)))
frames("roller_shaft", hub=Location((0, 0, 0)), seat=Location((0, 0, belt_z)))
frames("small_roller", seat=Location((0, 0, 0)))
frames("big_roller", hub=Location((0, 0, 0)))

# === assembly ===
mate("drive_shaft.hub", "base.drive_axis", "revolute", nominal="shaft_d", features=False)
mate("follow_pulley.hub", "base.follow_axis", "revolute", nominal="shaft_d", features=False)
mate("roller_shaft.hub", "base.roller_axis", "revolute", nominal="shaft_d", features=False)
mate("small_roller.seat", "roller_shaft.seat", "seat_face", nominal="shaft_d", features=False)
mate("big_roller.hub", "base.big_axis", "revolute", nominal="shaft_d", features=False)
couple("follow_pulley_hub", "drive_shaft_hub", "belt", driver_teeth="z_drive", driven_teeth="z_follow")
couple("big_roller_hub", "roller_shaft_hub", "belt", driver_diameter="d_small", driven_diameter="d_big")
