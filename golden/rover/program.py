"""Six-wheeled planetary rover with a rocker-bogie suspension, camera mast and solar wings.

Hand-written golden program (procedura-brep format). The rover drives along +X, Y is lateral
(left = +Y, right = -Y) and Z is up; the chassis is the root and its floor is at z = 0. Every
part is modelled in the rover's axes with its local origin on its mounting frame, so a child's
frame carries the same rotation as its parent's. All six wheel axles sit at ``axle_z``, so the
wheels rest on one flat ground plane at ``axle_z - wheel_d / 2``.
"""
from procedura_brep.program import *

# === params ===
body_l = 520.0        # mm, chassis (warm electronics box) length along X
body_w = 300.0        # mm, chassis width along Y
body_h = 160.0        # mm, chassis height
body_r = 24.0         # mm, fillet radius of the chassis' vertical edges
deck_pocket = 3.0     # mm, depth of the service-lid pocket in the top deck
body_wall = 2.5       # mm, chassis shell wall: it weighs as an aluminium box, not a solid block
pivot_z = 80.0        # mm, height of the rocker pivots above the chassis floor
pivot_boss_d = 44.0   # mm, diameter of the chassis' rocker-pivot bosses
pivot_boss_l = 15.0   # mm, how far each pivot boss stands out of the chassis side
pivot_d = 16.0        # mm, rocker pivot pin: nominal of the rocker revolutes
rocker_t = 12.0       # mm, rocker plate thickness (Y)
rocker_w = 30.0       # mm, rocker bar width
rocker_hub_d = 52.0   # mm, rocker hub diameter at the pivot
bogie_t = 12.0        # mm, bogie plate thickness (Y)
bogie_w = 26.0        # mm, bogie bar width
bogie_hub_d = 40.0    # mm, bogie hub diameter at its pivot
bogie_z = 20.0        # mm, height of the bogie pivots
bogie_pin_d = 12.0    # mm, bogie pivot pin: nominal of the bogie revolutes
axle_z = -40.0        # mm, height of all six wheel axles
wheel_x_f = 230.0     # mm, X of the front wheels (on the rockers)
wheel_x_m = -20.0     # mm, X of the middle wheels (on the bogies)
wheel_x_r = -250.0    # mm, X of the rear wheels (on the bogies)
hub_boss_d = 36.0     # mm, diameter of the axle bosses the wheels turn on
hub_boss_l = 10.0     # mm, axle boss length out of the bogie
wheel_d = 120.0       # mm, wheel diameter over the grousers
wheel_w = 60.0        # mm, wheel width
grouser_h = 4.0       # mm, grouser (tread bar) height
grouser_w = 6.0       # mm, grouser thickness
grouser_n = 16        # count, grousers per wheel (a multiple of 4 keeps one on the ground)
rim_t = 8.0           # mm, tyre rim thickness
web_t = 10.0          # mm, wheel web (disc) thickness on the inner side
hub_d = 40.0          # mm, wheel hub diameter
axle_d = 10.0         # mm, wheel axle: nominal of the six wheel revolutes
cap_d = 30.0          # mm, hub cap diameter
cap_t = 6.0           # mm, hub cap thickness
cap_pin_d = 8.0       # mm, hub cap pin: nominal of the hub caps' press fits
mast_x = 170.0        # mm, X of the camera mast on the deck
mast_flange_d = 40.0  # mm, mast base spigot: nominal of its flange mate
mast_base_d = 90.0    # mm, mast base disc diameter
mast_base_t = 12.0    # mm, mast base disc thickness
mast_d = 36.0         # mm, mast tube diameter: nominal of its lip_rabbet mate
mast_wall = 4.0       # mm, mast tube wall
mast_h = 320.0        # mm, mast height
pan_pin_d = 10.0      # mm, pan bearing pin: nominal of the pan revolute
head_l = 60.0         # mm, camera head depth (X)
head_w = 70.0         # mm, camera head width (Y)
head_h = 40.0         # mm, camera head height (Z)
cheek_t = 10.0        # mm, pan yoke cheek thickness
tilt_z = 50.0         # mm, tilt axis height above the pan head's foot
tilt_pin_d = 8.0      # mm, tilt pin: nominal of the tilt revolute
lens_d = 16.0         # mm, lens seat pad: nominal of the lens seat_face mates
lens_od = 22.0        # mm, lens barrel diameter
lens_len = 14.0       # mm, lens barrel length
lens_sep = 36.0       # mm, stereo baseline between the lenses
wing_x = -40.0        # mm, X of the solar wing brackets
bracket_l = 160.0     # mm, wing bracket length (X)
bracket_d = 40.0      # mm, wing bracket depth (Y)
bracket_h = 24.0      # mm, wing bracket height
bracket_bolt = 5.0    # mm, bracket bolt M-size (ISO 273): nominal of the bracket bolt patterns
bracket_pcd = 120.0   # mm, bracket bolt spacing
wing_l = 300.0        # mm, solar wing length (X)
wing_span = 200.0     # mm, solar wing span out of the chassis side
wing_t = 6.0          # mm, solar panel thickness
wing_tab_w = 60.0     # mm, wing root tab width: nominal of the wing tab_slot mates
ant_x = -170.0        # mm, X of the antenna post
ant_y = -70.0         # mm, Y of the antenna post
ant_post_d = 12.0     # mm, antenna post peg: nominal of its peg_socket mate
ant_h = 110.0         # mm, antenna post height
ant_key_w = 6.0       # mm, dish key width: nominal of the dish key mate
dish_d = 120.0        # mm, high-gain antenna dish diameter

