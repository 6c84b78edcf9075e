"""Two-stage spur reduction gearbox: input pinion -> countershaft cluster -> output wheel, 9:1.

Hand-written golden program (procedura-brep format). Z is up; the three shafts stand on the
housing floor in a row along X, each journalled in a bore of the floor (a revolute mate), and
carry real involute teeth (spur_gear). Stage 1 (z1 -> z2) meshes low, stage 2 (z3 -> z4) high,
so the big wheels pass over each other. The cover seats on a corner boss of the base and is held
by four hex bolts; the input and output shafts pass through clearance holes in the cover. Each
mesh is a couple(...) whose ratio comes from the same tooth-count params that cut the teeth.
"""
from procedura_brep.program import *

# === params ===
m = 2.0             # mm, module of both stages
z1 = 14             # teeth, input pinion
z2 = 42             # teeth, countershaft wheel (stage 1: 3:1)
z3 = 15             # teeth, countershaft pinion
z4 = 45             # teeth, output wheel (stage 2: 3:1)
gear_w = 14.0       # mm, face width of every gear
shaft_d = 12.0      # mm, shaft diameter
journal_d = 10.0    # mm, shaft journal in the floor bore: nominal of the shaft revolutes
journal_l = 6.0     # mm, journal length: a blind bore, the floor stays closed under it
low_z = 8.0         # mm, stage 1 gears start this far above the floor
high_z = 28.0       # mm, stage 2 gears start this far above the floor
inner_h = 50.0      # mm, housing cavity height (floor top to cover)
floor_t = 10.0      # mm, housing floor thickness
wall_t = 8.0        # mm, housing wall thickness
gap = 8.0           # mm, clearance from a gear's tip to the wall
boss_r = 10.0       # mm, corner boss radius
cover_t = 8.0       # mm, cover thickness
stick_out = 30.0    # mm, input and output shafts above the cover
seat_d = 8.0        # mm, cover locating pad on a corner boss: nominal of its seat_face mate
bolt_d = 6.0        # mm, cover bolts (M6): nominal of their peg_socket mates
plug_d = 10.0       # mm, breather and drain plugs: nominal of their peg_socket mates

# === helpers ===
def tip(z):
    """Tip radius of a gear of z teeth, mm."""
    return m * (z / 2 + 1)


def a1():
    """Stage 1 centre distance, mm."""
    return m * (z1 + z2) / 2


def a2():
    """Stage 2 centre distance, mm."""
    return m * (z3 + z4) / 2


def half_l():
    """Half the cavity length (X), mm."""
    return (tip(z1) + a1() + a2() + tip(z4)) / 2 + gap


def half_w():
    """Half the cavity width (Y), mm."""
    return max(tip(z2), tip(z4)) + gap


def shaft_x(i):
    """X of shaft i (0 input, 1 countershaft, 2 output) in the housing's frame, mm."""
    x0 = -half_l() + gap + tip(z1)
    return [x0, x0 + a1(), x0 + a1() + a2()][i]


def corners():
    """The four bolt boss centres (x, y), mm."""
    x, y = half_l() + wall_t, half_w() + wall_t
    return [(x, y), (-x, y), (-x, -y), (x, -y)]


def gear_at(z, z0, phase=0.0):
    """A spur gear of z teeth whose face starts z0 above the shaft's seat."""
    return Pos(0, 0, z0 + gear_w / 2) * spur_gear(m, z, gear_w, phase=phase)


def hex_bolt_head():
    """M6 hex head, 10 mm across flats, 4 mm high, chamfered."""
    head = extrude(RegularPolygon(10 / math.sqrt(3), 6), 4)
    return chamfer(head.edges().group_by(Axis.Z)[-1], length=0.5)


# === parts ===
@part(detail="silhouette", material="cast_iron", description="housing base: floor, four walls, corner bosses")
def base():
    lo = (Align.CENTER, Align.CENTER, Align.MIN)
    outer = Pos(0, 0, -floor_t) * Box(2 * (half_l() + wall_t), 2 * (half_w() + wall_t),
                                      floor_t + inner_h, align=lo)
    cavity = Box(2 * half_l(), 2 * half_w(), inner_h + 1, align=lo)
    bosses = [Pos(x, y, -floor_t) * Cylinder(boss_r, floor_t + inner_h, align=lo)
              for x, y in corners()]
    return outer - cavity + bosses


@part(detail="major", material="painted_aluminium", description="cover plate with corner ears, shaft clearance holes")
def cover():
    lo = (Align.CENTER, Align.CENTER, Align.MIN)
    plate = Box(2 * (half_l() + wall_t), 2 * (half_w() + wall_t), cover_t, align=lo)
    ears = [Pos(x, y, 0) * Cylinder(boss_r, cover_t, align=lo) for x, y in corners()]
    holes = [Pos(shaft_x(i), 0, 0) * Cylinder(shaft_d / 2 + 1, 3 * cover_t) for i in (0, 2)]
    return plate + ears - holes


