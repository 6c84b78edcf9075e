"""procedura-brep: a text prompt to an editable CAD assembly.

The package is layered (see docs/architecture.md): ``errors``/``config`` -> ``mates`` -> ``program`` ->
``gates`` -> ``export`` -> ``sim``/``render`` -> ``agent`` -> ``cli``. ``llm`` sits to the side.
Importing this package is cheap: nothing here imports the CAD kernel.
"""

__version__ = "0.1.0"

# Headless GL (MUJOCO_GL / PYOPENGL_PLATFORM = egl) must be set before MuJoCo is imported
# anywhere in the process; this loads no GL and no CAD kernel.
from .headless import ensure_headless as _ensure_headless

_ensure_headless()
