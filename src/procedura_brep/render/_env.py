"""Headless GL environment: the one place that sets the variables EGL-based libraries read.

Both MuJoCo (``MUJOCO_GL``) and PyOpenGL (``PYOPENGL_PLATFORM``) read their platform when they
are first imported, so :func:`ensure_headless` must run before ``import mujoco``. The render
package calls it on import; a process that imports MuJoCo first should call it earlier (the
package ``__init__`` is the right place). Values a user already set are kept.
"""

from __future__ import annotations

import os

HEADLESS_ENV: dict[str, str] = {"MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}
"""Variables set (with ``setdefault``) for headless EGL rendering on Mesa llvmpipe or a GPU."""


def ensure_headless() -> None:
    """Set :data:`HEADLESS_ENV` in ``os.environ`` unless the user chose other values."""
    for key, value in HEADLESS_ENV.items():
        os.environ.setdefault(key, value)
