"""Six-axis-style industrial robot arm with a two-finger parallel gripper.

Hand-written golden program (procedura-brep format). Z is up, the arm reaches along +X at home
(all joints 0): base yaw, shoulder pitch, elbow pitch, wrist pitch (all about world axes at home)
and wrist roll about X, then a U-channel gripper whose two fingers slide towards each other.
Each part is modelled in world axes with its local origin on its mounting frame.
"""
from procedura_brep.program import *

# === params ===
base_d = 280.0         # mm, floor plate diameter
base_t = 20.0          # mm, floor plate thickness
column_d = 180.0       # mm, base column diameter
column_h = 140.0       # mm, base column height
column_flange_d = 120.0  # mm, column spigot: nominal of its flange mate
column_bolt_pcd = 140.0  # mm, column flange stud circle
turret_pin_d = 30.0    # mm, yaw bearing pin: nominal of the turret revolute
turret_d = 170.0       # mm, turret disc diameter
turret_t = 30.0        # mm, turret disc thickness
block_l = 110.0        # mm, shoulder block length (X)
block_w = 80.0         # mm, shoulder block width (Y)
shoulder_z = 110.0     # mm, shoulder axis height above the turret disc
shoulder_pin_d = 25.0  # mm, shoulder pin: nominal of the shoulder revolute
motor_bolt = 6.0       # mm, motor bolt M-size (ISO 273): nominal of the motor bolt patterns
upper_l = 400.0        # mm, shoulder-to-elbow length
upper_t = 50.0         # mm, upper arm thickness (Y)
upper_w = 90.0         # mm, upper arm width
elbow_pin_d = 20.0     # mm, elbow pin: nominal of the elbow revolute
forearm_l = 380.0      # mm, elbow-to-wrist length
forearm_t = 40.0       # mm, forearm thickness (Y)
forearm_w = 70.0       # mm, forearm width
wrist_pin_d = 14.0     # mm, wrist pitch pin: nominal of the wrist revolute
wrist_t = 36.0         # mm, wrist body thickness (Y)
wrist_l = 90.0         # mm, wrist body length (X)
roll_pin_d = 12.0      # mm, roll pin: nominal of the wrist roll revolute
flange_d = 63.0        # mm, tool flange diameter (ISO 9409-1-50 style)
flange_t = 16.0        # mm, tool flange thickness
grip_bolt = 5.0        # mm, gripper bolt M-size: nominal of the gripper bolt pattern
grip_pcd = 40.0        # mm, gripper bolt circle
palm_t = 15.0          # mm, gripper palm thickness (X)
grip_len = 60.0        # mm, gripper channel length (X)
grip_w = 110.0         # mm, gripper width across the fingers (Y)
grip_h = 56.0          # mm, gripper height (Z)
wall_t = 16.0          # mm, gripper side wall thickness
guide_w = 8.0          # mm, finger guide bar: nominal of the finger prismatic mates
finger_t = 18.0        # mm, finger carriage thickness (Y)
carriage_l = 36.0      # mm, finger carriage length (X), clear of the palm's bolt heads
finger_len = 70.0      # mm, finger tip length beyond the carriage
stroke = 18.0          # mm, finger stroke (each)
head_h = 4.0           # mm, gripper bolt head height above the palm
lamp_peg_d = 8.0       # mm, status lamp peg: nominal of its peg_socket mate

# === helpers ===
def bottom():
    """Alignment that puts a solid's base on z = 0."""
    return (Align.CENTER, Align.CENTER, Align.MIN)


def shift(shape, o):
    """Move a shape modelled in world axes so that the point ``o`` becomes its local origin."""
    return Pos(-o[0], -o[1], -o[2]) * shape


def frame(o, x, y, z, rot=(0, 0, 0)):
    """A frame at world point (x, y, z) in the local coordinates of a part whose origin is ``o``."""
    return Location((x - o[0], y - o[1], z - o[2]), rot)


def side(s):
    """Frame rotation with +Z along +Y (s = 1) or -Y (s = -1)."""
    return (-90 * s, 0, 0)


def ahead():
    """Frame rotation with +Z along +X."""
    return (0, 90, 0)


def link(x1, z1, x2, z2, width, d1, d2, y0, t):
    """Arm link plate in the XZ plane between two joint hubs, Y from y0 to y0 + t (t may be < 0)."""
    ang = math.degrees(math.atan2(z2 - z1, x2 - x1))
    length = math.hypot(x2 - x1, z2 - z1)
    prof = (Pos((x1 + x2) / 2, (z1 + z2) / 2) * Rot(0, 0, ang) * SlotCenterToCenter(length, width)
            + Pos(x1, z1) * Circle(d1 / 2) + Pos(x2, z2) * Circle(d2 / 2))
    prof -= Pos((x1 + x2) / 2, (z1 + z2) / 2) * Rot(0, 0, ang) * SlotCenterToCenter(0.45 * length, 0.35 * width)
    body = Pos(0, max(y0, y0 + t), 0) * Rot(90, 0, 0) * extrude(prof, abs(t))
    return body


