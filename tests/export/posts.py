"""A plate with five posts and a swinging arm, each part in its own material. Hand-written test
program (procedura-brep format) for the cross-process byte-reproducibility test: seven coloured
parts give the STEP colour section 7! possible orders."""
from procedura_brep.program import *

# === params ===
plate_w = 160.0  # mm, square plate side
plate_t = 10.0   # mm, plate thickness
post_d = 16.0    # mm, post diameter
post_h = 60.0    # mm, post height
spigot_d = 10.0  # mm, spigot under each post: the nominal of its peg_socket
pin_d = 6.0      # mm, hinge pin: the nominal of the arm's revolute mate

# === helpers ===
def post_body():
    return Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))

# === parts ===
@part(detail="silhouette", material="cast_iron", description="square plate")
def plate():
    return Box(plate_w, plate_w, plate_t, align=(Align.CENTER, Align.CENTER, Align.MIN))

@part(detail="major", material="brass", description="post 1")
def post_a():
    return post_body()

@part(detail="major", material="copper", description="post 2")
def post_b():
    return post_body()

@part(detail="major", material="titanium", description="post 3")
def post_c():
    return post_body()

@part(detail="major", material="orange_plastic", description="post 4")
def post_d_part():
    return post_body()

@part(detail="major", material="nylon", description="post 5")
def post_e():
    return post_body()

@part(detail="major", material="painted_steel", description="arm swinging on post 1")
def arm():
    return Box(50, 10, 8, align=(Align.MIN, Align.CENTER, Align.CENTER))

# === frames ===
frames("plate", s1=Location((-50, -50, plate_t)), s2=Location((50, -50, plate_t)),
       s3=Location((50, 50, plate_t)), s4=Location((-50, 50, plate_t)), s5=Location((0, 0, plate_t)))
frames("post_a", foot=Location((0, 0, 0)), head=Location((0, post_d / 2, post_h - 6), (-90, 0, 0)))
frames("post_b", foot=Location((0, 0, 0)))
frames("post_c", foot=Location((0, 0, 0)))
frames("post_d_part", foot=Location((0, 0, 0)))
frames("post_e", foot=Location((0, 0, 0)))
frames("arm", pivot=Location((6, -5, 0), (-90, 0, 0)))

# === assembly ===
mate("post_a.foot", "plate.s1", "peg_socket", nominal="spigot_d", fit="location")
mate("post_b.foot", "plate.s2", "peg_socket", nominal="spigot_d", fit="location")
mate("post_c.foot", "plate.s3", "peg_socket", nominal="spigot_d", fit="location")
mate("post_d_part.foot", "plate.s4", "peg_socket", nominal="spigot_d", fit="location")
mate("post_e.foot", "plate.s5", "peg_socket", nominal="spigot_d", fit="location")
mate("arm.pivot", "post_a.head", "revolute", nominal="pin_d", fit="clearance", limits=(-30, 30))
