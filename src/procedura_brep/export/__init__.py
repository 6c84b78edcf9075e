"""Exporters: pure functions from a CompiledModel to file bytes (STEP, OBJ+MTL, GLB, USD, URDF, MJCF).

Kept import-free on purpose (the CLI loads this package for ``--help``): import the submodule you
need, e.g. ``from procedura_brep.export.step import step_bytes``.
"""