# === helpers ===
def bottom():
    """Alignment that puts a solid's base on z = 0."""
    return (Align.CENTER, Align.CENTER, Align.MIN)


def out(s):
    """Frame rotation whose +Z points out of the rover's side: +Y for s = 1, -Y for s = -1."""
    return (-90 * s, 0, 0)


def shift(shape, o):
    """Move a shape modelled in rover axes so that the point ``o`` becomes its local origin."""
    return Pos(-o[0], -o[1], -o[2]) * shape


def frame(o, x, y, z, rot=(0, 0, 0)):
    """A frame at rover point (x, y, z), in the local coordinates of a part whose origin is ``o``."""
    return Location((x - o[0], y - o[1], z - o[2]), rot)


def y_rocker(s):
    """Y of the rocker's inner face on side s."""
    return s * (body_w / 2 + pivot_boss_l)


def y_bogie(s):
    """Y of the bogie's inner face (the rocker's outer face) on side s."""
    return y_rocker(s) + s * rocker_t


def y_wheel(s):
    """Y of the wheels' inner faces (the axle bosses' ends) on side s."""
    return y_bogie(s) + s * (bogie_t + hub_boss_l)


def bogie_x():
    return (wheel_x_m + wheel_x_r) / 2


def rocker_o(s):
    return (0.0, y_rocker(s), pivot_z)


def bogie_o(s):
    return (bogie_x(), y_bogie(s), bogie_z)


def slot(x1, z1, x2, z2, width):
    """2D round-ended slot from (x1, z1) to (x2, z2) in sketch coordinates (x, z)."""
    ang = math.degrees(math.atan2(z2 - z1, x2 - x1))
    return (Pos((x1 + x2) / 2, (z1 + z2) / 2) * Rot(0, 0, ang)
            * SlotCenterToCenter(math.hypot(x2 - x1, z2 - z1), width))


def plate(bars, hubs, y0, t):
    """Flat link plate in the XZ plane, spanning Y from y0 to y0 + t (t < 0 on the right side).

    ``bars`` are (x1, z1, x2, z2, width) round-ended bars, each with a lightening slot;
    ``hubs`` are (x, z, diameter) round hubs. One 2D profile, one extrusion: cheap to build.
    """
    prof = Sketch() + [slot(*b) for b in bars] + [Pos(x, z) * Circle(d / 2) for x, z, d in hubs]
    prof -= [slot(x1 + 0.3 * (x2 - x1), z1 + 0.3 * (z2 - z1), x1 + 0.75 * (x2 - x1),
                  z1 + 0.75 * (z2 - z1), 0.4 * w) for x1, z1, x2, z2, w in bars]
    return Pos(0, max(y0, y0 + t), 0) * Rot(90, 0, 0) * extrude(prof, abs(t))


def boss(x, z, y0, y1, dia):
    """Axle boss along Y between y0 and y1 at (x, z), chamfered at its free end (y1)."""
    c = Cylinder(dia / 2, abs(y1 - y0), align=bottom())
    c = chamfer(c.edges().group_by(Axis.Z)[-1], length=1.5)
    s = 1 if y1 > y0 else -1
    return Pos(x, y0, z) * Rot(-90 * s, 0, 0) * c


