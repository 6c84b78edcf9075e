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


def egl_available() -> bool:
    """Whether a libEGL can be loaded (Mesa's or a GPU driver's)."""
    import ctypes
    for name in ("libEGL.so.1", "libEGL.so"):
        try:
            ctypes.CDLL(name)
            return True
        except OSError:
            continue
    return False


def ensure_headless() -> None:
    """Set :data:`HEADLESS_ENV` in ``os.environ`` unless the user chose other values.

    Without a loadable libEGL nothing is set: ``MUJOCO_GL=egl`` would make ``import mujoco``
    fail, while without it MuJoCo still imports and simulates (only rendering is unavailable;
    ``procedura-brep doctor`` says how to install EGL).
    """
    if all(k in os.environ for k in HEADLESS_ENV) or not egl_available():
        return
    for key, value in HEADLESS_ENV.items():
        os.environ.setdefault(key, value)
