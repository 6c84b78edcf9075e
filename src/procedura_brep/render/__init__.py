"""Offscreen views of a compiled assembly: parts-colour sheets, grey clay, PBR.

Rendering is headless OpenGL 3.3 through moderngl on EGL (Mesa llvmpipe on a CPU machine, or a
GPU driver), in the same process as MuJoCo; see ``docs/render.md``. Importing this package sets
the headless environment variables (:mod:`procedura_brep.headless`) but loads no GL and no CAD kernel.
"""

from __future__ import annotations

from ..headless import ensure_headless

ensure_headless()

from .api import (  # noqa: E402 - after ensure_headless(): GL picks EGL
                  CLOSE_UP_VIEWS,
                  MODES,
                  Focus,
                  RenderResult,
                  legend_of,
                  part_frames,
                  render_images,
                  render_to_dir,
                  resolve_focus,
                  sheet_image,
)
from .cache import ViewStatus, geometry_key, views_status  # noqa: E402 - after ensure_headless(): GL picks EGL
from .palette import PALETTE, part_colors  # noqa: E402 - after ensure_headless(): GL picks EGL
from .views import DEFAULT_VIEWS, VIEWS, View, fit_camera, parse_views  # noqa: E402 - after ensure_headless(): GL picks EGL

__all__ = ["CLOSE_UP_VIEWS", "DEFAULT_VIEWS", "MODES", "PALETTE", "VIEWS", "Focus", "RenderResult",
           "View", "ViewStatus", "ensure_headless", "fit_camera", "geometry_key", "legend_of",
           "parse_views", "part_colors", "part_frames", "render_images", "render_to_dir",
           "resolve_focus", "sheet_image", "views_status"]
