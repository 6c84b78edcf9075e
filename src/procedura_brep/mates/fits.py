"""Fit classes resolved from ISO 286 hole/shaft pairs and ISO 273 clearance holes.

A fit class resolves, for a nominal size ``d`` (mm), to the hole and shaft diameters at the
middle of their ISO 286 tolerance zones, and to a signed **per-side offset**
``(hole - shaft) / 2``: positive is clearance, negative is interference.

=========== ============ ==================================================================
fit class   ISO pair     meaning
=========== ============ ==================================================================
clearance   H7/g6        sliding/running fit (pins, pivots, pegs that must come apart)
location    H7/k6        transition fit: accurate location, light tap to assemble
press       H7/p6        interference fit: pressed in, transmits load by friction
snap        H7 + snap    documented interference for snap features: the shaft (hook) is
                         oversize per side by ``clamp(0.02 d, 0.05, 0.5)`` mm
=========== ============ ==================================================================

Deviations are ISO 286-2:2010 values in micrometres for nominal sizes over 0 up to 500 mm
(13 bands). Bolt patterns use ISO 273:1979 clearance holes (``fine`` for the location fit,
``medium`` for the clearance fit) and accept only the metric sizes in that table.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal

from ..errors import RangeError

FitClass = Literal["clearance", "location", "press", "snap"]
FIT_CLASSES: tuple[FitClass, ...] = ("clearance", "location", "press", "snap")

#: Upper limits (mm, inclusive) of the ISO 286 nominal size bands; each band is (previous, this].
BANDS_MM = (3, 6, 10, 18, 30, 50, 80, 120, 180, 250, 315, 400, 500)
#: Standard tolerance grades IT6 / IT7 per band, micrometres (ISO 286-1 table 1).
IT6_UM = (6, 8, 9, 11, 13, 16, 19, 22, 25, 29, 32, 36, 40)
IT7_UM = (10, 12, 15, 18, 21, 25, 30, 35, 40, 46, 52, 57, 63)
#: Fundamental deviations per band, micrometres (ISO 286-2): g = upper (es), k and p = lower (ei).
G_ES_UM = (-2, -4, -5, -6, -7, -9, -10, -12, -14, -15, -17, -18, -20)
K_EI_UM = (0, 1, 1, 1, 2, 2, 2, 3, 3, 4, 4, 4, 5)
P_EI_UM = (6, 12, 15, 18, 22, 26, 32, 37, 43, 50, 56, 62, 68)

#: ISO 273 clearance holes: metric thread size -> (fine, medium, coarse) hole diameter, mm.
ISO273_MM: dict[float, tuple[float, float, float]] = {
    1.6: (1.7, 1.8, 2.0), 2.0: (2.2, 2.4, 2.6), 2.5: (2.7, 2.9, 3.1), 3.0: (3.2, 3.4, 3.6),
    4.0: (4.3, 4.5, 4.8), 5.0: (5.3, 5.5, 5.8), 6.0: (6.4, 6.6, 7.0), 8.0: (8.4, 9.0, 10.0),
    10.0: (10.5, 11.0, 12.0), 12.0: (13.0, 13.5, 14.5), 14.0: (15.0, 15.5, 16.5),
    16.0: (17.0, 17.5, 18.5), 20.0: (21.0, 22.0, 24.0), 24.0: (25.0, 26.0, 28.0),
    30.0: (31.0, 33.0, 35.0), 36.0: (37.0, 39.0, 42.0), 42.0: (43.0, 45.0, 48.0),
    48.0: (50.0, 52.0, 56.0), 56.0: (58.0, 62.0, 66.0), 64.0: (66.0, 70.0, 74.0),
}


@dataclass(frozen=True)
class Fit:
    """A resolved fit for one nominal size.

    Attributes:
        fit: the fit class.
        nominal: nominal size d, mm.
        iso: the ISO designation used, e.g. ``"H7/g6"`` or ``"ISO 273 medium"``.
        hole: hole (female) diameter at mid-tolerance, mm.
        shaft: shaft (male) diameter at mid-tolerance, mm.
        hole_limits: (min, max) hole diameter, mm.
        shaft_limits: (min, max) shaft diameter, mm.
    """

    fit: FitClass
    nominal: float
    iso: str
    hole: float
    shaft: float
    hole_limits: tuple[float, float]
    shaft_limits: tuple[float, float]

    @property
    def offset(self) -> float:
        """Signed per-side offset, mm: positive clearance, negative interference."""
        return (self.hole - self.shaft) / 2.0

    @property
    def interference(self) -> float:
        """Per-side interference (>= 0), mm: 0 for clearance fits."""
        return max(0.0, -self.offset)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["offset"] = self.offset
        return d


def _band(d: float) -> int:
    if not 0.0 < d <= BANDS_MM[-1]:
        raise RangeError("nominal size", d, 0.0, float(BANDS_MM[-1]), unit="mm")
    for i, top in enumerate(BANDS_MM):
        if d <= top:
            return i
    raise AssertionError("unreachable")


def iso286(d: float, fit: FitClass) -> Fit:
    """Resolve ``fit`` at nominal ``d`` (mm) to mid-tolerance hole and shaft diameters.

    Example:
        >>> f = iso286(10.0, "clearance")       # H7/g6 at 10 mm
        >>> round(f.offset * 1000, 1)           # per-side clearance in micrometres
        8.5
    """
    if fit not in FIT_CLASSES:
        raise ValueError(f"fit {fit!r} is not one of {', '.join(FIT_CLASSES)}")
    b = _band(d)
    um = 1e-3
    hole_lo, hole_hi = d, d + IT7_UM[b] * um  # H7: EI = 0, ES = IT7
    lo: float
    hi: float
    if fit == "clearance":
        es = G_ES_UM[b]
        lo, hi, iso = es - IT6_UM[b], es, "H7/g6"
    elif fit == "location":
        ei = K_EI_UM[b]
        lo, hi, iso = ei, ei + IT6_UM[b], "H7/k6"
    elif fit == "press":
        ei = P_EI_UM[b]
        lo, hi, iso = ei, ei + IT6_UM[b], "H7/p6"
    else:
        snap_um = 1000.0 * min(0.5, max(0.05, 0.02 * d))
        lo = hi = 2 * snap_um + IT7_UM[b] / 2
        iso = "H7/snap"
    shaft_lo, shaft_hi = d + lo * um, d + hi * um
    return Fit(fit, d, iso, (hole_lo + hole_hi) / 2, (shaft_lo + shaft_hi) / 2,
               (hole_lo, hole_hi), (shaft_lo, shaft_hi))


def iso273(d: float, fit: FitClass) -> Fit:
    """Clearance hole for an M``d`` bolt: ``location`` -> fine series, ``clearance`` -> medium.

    Raises:
        RangeError: ``d`` is not a size in ISO 273's table (the message lists the sizes).
    """
    series = {"location": 0, "clearance": 1}
    if fit not in series:
        raise ValueError(f"bolt patterns take fit 'clearance' or 'location', not {fit!r}")
    key = round(float(d), 3)
    if key not in ISO273_MM:
        sizes = ", ".join(f"{s:g}" for s in ISO273_MM)
        raise ValueError(f"bolt size M{d:g} is not in ISO 273; use one of: {sizes}")
    hole = ISO273_MM[key][series[fit]]
    name = ("fine", "medium")[series[fit]]
    return Fit(fit, d, f"ISO 273 {name}", hole, d, (hole, hole), (d, d))