def motor(s, dia, length):
    """Servo motor can along +Y (s = 1) or -Y (s = -1) from the origin: chamfered cap, cooling ribs."""
    can = Cylinder(dia / 2, length, align=bottom())
    can = chamfer(can.edges().group_by(Axis.Z)[-1], length=3)
    ribs = [Pos(0, 0, z) * Cylinder(dia / 2 + 3, 4, align=bottom()) for z in (0.3 * length, 0.55 * length)]
    return Rot(-90 * s, 0, 0) * (can + ribs)


def shoulder_o():
    return (0.0, block_w / 2, column_h + base_t + turret_t + shoulder_z)


def elbow_o():
    o = shoulder_o()
    return (0.0, o[1], o[2] + upper_l)


def wrist_o():
    o = elbow_o()
    return (forearm_l, o[1] - forearm_t, o[2])


def finger(s):
    """Finger on side s: carriage against the side wall and a jaw reaching past the channel."""
    carriage = Pos(0, -s * finger_t / 2, 0) * Box(carriage_l, finger_t, 40)
    carriage = fillet(carriage.edges().filter_by(Axis.Y), radius=3)
    tip = Pos(15 + finger_len / 2, -s * (finger_t - 5), 0) * Box(finger_len, 10, 30)
    pad = Pos(25 + finger_len / 2, -s * (finger_t + 1), 0) * Box(finger_len - 20, 2.5, 24)
    return carriage + tip + pad


# === parts ===
@part(detail="silhouette", material="cast_iron", description="280 mm round floor plate with anchor holes")
def base_plate():
    p = Cylinder(base_d / 2, base_t, align=bottom())
    p = chamfer(p.edges().group_by(Axis.Z)[-1], length=3)
    holes = [Rot(0, 0, 45 + 90 * i) * Pos(base_d / 2 - 18, 0, 0) * Cylinder(7, 3 * base_t) for i in range(4)]
    return p - holes


@part(detail="silhouette", material="painted_steel", description="180 mm base column with a bolted foot ring")
def base_column():
    c = Cylinder(column_d / 2, column_h, align=bottom())
    c = chamfer(c.edges().group_by(Axis.Z)[-1], length=4)
    ring = Cylinder(column_d / 2 + 15, 15, align=bottom())
    heads = [Rot(0, 0, 22.5 + 45 * i) * Pos(column_d / 2 + 8, 0, 15) * Cylinder(5, 6, align=bottom())
             for i in range(8)]
    return c + ring + heads


@part(detail="major", material="painted_steel", description="turret: yaw disc and the shoulder block with a round top")
def turret():
    disc = Cylinder(turret_d / 2, turret_t, align=bottom())
    disc = chamfer(disc.edges().group_by(Axis.Z)[-1], length=2)
    block = Pos(0, 0, turret_t) * Box(block_l, block_w, shoulder_z, align=bottom())
    block = fillet(block.edges().filter_by(Axis.Z), radius=10)
    top = Pos(0, 0, turret_t + shoulder_z) * Rot(90, 0, 0) * Cylinder(block_l / 2, block_w)
    return disc + block + top


@part(detail="sub", material="black_oxide_steel", description="shoulder servo on the turret's -Y face")
def shoulder_motor():
    return motor(-1, 90, 70)


@part(detail="major", material="painted_steel", description="400 mm upper arm link")
def upper_arm():
    o = shoulder_o()
    body = link(0, o[2], 0, o[2] + upper_l, upper_w, 110, 100, o[1], upper_t)
    return shift(body, o)


@part(detail="sub", material="black_oxide_steel", description="elbow servo on the upper arm's +Y face")
def elbow_motor():
    return motor(1, 80, 60)


@part(detail="major", material="painted_steel", description="380 mm forearm reaching forward")
def forearm():
    o = elbow_o()
    body = link(0, o[2], forearm_l, o[2], forearm_w, 90, 76, o[1], -forearm_t)
    return shift(body, o)


@part(detail="major", material="painted_steel", description="wrist pitch body carrying the roll axis")
def wrist():
    hub = Pos(0, -wrist_t / 2, 0) * Rot(90, 0, 0) * Cylinder(35, wrist_t)
    body = Pos(wrist_l / 2, -wrist_t / 2, 0) * Box(wrist_l, wrist_t, 60)
    body = fillet(body.edges().filter_by(Axis.X), radius=6)
    return hub + body


@part(detail="major", material="aluminium", description="tool flange turning about the roll axis")
def tool_flange():
    f = Cylinder(flange_d / 2, flange_t, align=bottom())
    f = chamfer(f.edges().group_by(Axis.Z)[-1], length=1.5)
    f -= Pos(0, 0, flange_t - 3) * Cylinder(6, 4, align=bottom())
    return Rot(0, 90, 0) * f


