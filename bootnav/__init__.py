"""bootnav: foot-mounted inertial navigation for firefighters and pedestrians.

Conventions used by every package (written into every output file as attributes):

* Units: SI inside — m, s, m/s², rad/s, °C.
* Navigation frame ``n``: local level, right-handed, east-north-up (z up), origin at the start.
* Body frame ``b``: the sensor's own axes as printed on the MPU6050 breakout (right-handed).
* Quaternions: scalar first ``[w, x, y, z]``, ``q_nb`` rotates body vectors into the navigation frame.
* Gravity: ``g_n = [0, 0, -g]``; an accelerometer at rest reads ``+g`` along the up axis
  (specific force). Default ``g = 9.80665`` m/s² unless a latitude/height is given (WGS-84 normal gravity).
* Heading (direction of travel of a stride or step): two columns, never a bare ``heading_rad`` —
  ``yaw_enu_rad``, counter-clockwise from east (x), ``atan2(Δy, Δx)`` in (−π, π], the angle of the ENU
  frame; ``heading_deg_cw_from_north``, the same direction as a compass reads it, clockwise from north (y),
  in [0, 360) = (90 − degrees(yaw_enu_rad)) mod 360.

Python API (``bootnav.api``, imported on first use so that ``import bootnav`` stays light):
``bootnav.load(path)``, ``bootnav.process(path | recording | t_s, acc_mps2, gyro_radps, **settings)``,
``bootnav.pdr(...)``, ``bootnav.process_two_boots(left, right)`` (both feet of one walker); results hold numpy
arrays and convert with ``.to_dataframe()`` (pandas optional).
"""

from .core.conventions import CONVENTIONS, __version__

_API = ("load", "process", "process_two_boots", "pdr", "PathResult", "StepResult", "TwoBootPathResult")
__all__ = ["CONVENTIONS", "__version__", *_API]


def __getattr__(name: str):
    """Resolve the API names on first use (PEP 562): ``import bootnav`` imports no numpy."""
    if name in _API:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'bootnav' has no attribute {name!r}")
