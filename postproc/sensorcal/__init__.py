"""``bootnav calibrate``: per-device sensor calibration from hand-held sessions (issue #23).

Modules: ``settings`` (tunables), ``static`` (still poses), ``accel_fit`` (multi-position accelerometer fit
[Skog2006]), ``gyro_fit`` (gyro scale and misalignment from the rotations between poses [Tedaldi2014]),
``fit`` (the whole calibration, checks, uncertainties), ``cli`` (the command), ``report`` (table and
files), ``live`` (guided live mode), ``synthetic`` (exact sessions for tests).
The model and the file format are ``bootnav.core.sensorcal``; docs/calibration.md has the procedure.
"""

from .fit import CalibrationResult, Session, calibrate, load_session, session_from_recording
from .settings import SensorCalSettings

__all__ = ["CalibrationResult", "Session", "SensorCalSettings", "calibrate", "load_session",
           "session_from_recording"]
