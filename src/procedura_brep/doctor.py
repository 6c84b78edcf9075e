"""``procedura-brep doctor``: what is installed, what is missing, and how to fix it."""

from __future__ import annotations

import importlib
import os
import shutil
import subprocess
import sys

from .llm import Check, check_provider


def _module(name: str, label: str, fix: str, *, optional: bool = False, attr: str = "__version__") -> Check:
    try:
        mod = importlib.import_module(name)
    except Exception as exc:  # noqa: BLE001 - whatever breaks the import is the report - any import failure is a finding
        return Check(label, False, f"cannot import {name}: {type(exc).__name__}: {exc}", fix, optional)
    return Check(label, True, f"{name} {getattr(mod, attr, '')}".strip())


def _kernel() -> Check:
    code = ("import build123d, OCP; from build123d import Box; "
            "print(build123d.__version__, round(Box(1, 2, 3).volume, 6))")
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return Check("CAD kernel", False, "build123d did not import within 60 s", "pip install -e .")
    if out.returncode != 0 or not out.stdout.strip().endswith("6.0"):
        tail = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return Check("CAD kernel", False, f"build123d/OCP broken: {tail}",
                     "pip install 'build123d==0.13.0' (and do not install cadquery beside it)")
    return Check("CAD kernel", True, f"build123d {out.stdout.split()[0]} (OCCT via OCP), a box's volume is exact")


def _render() -> Check:
    code = ("from procedura_brep.render.gl import *; import moderngl; "
            "ctx = moderngl.create_standalone_context(backend='egl'); "
            "print(ctx.info['GL_RENDERER'])")
    fix = "pip install moderngl; apt-get install -y libegl1 libgl1-mesa-dri"
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        return Check("render backend", False, "EGL context creation hung for 60 s", fix)
    if out.returncode != 0:
        tail = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return Check("render backend", False, f"moderngl on EGL failed: {tail}", fix)
    return Check("render backend", True, f"moderngl on EGL: {out.stdout.strip()}")


def _usd() -> Check:
    try:
        from pxr import Usd, UsdValidation  # noqa: F401 - the check is that they import
    except Exception as exc:  # noqa: BLE001 - whatever breaks the import is the report
        return Check("OpenUSD", False, f"cannot import pxr.UsdValidation: {exc}", "pip install usd-core")
    return Check("OpenUSD", True, f"usd-core {'.'.join(map(str, Usd.GetVersion()))} with UsdValidation")


def _freecad() -> Check:
    exe = shutil.which("freecadcmd")
    if exe is None:
        return Check("FreeCAD (optional)", False, "freecadcmd not found", "apt-get install -y freecad",
                     optional=True)
    return Check("FreeCAD (optional)", True, exe)


def _isolation() -> Check:
    """Which OS layers a compile child gets here (a probe child applies them to itself)."""
    from .program.isolation import probe
    fix = ("Landlock needs Linux >= 5.13 (and not disabled with lsm=); the network namespace "
           "needs root or unprivileged user namespaces; the own uid needs root")
    try:
        res = probe()
    except OSError as exc:
        return Check("sandbox isolation (optional)", False, f"the probe failed: {exc}", fix,
                     optional=True)
    return Check("sandbox isolation" + ("" if not res.missing else " (optional)"),
                 not res.missing, res.line(), fix, optional=True)


def run_checks(*, model: str | None, base_url: str | None, ping: bool) -> list[Check]:
    """Every check, in a stable order."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    checks = [
        Check("python", sys.version_info >= (3, 11), sys.version.split()[0], "use Python 3.11 or newer"),
        _kernel(),
        _module("mujoco", "MuJoCo", "pip install mujoco"),
        _usd(),
        _render(),
        _freecad(),
        _module("yourdfpy", "yourdfpy", "pip install yourdfpy"),
        _isolation(),
    ]
    if shutil.which("check_urdf") is None:
        checks.append(Check("check_urdf (optional)", False, "not found", "apt-get install -y liburdfdom-tools",
                            optional=True))
    else:
        checks.append(Check("check_urdf (optional)", True, shutil.which("check_urdf") or ""))
    checks.extend(check_provider(model, base_url, ping=ping))
    return checks