@part(detail="major", material="anodized_aluminium", description="U-channel gripper body: palm and two guide walls")
def gripper_body():
    palm = Pos(palm_t / 2, 0, 0) * Box(palm_t, grip_w, grip_h)
    walls = [Pos(grip_len / 2, s * (grip_w - wall_t) / 2, 0) * Box(grip_len, wall_t, grip_h) for s in (1, -1)]
    g = palm + walls
    heads = [Rot(45 + 90 * i, 0, 0) * Pos(palm_t, 0, grip_pcd / 2) * Rot(0, 90, 0)
             * Cylinder(0.85 * grip_bolt, head_h, align=bottom()) for i in range(4)]
    return g + heads


@part(detail="sub", material="stainless_steel", description="left finger (+Y), slides towards -Y")
def finger_l():
    return finger(1)


@part(detail="sub", material="stainless_steel", description="right finger (-Y), mirror of finger_l")
def finger_r():
    return finger(-1)


@part(detail="sub", material="orange_plastic", description="status lamp on the turret disc")
def status_lamp():
    return Cylinder(10, 24, align=bottom()) + Pos(0, 0, 24) * Sphere(10)


# === frames ===
frames("base_plate", column=Location((0, 0, base_t)))
frames("base_column", foot=Location((0, 0, 0)), top=Location((0, 0, column_h)))
frames("turret", yaw=Location((0, 0, 0)),
       shoulder=Location((0, block_w / 2, turret_t + shoulder_z), side(1)),
       motor=Location((0, -block_w / 2, turret_t + shoulder_z), side(-1)),
       lamp=Location((turret_d / 2 - 15, 0, turret_t)))
frames("shoulder_motor", face=Location((0, 0, 0), side(-1)))
frames("upper_arm", shoulder=frame(shoulder_o(), *shoulder_o(), side(1)),
       elbow=frame(shoulder_o(), *elbow_o(), side(-1)),
       motor=frame(shoulder_o(), 0, shoulder_o()[1] + upper_t, elbow_o()[2], side(1)))
frames("elbow_motor", face=Location((0, 0, 0), side(1)))
frames("forearm", elbow=Location((0, 0, 0), side(-1)),
       wrist=frame(elbow_o(), *wrist_o(), side(-1)))
frames("wrist", pitch=Location((0, 0, 0), side(-1)),
       roll=Location((wrist_l, -wrist_t / 2, 0), ahead()))
frames("tool_flange", roll=Location((0, 0, 0), ahead()), face=Location((flange_t, 0, 0), ahead()))
frames("gripper_body", mount=Location((0, 0, 0), ahead()),
       finger_l=Location(((grip_len + palm_t + head_h) / 2, grip_w / 2 - wall_t, 0), side(-1)),
       finger_r=Location(((grip_len + palm_t + head_h) / 2, -(grip_w / 2 - wall_t), 0), side(1)))
frames("finger_l", slide=Location((0, 0, 0), side(-1)))
frames("finger_r", slide=Location((0, 0, 0), side(1)))
frames("status_lamp", foot=Location((0, 0, 0)))

# === assembly ===
mate("base_column.foot", "base_plate.column", "flange", nominal="column_flange_d", fit="location",
     count=8, pcd=column_bolt_pcd)
mate("turret.yaw", "base_column.top", "revolute", nominal="turret_pin_d", fit="clearance",
     limits=(-170, 170), effort=400, velocity=2.0)
mate("shoulder_motor.face", "turret.motor", "bolt_pattern", nominal="motor_bolt", fit="clearance",
     count=4, pcd=60, angle0=45)
mate("upper_arm.shoulder", "turret.shoulder", "revolute", nominal="shoulder_pin_d", fit="clearance",
     limits=(-90, 90), effort=300, velocity=1.5)
mate("elbow_motor.face", "upper_arm.motor", "bolt_pattern", nominal="motor_bolt", fit="clearance",
     count=4, pcd=50, angle0=45)
mate("forearm.elbow", "upper_arm.elbow", "revolute", nominal="elbow_pin_d", fit="clearance",
     limits=(-65, 135), effort=150, velocity=2.0)
mate("wrist.pitch", "forearm.wrist", "revolute", nominal="wrist_pin_d", fit="clearance",
     limits=(-120, 120), effort=40, velocity=3.0)
mate("tool_flange.roll", "wrist.roll", "revolute", nominal="roll_pin_d", fit="clearance",
     limits=(-350, 350), effort=20, velocity=4.0)
mate("gripper_body.mount", "tool_flange.face", "bolt_pattern", nominal="grip_bolt", fit="clearance",
     count=4, pcd=grip_pcd, angle0=45)
mate("finger_l.slide", "gripper_body.finger_l", "prismatic", nominal="guide_w", fit="clearance",
     limits=(0, stroke), depth=stroke + 1.5 * guide_w, effort=80)
mate("finger_r.slide", "gripper_body.finger_r", "prismatic", nominal="guide_w", fit="clearance",
     limits=(0, stroke), depth=stroke + 1.5 * guide_w, effort=80)
mate("status_lamp.foot", "turret.lamp", "peg_socket", nominal="lamp_peg_d", fit="location")
