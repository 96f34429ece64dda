"""``bootnav calibrate``: per-device sensor calibration from hand-held sessions (issue #23).

Modules: ``settings`` (tunables), ``static`` (still poses), ``accel_fit`` (multi-position accelerometer fit
[Skog2006]), ``gyro_fit`` (gyro scale and misalignment from the rotations between poses [Tedaldi2014]),
``fit`` (the whole calibration, checks, uncertainties), ``cli`` (the command), ``report`` (table and
files), ``live`` (guided live mode), ``synthetic`` (exact sessions for tests).
The model and the file format are ``bootnav.core.sensorcal``; docs/calibration.md has the procedure.
"""

import importlib

# lazy: `bootnav --help` imports the command's module (cli) through this package, and must not pay for
# numpy/scipy/numba (tests/test_long_speed.py)
_EXPORTS = {"CalibrationResult": "fit", "Session": "fit", "calibrate": "fit", "load_session": "fit",
            "session_from_recording": "fit", "SensorCalSettings": "settings"}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
