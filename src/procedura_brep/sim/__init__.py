"""The MuJoCo battery: ``run_battery(bundle_dir | model) -> BatteryReport`` (checks B0-B8)."""

from .report import BatteryReport, CheckResult


def run_battery(*args, **kwargs):  # noqa: ANN002, ANN003, ANN201 - lazy (mujoco import)
    """See :func:`procedura_brep.sim.battery.run_battery`."""
    from .battery import run_battery as _run
    return _run(*args, **kwargs)


__all__ = ["BatteryReport", "CheckResult", "run_battery"]
