"""Offscreen frames of a failing battery phase (MuJoCo renderer, EGL when available).

Rendering is best effort: if no GL context can be made, no frames are saved and the caller
notes it; a check never fails because frames could not be rendered.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

#: At most this many frames are saved per failing check.
MAX_FRAMES = 8
#: Frame size, pixels.
WIDTH, HEIGHT = 480, 360


def render_frames(model, qpos_list: list[np.ndarray], out_dir: Path, stem: str) -> list[str]:
    """Render up to :data:`MAX_FRAMES` evenly spaced states; return paths relative to
    ``out_dir`` (empty if rendering is unavailable)."""
    if not qpos_list:
        return []
    try:
        import mujoco
        from PIL import Image
        idx = np.unique(np.linspace(0, len(qpos_list) - 1, min(MAX_FRAMES, len(qpos_list))).astype(int))
        data = mujoco.MjData(model)
        opt = mujoco.MjvOption()
        cam = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, cam)
        sub = out_dir / "renders" / "sim"
        sub.mkdir(parents=True, exist_ok=True)
        paths = []
        with mujoco.Renderer(model, HEIGHT, WIDTH) as renderer:  # GL context freed on errors
            for k, i in enumerate(idx):
                data.qpos[:] = qpos_list[int(i)]
                mujoco.mj_forward(model, data)
                renderer.update_scene(data, camera=cam, scene_option=opt)
                path = sub / f"{stem}_{k}.png"
                Image.fromarray(renderer.render()).save(path)
                paths.append(str(path.relative_to(out_dir)))
        return paths
    except Exception as exc:  # no GL context, no display: frames are optional
        log.warning("could not render frames for %s: %s", stem, exc)
        return []