def rocker(s):
    """Rocker on side s: a hub on the chassis pivot, a bar to the front axle, a bar to the bogie."""
    bars = [(0, pivot_z, wheel_x_f, axle_z, rocker_w), (0, pivot_z, bogie_x(), bogie_z, rocker_w)]
    body = plate(bars, [(0, pivot_z, rocker_hub_d)], y_rocker(s), s * rocker_t)
    axle = boss(wheel_x_f, axle_z, y_bogie(s), y_wheel(s), hub_boss_d)
    return shift(body + axle, rocker_o(s))


def rocker_frames(s):
    o = rocker_o(s)
    return {"pivot": frame(o, 0, y_rocker(s), pivot_z, out(s)),
            "bogie": frame(o, bogie_x(), y_bogie(s), bogie_z, out(s)),
            "wheel": frame(o, wheel_x_f, y_wheel(s), axle_z, out(s))}


def bogie(s):
    """Bogie on side s: a hub on the rocker's rear pin and two bars down to the wheel axles."""
    bars = [(bogie_x(), bogie_z, x, axle_z, bogie_w) for x in (wheel_x_m, wheel_x_r)]
    body = plate(bars, [(bogie_x(), bogie_z, bogie_hub_d)], y_bogie(s), s * bogie_t)
    bosses = [boss(x, axle_z, y_bogie(s) + s * bogie_t, y_wheel(s), hub_boss_d) for x in (wheel_x_m, wheel_x_r)]
    return shift(body + bosses, bogie_o(s))


def bogie_frames(s):
    o = bogie_o(s)
    return {"pivot": frame(o, bogie_x(), y_bogie(s), bogie_z, out(s)),
            "wheel_m": frame(o, wheel_x_m, y_wheel(s), axle_z, out(s)),
            "wheel_r": frame(o, wheel_x_r, y_wheel(s), axle_z, out(s))}


def wheel(s):
    """Grousered wheel, inner face on the local origin, axis along +Y (s = 1) or -Y (s = -1)."""
    r = wheel_d / 2 - grouser_h
    tyre = Cylinder(r, wheel_w, align=bottom())
    tyre = fillet(tyre.edges().filter_by(GeomType.CIRCLE), radius=3)
    tyre -= Pos(0, 0, web_t) * Cylinder(r - rim_t, wheel_w - web_t, align=bottom())
    hub = Cylinder(hub_d / 2, wheel_w, align=bottom())
    hub = chamfer(hub.edges().group_by(Axis.Z)[-1], length=1.5)
    treads = [Rot(0, 0, i * 360 / grouser_n) * Pos(r + grouser_h / 2 - 0.5, 0, wheel_w / 2)
              * Box(grouser_h + 1, grouser_w, wheel_w - 10) for i in range(grouser_n)]
    holes = [Rot(0, 0, 30 + 60 * i) * Pos((hub_d / 2 + r - rim_t) / 2, 0, 0)
             * Cylinder(0.22 * (r - rim_t - hub_d / 2), 3 * web_t) for i in range(6)]
    w = (tyre + hub + treads) - holes
    return Rot(-90 * s, 0, 0) * w


def wheel_frames(s):
    return {"hub": Location((0, 0, 0), out(s)), "cap": Location((0, s * wheel_w, 0), out(s))}


def hubcap(s):
    """Domed hub cap on the wheel's outer face, with a centre nut."""
    c = Cylinder(cap_d / 2, cap_t, align=bottom())
    c = chamfer(c.edges().group_by(Axis.Z)[-1], length=1.5)
    nut = Pos(0, 0, cap_t) * Cylinder(6, 3, align=bottom())
    return Rot(-90 * s, 0, 0) * (c + nut)


def wing_bracket(s):
    """Aluminium bracket on the deck edge, two socket-head bolts on top, slot for the wing tab."""
    b = Box(bracket_l, bracket_d, bracket_h, align=bottom())
    b = fillet(b.edges().filter_by(Axis.Z), radius=6)
    heads = [Pos(x, 0, bracket_h) * Cylinder(0.85 * bracket_bolt, bracket_bolt, align=bottom())
             for x in (-bracket_pcd / 2, bracket_pcd / 2)]
    return b + heads


