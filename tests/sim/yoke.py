"""A camera head tilting in the yoke of a pan head, as on golden/rover, for B2's turning
contact (issue 24.1; hand-written test program, not model output): a filleted box turns on its
pin between the yoke's two cheeks, its side face touching one cheek's inner face at every pose
and its fillets' edges crossing the cheek's end faces in that plane. Optionally the cheeks run
longer and a rib on the other cheek's inner face stands 2 mm into the head's slab beside the
head, where one of its corners passes: clear at the range's start (-45 degrees) and at rest,
hit on the way."""

from __future__ import annotations

TEMPLATE = '''"""A camera head tilting in a yoke; rib on the cheek: {rib}. Hand-written test program."""
from procedura_brep.program import *

# === params ===
head_l = 60.0  # mm, head depth (X)
head_w = 70.0  # mm, head width (along the tilt axis)
head_h = 40.0  # mm, head height
cheek_t = 10.0  # mm, cheek thickness
cheek_h = 82.0  # mm, cheek height above the plate
tilt_z = 50.0  # mm, tilt axis height above the plate's foot
pin_d = 8.0  # mm, tilt pin: nominal of the tilt revolute
cheek_l = {cheek_l}  # mm, cheek length (X)
rib_x = 30.5  # mm, the rib's inner edge from the tilt axis along X (the head ends at 30)
rib_z = 12.0  # mm, the rib's lower edge above the tilt axis
rib_t = 4.0  # mm, how far the rib stands off its cheek (the head clears that cheek by 2)

# === helpers ===

# === parts ===
@part(detail="major", material="aluminium", description="yoke: a plate and two cheeks")
def yoke():
    gap = head_w + 2
    plate = Box(60, gap + 2 * cheek_t, 10, align=(Align.CENTER, Align.CENTER, Align.MIN))
    cheeks = [Pos(0, s * (gap / 2 + cheek_t / 2), 10) * Box(cheek_l, cheek_t, cheek_h,
                                                            align=(Align.CENTER, Align.CENTER, Align.MIN))
              for s in (1, -1)]
    shape = plate + cheeks
{rib_code}    return shape


@part(detail="major", material="abs_plastic", description="camera head tilting in the yoke")
def head():
    h = Pos(0, -head_w / 2, 0) * Box(head_l, head_w, head_h)
    return fillet(h.edges(), radius=4)


# === frames ===
frames("yoke", tilt=Location((0, (head_w + 2) / 2, tilt_z), (90, 0, 0)))
frames("head", tilt=Location((0, 0, 0), (90, 0, 0)))

# === assembly ===
mate("head.tilt", "yoke.tilt", "revolute", nominal="pin_d", fit="clearance", limits=(-45, 60),
     depth=cheek_t - 4)
'''

RIB = '''    gap = head_w + 2
    shape = shape + Pos(rib_x, -gap / 2 + rib_t / 2, tilt_z + rib_z) * Box(8, rib_t, 8, align=(Align.MIN, Align.CENTER, Align.MIN))
'''


def program(rib: bool) -> str:
    """The program text, with or without the rib on the cheek."""
    return TEMPLATE.format(rib="yes" if rib else "no", rib_code=RIB if rib else "",
                           cheek_l=90.0 if rib else 36.0)
