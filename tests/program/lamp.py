"""Desk lamp base with a swinging arm. Hand-written test program (procedura-brep format)."""
from procedura_brep.program import *

# === params ===
base_w = 120.0  # mm, square base side
base_t = 12.0   # mm, base thickness
post_d = 20.0   # mm, post diameter: the nominal of the post's peg_socket
post_h = 80.0   # mm
spigot_d = 12.0  # mm, spigot under the post: the nominal of its peg_socket
pin_d = 8.0     # mm, hinge pin: the nominal of the arm's revolute mate

# === helpers ===

# === parts ===
@part(detail="silhouette", material="cast_iron", description="square base, rounded corners")
def base():
    b = Box(base_w, base_w, base_t, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return fillet(b.edges().filter_by(Axis.Z), radius=6)

@part(detail="major", material="brushed_steel", description="vertical post at the base centre")
def post():
    p = Cylinder(post_d / 2, post_h, align=(Align.CENTER, Align.CENTER, Align.MIN))
    return chamfer(p.edges().group_by(Axis.Z)[-1], length=1.0)

@part(detail="major", material="painted_aluminium", description="arm swinging about a pin at the post top")
def arm():
    return Box(90, 14, 10, align=(Align.MIN, Align.CENTER, Align.CENTER))

# === frames ===
frames("base", top=Location((0, 0, base_t)))
frames("post", foot=Location((0, 0, 0)), head=Location((0, post_d / 2, post_h - 6), (-90, 0, 0)))
frames("arm", pivot=Location((7, -7, 0), (-90, 0, 0)))

# === assembly ===
mate("post.foot", "base.top", "peg_socket", nominal="spigot_d", fit="location")
mate("arm.pivot", "post.head", "revolute", nominal="pin_d", fit="clearance", limits=(-45, 45))
