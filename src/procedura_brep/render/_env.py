"""Compatibility name: the headless GL environment lives in :mod:`procedura_brep.headless`."""

from ..headless import HEADLESS_ENV, egl_available, ensure_headless

__all__ = ["HEADLESS_ENV", "egl_available", "ensure_headless"]