def solar_wing(s):
    """Solar wing: a root spar (with the tab) and a thin panel with rounded outer corners."""
    spar = Pos(0, s * 10, 0) * Box(wing_l, 20, 16)
    panel = Pos(0, s * wing_span / 2, 8 - wing_t / 2) * Box(wing_l, wing_span, wing_t)
    panel = fillet(panel.edges().filter_by(Axis.Z), radius=12)
    return spar + panel


def lens():
    """Lens barrel along +X from the local origin, chamfered front and a glass recess."""
    b = Cylinder(lens_od / 2, lens_len, align=bottom())
    b = chamfer(b.edges().group_by(Axis.Z)[-1], length=1.5)
    b -= Pos(0, 0, lens_len - 2) * Cylinder(lens_od / 2 - 4, 3, align=bottom())
    return Rot(0, 90, 0) * b


# === parts ===
@part(detail="silhouette", material="painted_aluminium", hollow=body_wall,
      description="520 x 300 x 160 mm chassis box, rounded corners, rocker pivot bosses on both sides")
def chassis():
    body = Box(body_l, body_w, body_h, align=bottom())
    body = fillet(body.edges().filter_by(Axis.Z), radius=body_r)
    body = chamfer(body.edges().group_by(Axis.Z)[-1], length=4)
    bosses = [Pos(0, s * (body_w / 2 + (pivot_boss_l - 1) / 2), pivot_z) * Rot(90, 0, 0)
              * Cylinder(pivot_boss_d / 2, pivot_boss_l + 1) for s in (1, -1)]
    pocket = Pos(-10, 0, body_h - deck_pocket) * Box(200, 160, deck_pocket + 1, align=bottom())
    return body + bosses - pocket


@part(detail="major", material="anodized_aluminium", description="left rocker: pivot hub, bar to the front wheel, bar to the bogie")
def rocker_l():
    return rocker(1)


@part(detail="major", material="anodized_aluminium", description="right rocker, mirror of rocker_l")
def rocker_r():
    return rocker(-1)


@part(detail="major", material="anodized_aluminium", description="left bogie: V of two bars carrying the middle and rear wheels")
def bogie_l():
    return bogie(1)


@part(detail="major", material="anodized_aluminium", description="right bogie, mirror of bogie_l")
def bogie_r():
    return bogie(-1)


@part(detail="major", material="rubber", description="front left wheel, 120 mm, 16 grousers")
def wheel_fl():
    return wheel(1)


@part(detail="major", material="rubber", description="middle left wheel")
def wheel_ml():
    return wheel(1)


@part(detail="major", material="rubber", description="rear left wheel")
def wheel_rl():
    return wheel(1)


@part(detail="major", material="rubber", description="front right wheel")
def wheel_fr():
    return wheel(-1)


@part(detail="major", material="rubber", description="middle right wheel")
def wheel_mr():
    return wheel(-1)


@part(detail="major", material="rubber", description="rear right wheel")
def wheel_rr():
    return wheel(-1)


@part(detail="sub", material="brushed_steel", description="front left hub cap")
def hubcap_fl():
    return hubcap(1)


@part(detail="sub", material="brushed_steel", description="middle left hub cap")
def hubcap_ml():
    return hubcap(1)


@part(detail="sub", material="brushed_steel", description="rear left hub cap")
def hubcap_rl():
    return hubcap(1)


@part(detail="sub", material="brushed_steel", description="front right hub cap")
def hubcap_fr():
    return hubcap(-1)


@part(detail="sub", material="brushed_steel", description="middle right hub cap")
def hubcap_mr():
    return hubcap(-1)


@part(detail="sub", material="brushed_steel", description="rear right hub cap")
def hubcap_rr():
    return hubcap(-1)


@part(detail="major", material="aluminium", description="round mast base flanged to the front of the deck, six bolt heads")
def mast_base():
    d = Cylinder(mast_base_d / 2, mast_base_t, align=bottom())
    d = chamfer(d.edges().group_by(Axis.Z)[-1], length=2)
    heads = [Rot(0, 0, 60 * i) * Pos(0.75 * mast_flange_d, 0, mast_base_t) * Cylinder(3.5, 4, align=bottom())
             for i in range(6)]
    return d + heads


@part(detail="major", material="painted_aluminium", description="320 mm camera mast tube with a cable clamp collar")
def mast():
    tube = Cylinder(mast_d / 2, mast_h, align=bottom()) - Cylinder(mast_d / 2 - mast_wall, mast_h - 20, align=bottom())
    tube = chamfer(tube.edges().group_by(Axis.Z)[-1], length=1.5)
    collar = Pos(0, 0, 0.6 * mast_h) * Cylinder(mast_d / 2 + 3, 10)
    return tube + collar


