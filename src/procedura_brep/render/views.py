"""The fixed view catalog and camera fitting (pure numpy, no GL).

Convention: the program's front is its -Y side and up is +Z. A view is named by where the
camera stands: ``front`` looks from -Y towards +Y (so +X is to the image's right), ``right``
stands at +X, ``top`` at +Z (front at the image bottom), ``iso_se`` at (+X, -Y, +Z) (the front
right corner; north is +Y, east is +X). ``*_low`` corners stand below the model, ``eye_*`` are
perspective views a little above the ground plane, ``tilt_up`` / ``tilt_down`` are perspective
front views from below / above.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..errors import RangeError

Projection = Literal["ortho", "persp"]

ISO_ELEVATION_DEG: float = math.degrees(math.atan(1 / math.sqrt(2)))  # 35.264: true isometric
EYE_ELEVATION_DEG: float = 8.0
"""Elevation of the eye-level diagonals, degrees above the horizon."""
TILT_DEG: float = 25.0
"""Elevation magnitude of the front tilts."""
FOV_DEG: float = 35.0
"""Vertical field of view of perspective views."""
FIT_MARGIN: float = 1.08
"""Fitted views leave this factor of free space around the bounding box."""


@dataclass(frozen=True)
class View:
    """One catalog entry: the camera direction (from the target) and the projection.

    Attributes:
        name: catalog name.
        azimuth_deg: in the XY plane, from +X towards +Y (front = -90).
        elevation_deg: above the XY plane (top = 90).
        projection: ``"ortho"`` or ``"persp"``.
        up: the image-up world vector.
    """

    name: str
    azimuth_deg: float
    elevation_deg: float
    projection: Projection
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    @property
    def direction(self) -> np.ndarray:
        """Unit vector from the target to the camera."""
        az, el = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        d = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        d[np.abs(d) < 1e-12] = 0.0
        return d


def _catalog() -> dict[str, View]:
    iso, eye = ISO_ELEVATION_DEG, EYE_ELEVATION_DEG
    corners = {"ne": 45.0, "nw": 135.0, "sw": -135.0, "se": -45.0}
    views = [View("front", -90, 0, "ortho"), View("back", 90, 0, "ortho"),
             View("left", 180, 0, "ortho"), View("right", 0, 0, "ortho"),
             View("top", -90, 90, "ortho", (0.0, 1.0, 0.0)),
             View("bottom", -90, -90, "ortho", (0.0, 1.0, 0.0))]
    views += [View(f"iso_{k}", a, iso, "ortho") for k, a in corners.items()]
    views += [View(f"iso_{k}_low", a, -iso, "ortho") for k, a in corners.items()]
    views += [View(f"eye_{k}", a, eye, "persp") for k, a in corners.items()]
    views += [View("tilt_up", -90, -TILT_DEG, "persp"), View("tilt_down", -90, TILT_DEG, "persp")]
    return {v.name: v for v in views}


VIEWS: dict[str, View] = _catalog()
"""All 20 views, in catalog order."""
DEFAULT_VIEWS: tuple[str, ...] = ("iso_se", "iso_sw", "iso_ne", "iso_nw", "front", "back", "left",
                                  "right", "top", "bottom", "iso_se_low", "eye_se")
"""The 12 views the build loop sends to the model by default."""


def caption(name: str) -> str:
    """``"front (from -Y)"``: a view's name and the world side its camera looks from (every
    axis the camera direction leans along by more than 0.3), so a model or a person reading
    the images knows which way each looks; an unknown name is returned as it is."""
    v = VIEWS.get(name)
    if v is None:
        return name
    d = v.direction
    side = "".join(("+" if x > 0 else "-") + "XYZ"[k] for k, x in enumerate(d) if abs(x) > 0.3)
    return f"{name} (from {side}, {v.projection})"


def parse_views(views: str | list[str] | tuple[str, ...] | None) -> list[str]:
    """Normalise ``"iso_ne,front"`` or a list to catalog names (1..20, no duplicates, in order).

    Raises:
        ValueError: an unknown name (the message lists the catalog).
        RangeError: fewer than 1 or more than 20 views.
    """
    if views is None:
        return list(DEFAULT_VIEWS)
    if isinstance(views, str):
        views = [v for v in views.replace(" ", "").split(",") if v]
    if list(views) == ["all"]:
        return list(VIEWS)
    out: list[str] = []
    for v in views:
        if v not in VIEWS:
            raise ValueError(f"unknown view {v!r}; use 1-20 of: {', '.join(VIEWS)} (or 'all')")
        if v not in out:
            out.append(v)
    if not 1 <= len(out) <= len(VIEWS):
        raise RangeError("number of views", len(out), 1, len(VIEWS))
    return out


@dataclass(frozen=True)
class Camera:
    """A fitted camera: world-to-view and projection matrices plus the basis for shading."""

    view: np.ndarray
    proj: np.ndarray
    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    up: np.ndarray
    ortho: bool

    @property
    def view_proj(self) -> np.ndarray:
        return self.proj @ self.view

    def project(self, points: np.ndarray, size: int) -> np.ndarray:
        """World points (N, 3) to pixel coordinates (N, 2), origin top-left, x right, y down."""
        p = np.c_[np.asarray(points, float).reshape(-1, 3), np.ones(len(np.asarray(points).reshape(-1, 3)))]
        clip = p @ self.view_proj.T
        ndc = clip[:, :3] / clip[:, 3:4]
        return np.c_[(ndc[:, 0] + 1) * 0.5 * size, (1 - ndc[:, 1]) * 0.5 * size]


def _ortho(half: float, near: float, far: float) -> np.ndarray:
    m = np.eye(4)
    m[0, 0] = m[1, 1] = 1.0 / half
    m[2, 2] = -2.0 / (far - near)
    m[2, 3] = -(far + near) / (far - near)
    return m


def _persp(fovy_deg: float, near: float, far: float) -> np.ndarray:
    f = 1.0 / math.tan(math.radians(fovy_deg) / 2)
    m = np.zeros((4, 4))
    m[0, 0] = m[1, 1] = f
    m[2, 2] = (far + near) / (near - far)
    m[2, 3] = 2 * far * near / (near - far)
    m[3, 2] = -1.0
    return m


def fit_camera(view: View, lo: np.ndarray, hi: np.ndarray, *, margin: float = FIT_MARGIN) -> Camera:
    """Fit ``view`` to the axis-aligned box ``lo``..``hi`` (mm) so the whole box is in frame."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 1e-3)
    d = view.direction
    fwd = -d
    right = np.cross(fwd, np.asarray(view.up, float))
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    if view.projection == "ortho":
        rel = corners - centre
        u, v = rel @ right, rel @ up
        cu, cv = (u.max() + u.min()) / 2, (v.max() + v.min()) / 2
        half = max(u.max() - u.min(), v.max() - v.min(), 1e-3) / 2 * margin
        target = centre + cu * right + cv * up
        dist = 2 * radius + 1.0
        near, far = 0.5, 4 * radius + 2.0
        proj = _ortho(half, near, far)
    else:
        target = centre
        dist = radius / math.sin(math.radians(FOV_DEG) / 2) * margin
        near, far = max(dist - radius * 1.5, dist * 0.01), dist + radius * 1.5
        proj = _persp(FOV_DEG, near, far)
    eye = target + d * dist
    view_m = np.eye(4)
    view_m[0, :3], view_m[1, :3], view_m[2, :3] = right, up, -fwd
    view_m[:3, 3] = -view_m[:3, :3] @ eye
    return Camera(view_m, proj, eye, fwd, right, up, view.projection == "ortho")
