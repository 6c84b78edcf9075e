"""Bench vise on a ball-mounted swivel base.

Hand-written golden program (procedura-brep format). Z is up; the jaws close along +X. The vise
body swivels on a ball (spherical mate, cone limit) in a cup on the bench mount; the moving jaw
slides on the body's bed (prismatic mate, guide bar in the fixed jaw) and carries the lead screw
and its tommy-bar handle. Each part is modelled in world axes with its local origin on its
mounting frame, so children carry their parent frame's rotation.
"""
from procedura_brep.program import *

# === params ===
mount_d = 120.0       # mm, bench mount plate diameter
mount_t = 20.0        # mm, bench mount plate thickness
cup_d = 70.0          # mm, ball cup diameter
cup_h = 30.0          # mm, ball cup height above the mount plate
ball_d = 50.0         # mm, swivel ball: nominal of the spherical mate
cone = 25.0           # deg, swivel cone half-angle
knob_peg_d = 8.0      # mm, lock knob peg: nominal of its peg_socket mate
neck_d = 40.0         # mm, body neck diameter (narrower than the ball, so it swivels inside the socket)
neck_h = 25.0         # mm, body neck height
bed_l = 220.0         # mm, body bed length (X)
bed_w = 80.0          # mm, body bed width (Y)
bed_h = 40.0          # mm, body bed height
bed_front = 90.0      # mm, X of the bed's front end (the fixed jaw's outer face)
jaw_t = 30.0          # mm, fixed jaw thickness (X)
jaw_h = 60.0          # mm, jaw height above the bed
guide_w = 10.0        # mm, slide guide bar: nominal of the moving jaw's prismatic mate
opening = 100.0       # mm, maximum jaw opening
plate_t = 6.0         # mm, jaw plate thickness
plate_h = 30.0        # mm, jaw plate height
plate_bolt = 5.0      # mm, jaw plate screw M-size (ISO 273): nominal of the plate bolt patterns
plate_pcd = 60.0      # mm, jaw plate screw spacing
mjaw_l = 40.0         # mm, moving jaw length (X)
nose_h = 20.0         # mm, moving jaw nose height (rides under the jaw plates)
screw_collar_d = 24.0 # mm, lead screw collar pad: nominal of its seat_face mate
screw_d = 18.0        # mm, lead screw diameter
screw_l = 90.0        # mm, lead screw length behind the moving jaw
handle_pin_d = 8.0    # mm, handle hub pin: nominal of its press_fit mate
handle_l = 140.0      # mm, tommy bar length
handle_d = 10.0       # mm, tommy bar diameter

# === helpers ===
def bottom():
    """Alignment that puts a solid's base on z = 0."""
    return (Align.CENTER, Align.CENTER, Align.MIN)


def back():
    """Frame rotation with +Z along -X (towards the moving jaw and the handle)."""
    return (0, -90, 0)


def front():
    """Frame rotation with +Z along +X (towards the fixed jaw)."""
    return (0, 90, 0)


def bed_top():
    return neck_h + bed_h


def jaw_plate():
    """Jaw plate behind the local origin along -X, serrated face, counterbored screw holes."""
    p = Pos(-plate_t / 2, 0, 0) * Box(plate_t, bed_w, plate_h)
    p = chamfer(p.edges().filter_by(Axis.Y), length=1)
    grooves = [Pos(-plate_t, 0, z) * Box(2.0, bed_w + 2, 1.2) for z in (-9, -3, 3, 9)]
    bores = [Pos(-plate_t, y, 0) * Rot(0, 90, 0) * Cylinder(0.85 * plate_bolt, 2 * 2.5) for y in (-plate_pcd / 2, plate_pcd / 2)]
    return p - grooves - bores


# === parts ===
@part(detail="silhouette", material="cast_iron", description="bench mount: 120 mm plate with a ball cup")
def mount_base():
    plate = Cylinder(mount_d / 2, mount_t, align=bottom())
    plate = chamfer(plate.edges().group_by(Axis.Z)[-1], length=2)
    cup = Pos(0, 0, mount_t) * Cylinder(cup_d / 2, cup_h, align=bottom())
    cup = chamfer(cup.edges().group_by(Axis.Z)[-1], length=2)
    holes = [Rot(0, 0, 90 + 120 * i) * Pos(mount_d / 2 - 10, 0, 0) * Cylinder(4.5, 3 * mount_t) for i in range(3)]
    return plate + cup - holes


@part(detail="sub", material="black_oxide_steel", description="swivel lock knob on the mount plate")
def lock_knob():
    k = Cylinder(11, 18, align=bottom())
    k = chamfer(k.edges().group_by(Axis.Z)[-1], length=2)
    return k - [Rot(0, 0, 30 * i) * Pos(11, 0, 9) * Cylinder(1.5, 14) for i in range(12)]