@part(detail="major", material="anodized_aluminium", description="pan head: base plate and a yoke of two cheeks")
def pan_head():
    gap = head_w + 2
    plate = Box(50, gap + 2 * cheek_t, 10, align=bottom())
    plate = fillet(plate.edges().filter_by(Axis.Z), radius=6)
    cheeks = []
    for s in (1, -1):
        yc = s * (gap / 2 + cheek_t / 2)
        cheeks.append(Pos(0, yc, 10) * Box(36, cheek_t, tilt_z - 10, align=bottom()))
        cheeks.append(Pos(0, yc, tilt_z) * Rot(90, 0, 0) * Cylinder(18, cheek_t))
    return plate + cheeks


@part(detail="major", material="abs_plastic", description="stereo camera head tilting in the pan yoke")
def camera_head():
    h = Pos(0, -head_w / 2, 0) * Box(head_l, head_w, head_h)
    return fillet(h.edges(), radius=4)


@part(detail="sub", material="glass", description="left camera lens barrel")
def lens_l():
    return lens()


@part(detail="sub", material="glass", description="right camera lens barrel")
def lens_r():
    return lens()


@part(detail="major", material="aluminium", description="left solar wing bracket on the deck edge")
def wing_bracket_l():
    return wing_bracket(1)


@part(detail="major", material="aluminium", description="right solar wing bracket")
def wing_bracket_r():
    return wing_bracket(-1)


@part(detail="silhouette", material="solar_cell", description="left solar wing, 300 x 200 mm")
def solar_wing_l():
    return solar_wing(1)


@part(detail="silhouette", material="solar_cell", description="right solar wing")
def solar_wing_r():
    return solar_wing(-1)


@part(detail="major", material="brushed_steel", description="antenna post at the rear of the deck")
def antenna_post():
    foot = Cylinder(18, 6, align=bottom())
    foot = chamfer(foot.edges().group_by(Axis.Z)[-1], length=1.5)
    tube = Cylinder(8, ant_h, align=bottom())
    top = Pos(0, 0, ant_h) * Box(28, 28, 8, align=bottom())
    top = fillet(top.edges().filter_by(Axis.Z), radius=4)
    return foot + tube + top


@part(detail="major", material="painted_aluminium", description="high-gain antenna dish on the post, keyed")
def antenna_dish():
    hub = Cylinder(13, 12, align=bottom())
    slope = (dish_d / 2 - 16) / 30
    bowl = Pos(0, 0, 10) * (Cone(16, dish_d / 2, 30, align=bottom())
                            - Pos(0, 0, 4) * Cone(14, 14 + 30 * slope, 30, align=bottom()))
    strut = Pos(0, 0, 12) * Cylinder(2, 45, align=bottom())
    horn = Pos(0, 0, 52) * Cylinder(6, 10, align=bottom())
    return hub + bowl + strut + horn


# === frames ===
frames("chassis",
       rocker_l=Location((0, y_rocker(1), pivot_z), out(1)),
       rocker_r=Location((0, y_rocker(-1), pivot_z), out(-1)),
       mast=Location((mast_x, 0, body_h)),
       bracket_l=Location((wing_x, body_w / 2 - bracket_d / 2, body_h)),
       bracket_r=Location((wing_x, -(body_w / 2 - bracket_d / 2), body_h)),
       antenna=Location((ant_x, ant_y, body_h)))
frames("rocker_l", **rocker_frames(1))
frames("rocker_r", **rocker_frames(-1))
frames("bogie_l", **bogie_frames(1))
frames("bogie_r", **bogie_frames(-1))
for w in ("fl", "ml", "rl"):
    frames("wheel_" + w, **wheel_frames(1))
    frames("hubcap_" + w, seat=Location((0, 0, 0), out(1)))
for w in ("fr", "mr", "rr"):
    frames("wheel_" + w, **wheel_frames(-1))
    frames("hubcap_" + w, seat=Location((0, 0, 0), out(-1)))
