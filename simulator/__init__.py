"""Boot-motion simulator: exact truth (stance, swing, turns, stairs, running) and an MPU6050 error model.

Python API::

    from bootnav.simulator import simulate, write_h5, write_sd_txt
    res = simulate("three-floors", seed=1, profile="mpu6050-16g-2000dps", rate_hz=200.0)
    write_h5(res, "three_floors.h5")
    cal = simulate("calibration", seed=1, device=0x2A)  # one unit, hand-held calibration session

See docs/simulator.md for the scenarios and the model equations.

The names below load their module on first use (PEP 562), so that ``bootnav --help`` and every command that
never simulates do not import scipy for it. ``simulate`` is both a function and its module's name: the
package attribute is always the function, also after ``import bootnav.simulator.simulate`` (which would
otherwise bind the module there, ``_Package.__setattr__``).
"""

import importlib
import sys
import types

if __name__ != "bootnav.simulator":  # the folder simulator/ is importable only as bootnav.simulator (one module, one name)
    raise ImportError(f"import bootnav.simulator, not {__name__}: the simulator/ folder installs as bootnav.simulator")

_HOME = {  # public name -> its module in this package
    "GAITS": "gait", "Gait": "gait", "PathBuilder": "gait",
    "PROFILES": "imu_model", "SensorProfile": "imu_model", "get_profile": "imu_model",
    "MOUNTS": "imu_synth", "Mount": "imu_synth", "synthesize": "imu_synth",
    "SCENARIOS": "scenarios", "Scenario": "scenarios", "custom": "scenarios", "get_scenario": "scenarios",
    "SimResult": "simulate", "simulate": "simulate",
    "write_h5": "writers", "write_sd_txt": "writers",
    "DeviceModel": "device", "TemperatureProfile": "device", "draw_unit": "device",
    "CalibrationPlan": "calibration",
}

__all__ = ["simulate", "SimResult", "write_h5", "write_sd_txt", "SCENARIOS", "Scenario", "custom", "get_scenario",
           "PROFILES", "SensorProfile", "get_profile", "MOUNTS", "Mount", "GAITS", "Gait", "PathBuilder",
           "synthesize", "DeviceModel", "TemperatureProfile", "draw_unit", "CalibrationPlan"]


def __getattr__(name: str):
    """Import the module of a public name on first use and bind the name here (PEP 562)."""
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    setattr(sys.modules[__name__], name, value)
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """This package's module type: importing the submodule ``simulate`` binds the function, not the module."""

    def __setattr__(self, name, value):
        if name == "simulate" and isinstance(value, types.ModuleType):
            value = value.simulate
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