@part(detail="silhouette", material="painted_steel", description="vise body: neck on the ball, slide bed and fixed jaw")
def body():
    neck = Cylinder(neck_d / 2, neck_h + 1, align=bottom())
    bed = Pos(bed_front - bed_l / 2, 0, neck_h) * Box(bed_l, bed_w, bed_h, align=bottom())
    bed = fillet(bed.edges().filter_by(Axis.X), radius=5)
    jaw = Pos(bed_front - jaw_t / 2, 0, bed_top()) * Box(jaw_t, bed_w, jaw_h, align=bottom())
    jaw = chamfer(jaw.edges().group_by(Axis.Z)[-1], length=3)
    return neck + bed + jaw


@part(detail="sub", material="stainless_steel", description="fixed jaw plate, serrated")
def fixed_plate():
    return jaw_plate()


@part(detail="major", material="painted_steel", description="moving jaw sliding on the bed, with a nose under the plates")
def moving_jaw():
    nose = Pos(-plate_t, 0, 0) * Box(2 * plate_t, bed_w, nose_h)
    block = Pos(-2 * plate_t - mjaw_l / 2, 0, -nose_h / 2) * Box(mjaw_l, bed_w, jaw_h, align=bottom())
    block = chamfer(block.edges().group_by(Axis.Z)[-1], length=3)
    return nose + block


@part(detail="sub", material="stainless_steel", description="moving jaw plate, serrated")
def moving_plate():
    return Rot(0, 0, 180) * jaw_plate()


@part(detail="major", material="brushed_steel", description="lead screw with a thrust collar")
def screw():
    collar = Cylinder(15, 8, align=bottom())
    collar = chamfer(collar.edges().group_by(Axis.Z)[-1], length=1)
    rod = Cylinder(screw_d / 2, screw_l, align=bottom())
    rod = chamfer(rod.edges().group_by(Axis.Z)[-1], length=1.5)
    rings = [Pos(0, 0, z) * (Cylinder(screw_d / 2 + 1, 3, align=bottom()) - Cylinder(screw_d / 2 - 1, 3, align=bottom()))
             for z in (20, 40, 60)]
    return Rot(0, -90, 0) * (collar + rod - rings)


@part(detail="sub", material="brushed_steel", description="tommy-bar handle through a hub on the screw end")
def handle():
    hub = Cylinder(11, 16, align=bottom())
    bar = Pos(0, 0, 8) * Rot(90, 0, 0) * Cylinder(handle_d / 2, handle_l)
    knobs = [Pos(0, y, 8) * Sphere(handle_d * 0.9) for y in (-handle_l / 2, handle_l / 2)]
    return Rot(0, -90, 0) * (hub + bar + knobs)


# === frames ===
frames("mount_base", ball=Location((0, 0, mount_t + cup_h)), knob=Location((48, 0, mount_t)))
frames("lock_knob", foot=Location((0, 0, 0)))
frames("body", ball=Location((0, 0, 0)),
       slide=Location((bed_front - jaw_t, 0, bed_top() + nose_h / 2), back()),
       fixed_plate=Location((bed_front - jaw_t, 0, bed_top() + nose_h + 2 + plate_h / 2), back()))
frames("fixed_plate", back=Location((0, 0, 0), back()))
frames("moving_jaw", nose=Location((0, 0, 0), back()),
       plate=Location((-2 * plate_t, 0, nose_h / 2 + 2 + plate_h / 2), front()),
       screw=Location((-2 * plate_t - mjaw_l, 0, jaw_h / 2 - nose_h / 2 - 5), back()))
frames("moving_plate", back=Location((0, 0, 0), front()))
frames("screw", collar=Location((0, 0, 0), back()), end=Location((-screw_l, 0, 0), back()))
frames("handle", hub=Location((0, 0, 0), back()))

# === assembly ===
mate("body.ball", "mount_base.ball", "spherical", nominal="ball_d", fit="clearance", cone=cone)
mate("lock_knob.foot", "mount_base.knob", "peg_socket", nominal="knob_peg_d", fit="location")
mate("fixed_plate.back", "body.fixed_plate", "bolt_pattern", nominal="plate_bolt", fit="clearance",
     count=2, pcd=plate_pcd, angle0=90)
mate("moving_jaw.nose", "body.slide", "prismatic", nominal="guide_w", fit="clearance",
     limits=(0, opening), depth=opening + 1.5 * guide_w, effort=2000, velocity=0.05)
mate("moving_plate.back", "moving_jaw.plate", "bolt_pattern", nominal="plate_bolt", fit="clearance",
     count=2, pcd=plate_pcd, angle0=90)
mate("screw.collar", "moving_jaw.screw", "seat_face", nominal="screw_collar_d", fit="location")
mate("handle.hub", "screw.end", "press_fit", nominal="handle_pin_d", fit="press")