frames("mast_base", foot=Location((0, 0, 0)), top=Location((0, 0, mast_base_t)))
frames("mast", foot=Location((0, 0, 0)), top=Location((0, 0, mast_h)))
frames("pan_head", foot=Location((0, 0, 0)), tilt=Location((0, (head_w + 2) / 2, tilt_z), (90, 0, 0)))
frames("camera_head", tilt=Location((0, 0, 0), (90, 0, 0)),
       lens_l=Location((head_l / 2, -head_w / 2 + lens_sep / 2, 0), (0, 90, 0)),
       lens_r=Location((head_l / 2, -head_w / 2 - lens_sep / 2, 0), (0, 90, 0)))
frames("lens_l", seat=Location((0, 0, 0), (0, 90, 0)))
frames("lens_r", seat=Location((0, 0, 0), (0, 90, 0)))
for s, side in ((1, "l"), (-1, "r")):
    frames("wing_bracket_" + side, foot=Location((0, 0, 0)),
           wing=Location((0, s * bracket_d / 2, bracket_h / 2), out(s)))
    frames("solar_wing_" + side, root=Location((0, 0, 0), out(s)))
frames("antenna_post", foot=Location((0, 0, 0)), top=Location((0, 0, ant_h + 8)))
frames("antenna_dish", foot=Location((0, 0, 0)))

# === assembly ===
mate("rocker_l.pivot", "chassis.rocker_l", "revolute", nominal="pivot_d", fit="clearance", limits=(-20, 20))
mate("rocker_r.pivot", "chassis.rocker_r", "revolute", nominal="pivot_d", fit="clearance", limits=(-20, 20))
mate("bogie_l.pivot", "rocker_l.bogie", "revolute", nominal="bogie_pin_d", fit="clearance",
     limits=(-30, 30), depth=rocker_t - 2)
mate("bogie_r.pivot", "rocker_r.bogie", "revolute", nominal="bogie_pin_d", fit="clearance",
     limits=(-30, 30), depth=rocker_t - 2)
mate("wheel_fl.hub", "rocker_l.wheel", "revolute", nominal="axle_d", fit="clearance", limits=None)
mate("wheel_ml.hub", "bogie_l.wheel_m", "revolute", nominal="axle_d", fit="clearance", limits=None)
mate("wheel_rl.hub", "bogie_l.wheel_r", "revolute", nominal="axle_d", fit="clearance", limits=None)
mate("wheel_fr.hub", "rocker_r.wheel", "revolute", nominal="axle_d", fit="clearance", limits=None)
mate("wheel_mr.hub", "bogie_r.wheel_m", "revolute", nominal="axle_d", fit="clearance", limits=None)
mate("wheel_rr.hub", "bogie_r.wheel_r", "revolute", nominal="axle_d", fit="clearance", limits=None)
for w in ("fl", "ml", "rl", "fr", "mr", "rr"):
    mate("hubcap_" + w + ".seat", "wheel_" + w + ".cap", "press_fit", nominal="cap_pin_d", fit="press")
mate("mast_base.foot", "chassis.mast", "flange", nominal="mast_flange_d", fit="location")
mate("mast.foot", "mast_base.top", "lip_rabbet", nominal="mast_d", fit="location")
mate("pan_head.foot", "mast.top", "revolute", nominal="pan_pin_d", fit="clearance", limits=(-170, 170))
mate("camera_head.tilt", "pan_head.tilt", "revolute", nominal="tilt_pin_d", fit="clearance",
     limits=(-45, 60), depth=cheek_t - 4)
mate("lens_l.seat", "camera_head.lens_l", "seat_face", nominal="lens_d", fit="location")
mate("lens_r.seat", "camera_head.lens_r", "seat_face", nominal="lens_d", fit="location")
mate("wing_bracket_l.foot", "chassis.bracket_l", "bolt_pattern", nominal="bracket_bolt", fit="clearance",
     count=2, pcd=bracket_pcd)
mate("wing_bracket_r.foot", "chassis.bracket_r", "bolt_pattern", nominal="bracket_bolt", fit="clearance",
     count=2, pcd=bracket_pcd)
mate("solar_wing_l.root", "wing_bracket_l.wing", "tab_slot", nominal="wing_tab_w", fit="location",
     thickness=8, depth=20)
mate("solar_wing_r.root", "wing_bracket_r.wing", "tab_slot", nominal="wing_tab_w", fit="location",
     thickness=8, depth=20)
mate("antenna_post.foot", "chassis.antenna", "peg_socket", nominal="ant_post_d", fit="location")
mate("antenna_dish.foot", "antenna_post.top", "key", nominal="ant_key_w", fit="location")
