"""A linear axis for B2's sliding-contact sweeps (issue 23.2; hand-written test program, not
model output): four U-shaped bearing blocks under a carriage touch their two rails on three
faces at every pose over 760 mm of travel; optionally a stop block bolted on the left rail
stands in the left blocks' path (the front one meets it at 395 mm)."""

from __future__ import annotations

#: Travel (mm) at which block_lf's front face meets the stop's back face.
STOP_MEETS_MM = 395.0

TEMPLATE = '''"""A linear axis: a carriage on four U-shaped blocks sliding on two rails, 760 mm of travel; stop block: {stop}. Hand-written test program."""
from procedura_brep.program import *

# === params ===
base_l = 1000.0  # mm, base length (X)
base_w = 200.0  # mm, base width (Y)
base_t = 20.0  # mm, base thickness
end_h = 80.0  # mm, end plate height above the base
end_t = 20.0  # mm, end plate thickness
rail_len = 970.0  # mm, rail length
rail_w = 20.0  # mm, rail width
rail_h = 20.0  # mm, rail height
rail_y = 60.0  # mm, rail centre offset from the axis
rail_x0 = -475.0  # mm, rail start (X)
peg_d = 8.0  # mm, rail peg: nominal of the rails' peg_socket
blk_l = 50.0  # mm, bearing block length
blk_w = 40.0  # mm, bearing block width
blk_h = 28.0  # mm, bearing block height
blk_top = 10.0  # mm, block material above the rail
seat_d = 12.0  # mm, block seat: nominal of the blocks' seat_face
car_l = 200.0  # mm, carriage length
car_w = 180.0  # mm, carriage width
car_t = 10.0  # mm, carriage thickness
blk_dx = 60.0  # mm, block offset from the carriage centre (X)
guide_w = 8.0  # mm, guide bar: nominal of the carriage's prismatic mate
travel = 760.0  # mm, carriage travel
stop_x = 100.0  # mm, stop block position along the left rail (from its centre)
stop_peg_d = 5.0  # mm, stop peg: nominal of the stop's peg_socket

# === helpers ===
def block():
    b = Box(blk_l, blk_w, blk_h, align=(Align.CENTER, Align.CENTER, Align.MAX))
    return b - Pos(0, 0, -blk_top) * Box(blk_l + 2, rail_w, blk_h, align=(Align.CENTER, Align.CENTER, Align.MAX))

def rail_top_z():
    return base_t + rail_h

# === parts ===
@part(detail="silhouette", material="cast_iron", description="base plate with an end plate at -X")
def base():
    b = Pos(0, 0, 0) * Box(base_l, base_w, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
    e = Pos(-base_l / 2 + end_t / 2, 0, base_t) * Box(end_t, base_w, end_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return b + e

@part(detail="major", material="brushed_steel", description="left rail")
def rail_l():
    return Box(rail_len, rail_w, rail_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="brushed_steel", description="right rail")
def rail_r():
    return Box(rail_len, rail_w, rail_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="painted_aluminium", description="carriage plate")
def carriage():
    return Box(car_l, car_w, car_t, align=(Align.MIN, Align.CENTER, Align.CENTER))

@part(detail="major", material="brushed_steel", description="bearing block, left front")
def block_lf():
    return block()

@part(detail="major", material="brushed_steel", description="bearing block, left back")
def block_lb():
    return block()

@part(detail="major", material="brushed_steel", description="bearing block, right front")
def block_rf():
    return block()

@part(detail="major", material="brushed_steel", description="bearing block, right back")
def block_rb():
    return block()

{stop_part}# === frames ===
frames("base", rail_l=Location((rail_x0 + rail_len / 2, -rail_y, base_t)),
       rail_r=Location((rail_x0 + rail_len / 2, rail_y, base_t)),
       slide=Location((-base_l / 2 + end_t, 0, rail_top_z() + blk_top + car_t / 2), (0, 90, 0)))
frames("rail_l", foot=Location((0, 0, 0)), stop=Location((stop_x, 0, rail_h)))
{stop_frames}frames("rail_r", foot=Location((0, 0, 0)))
frames("carriage", slide=Location((0, 0, 0), (0, 90, 0)),
       lf=Location((car_l / 2 + blk_dx, -rail_y, -car_t / 2), (180, 0, 0)),
       lb=Location((car_l / 2 - blk_dx, -rail_y, -car_t / 2), (180, 0, 0)),
       rf=Location((car_l / 2 + blk_dx, rail_y, -car_t / 2), (180, 0, 0)),
       rb=Location((car_l / 2 - blk_dx, rail_y, -car_t / 2), (180, 0, 0)))
frames("block_lf", top=Location((0, 0, 0), (180, 0, 0)))
frames("block_lb", top=Location((0, 0, 0), (180, 0, 0)))
frames("block_rf", top=Location((0, 0, 0), (180, 0, 0)))
frames("block_rb", top=Location((0, 0, 0), (180, 0, 0)))

# === assembly ===
mate("rail_l.foot", "base.rail_l", "peg_socket", nominal="peg_d", fit="location")
mate("rail_r.foot", "base.rail_r", "peg_socket", nominal="peg_d", fit="location")
mate("carriage.slide", "base.slide", "prismatic", nominal="guide_w", fit="clearance", limits=(0, travel))
mate("block_lf.top", "carriage.lf", "seat_face", nominal="seat_d", fit="location")
mate("block_lb.top", "carriage.lb", "seat_face", nominal="seat_d", fit="location")
mate("block_rf.top", "carriage.rf", "seat_face", nominal="seat_d", fit="location")
mate("block_rb.top", "carriage.rb", "seat_face", nominal="seat_d", fit="location")
{stop_mate}'''

STOP_PART = '''@part(detail="sub", material="brushed_steel", description="stop block bolted on the left rail")
def stop():
    return Box(20, 16, 8, align=(Align.CENTER, Align.CENTER, Align.MIN))

'''


def program(stop: bool) -> str:
    """The program text, with or without the stop block on the left rail."""
    return TEMPLATE.format(
        stop="yes" if stop else "no",
        stop_part=STOP_PART if stop else "",
        stop_frames='frames("stop", foot=Location((0, 0, 0)))\n' if stop else "",
        stop_mate=('mate("stop.foot", "rail_l.stop", "peg_socket", nominal="stop_peg_d", '
                   'fit="location")\n') if stop else "")