@part(detail="major", material="steel", description="input shaft with the 14-tooth stage 1 pinion")
def input_shaft():
    shaft = Cylinder(shaft_d / 2, inner_h + cover_t + stick_out, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return shaft + gear_at(z1, low_z)


@part(detail="major", material="steel", description="countershaft: 42-tooth stage 1 wheel and 15-tooth stage 2 pinion")
def countershaft():
    shaft = Cylinder(shaft_d / 2, inner_h - 2, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return shaft + gear_at(z2, low_z, phase=0.5) + gear_at(z3, high_z)


@part(detail="major", material="steel", description="output shaft with the 45-tooth stage 2 wheel")
def output_shaft():
    shaft = Cylinder(shaft_d / 2, inner_h + cover_t + stick_out, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return shaft + gear_at(z4, high_z)


@part(detail="sub", material="black_oxide_steel", description="cover bolt, +X +Y corner")
def bolt_1():
    return hex_bolt_head()


@part(detail="sub", material="black_oxide_steel", description="cover bolt, -X +Y corner")
def bolt_2():
    return hex_bolt_head()


@part(detail="sub", material="black_oxide_steel", description="cover bolt, -X -Y corner")
def bolt_3():
    return hex_bolt_head()


@part(detail="sub", material="black_oxide_steel", description="cover bolt, +X -Y corner")
def bolt_4():
    return hex_bolt_head()


@part(detail="sub", material="brass", description="breather plug on the cover")
def breather():
    cap = Cylinder(8, 5, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return cap + Pos(0, 0, 5) * Cylinder(4, 4, align=(Align.CENTER, Align.CENTER, Align.MIN))


@part(detail="sub", material="brass", description="oil drain plug in the +X end wall")
def drain_plug():
    return extrude(RegularPolygon(7, 6), 5)


# === frames ===
frames("base", seat=Location((corners()[0][0], corners()[0][1], inner_h)),
       shaft_in=Location((shaft_x(0), 0, 0)), shaft_mid=Location((shaft_x(1), 0, 0)),
       shaft_out=Location((shaft_x(2), 0, 0)),
       drain=Location((half_l() + wall_t, 0, 6 - floor_t / 2), (0, 90, 0)))
frames("cover", seat=Location((corners()[0][0], corners()[0][1], 0)),
       bolt_1=Location((corners()[0][0], corners()[0][1], cover_t)),
       bolt_2=Location((corners()[1][0], corners()[1][1], cover_t)),
       bolt_3=Location((corners()[2][0], corners()[2][1], cover_t)),
       bolt_4=Location((corners()[3][0], corners()[3][1], cover_t)),
       breather=Location((shaft_x(1), 0, cover_t)))
frames("input_shaft", seat=Location((0, 0, 0)))
frames("countershaft", seat=Location((0, 0, 0)))
frames("output_shaft", seat=Location((0, 0, 0)))
frames("bolt_1", foot=Location((0, 0, 0)))
frames("bolt_2", foot=Location((0, 0, 0)))
frames("bolt_3", foot=Location((0, 0, 0)))
frames("bolt_4", foot=Location((0, 0, 0)))
frames("breather", foot=Location((0, 0, 0)))
frames("drain_plug", foot=Location((0, 0, 0)))

# === assembly ===
mate("cover.seat", "base.seat", "seat_face", nominal="seat_d", fit="location")
mate("input_shaft.seat", "base.shaft_in", "revolute", nominal="journal_d", fit="clearance",
     depth=journal_l, effort=5, velocity=20)
mate("countershaft.seat", "base.shaft_mid", "revolute", nominal="journal_d", fit="clearance",
     depth=journal_l)
mate("output_shaft.seat", "base.shaft_out", "revolute", nominal="journal_d", fit="clearance",
     depth=journal_l)
mate("bolt_1.foot", "cover.bolt_1", "peg_socket", nominal="bolt_d", fit="clearance", depth=cover_t - 2)
mate("bolt_2.foot", "cover.bolt_2", "peg_socket", nominal="bolt_d", fit="clearance", depth=cover_t - 2)
mate("bolt_3.foot", "cover.bolt_3", "peg_socket", nominal="bolt_d", fit="clearance", depth=cover_t - 2)
mate("bolt_4.foot", "cover.bolt_4", "peg_socket", nominal="bolt_d", fit="clearance", depth=cover_t - 2)
mate("breather.foot", "cover.breather", "peg_socket", nominal="plug_d", fit="location", depth=cover_t / 2)
mate("drain_plug.foot", "base.drain", "peg_socket", nominal="plug_d", fit="location", depth=wall_t / 2)
couple("countershaft_seat", "input_shaft_seat", "gear", driver_teeth="z1", driven_teeth="z2")
couple("output_shaft_seat", "countershaft_seat", "gear", driver_teeth="z3", driven_teeth="z4")
