"""A gear pair for B2's coupled sweep (hand-written test program, not model output): a driver
disc turns a driven disc at 20:40 teeth (plain discs 1 mm inside their pitch circles); an arm
on the driven disc reaches out over a post that stands ``post_deg`` about the driven axis. Both
mates allow +-170 deg, so the driven disc, following the driver, turns only +-85 deg: a post at
120 deg is out of the arm's reach, one at 60 deg in it."""

from __future__ import annotations

TEMPLATE = '''"""A driver disc turns a driven disc (20:40); an arm on the driven disc, a post on the base. Hand-written test program."""
from procedura_brep.program import *
import math

# === params ===
gear_m = 2.0  # mm, module
z1 = 20  # teeth of the driver
z2 = 40  # teeth of the driven disc
shaft_d = 8.0  # mm, nominal of the revolutes
peg_d = 6.0  # mm, nominal of the static mates
post_deg = {post_deg}  # deg, the post's angle about the driven axis from the arm at rest
post_r = 50.0  # mm, the post's distance from the driven axis

# === helpers ===
def centre_distance():
    return gear_m * (z1 + z2) / 2

# === parts ===
@part(detail="silhouette", material="steel", description="base plate")
def base():
    return Box(300, 200, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="driver disc, 1 mm inside its pitch circle")
def driver():
    return Cylinder(gear_m * z1 / 2 - 1, 8, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="steel", description="driven disc, 1 mm inside its pitch circle")
def driven():
    return Cylinder(gear_m * z2 / 2 - 1, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="sub", material="steel", description="arm on the driven disc, along its +X")
def arm():
    return Box(60, 8, 6, align=(Align.MIN, Align.CENTER, Align.MIN))

@part(detail="sub", material="steel", description="post on the base")
def post():
    return Box(6, 6, 30, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === frames ===
frames("base", d_axis=Location((0, 0, 11)), n_axis=Location((centre_distance(), 0, 11)),
       post=Location((centre_distance() + post_r * math.cos(math.radians(post_deg)), post_r * math.sin(math.radians(post_deg)), 10)))
frames("driver", hub=Location((0, 0, 0)))
frames("driven", hub=Location((0, 0, 0)), top=Location((0, 0, 10)))
frames("arm", foot=Location((0, 0, 0)))
frames("post", foot=Location((0, 0, 0)))

# === assembly ===
mate("driver.hub", "base.d_axis", "revolute", nominal="shaft_d", limits=(-170, 170), features=False)
mate("driven.hub", "base.n_axis", "revolute", nominal="shaft_d", limits=(-170, 170), features=False)
mate("arm.foot", "driven.top", "peg_socket", nominal="peg_d", fit="location", features=False)
mate("post.foot", "base.post", "peg_socket", nominal="peg_d", fit="location", features=False)
couple("driven_hub", "driver_hub", "gear", driver_teeth="z1", driven_teeth="z2")
'''


def program(post_deg: float) -> str:
    """The program with the post at ``post_deg`` about the driven axis."""
    return TEMPLATE.format(post_deg=post_deg)
