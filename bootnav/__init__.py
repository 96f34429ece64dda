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
"""

__version__ = "0.1.0"

CONVENTIONS = {
    "units": "SI: m, s, m/s^2, rad/s, degC",
    "nav_frame": "ENU (x east, y north, z up), right-handed, origin at start",
    "body_frame": "sensor axes as printed on the MPU6050 board, right-handed",
    "quaternion_order": "wxyz (scalar first), q_nb rotates body to nav",
    "gravity_model": "g_n = [0, 0, -g]; accelerometer at rest reads +g on the up axis",
    "heading": ("direction of travel: yaw_enu_rad = counter-clockwise from east (x), atan2(dy, dx), rad in "
                "(-pi, pi]; heading_deg_cw_from_north = clockwise from north (y), deg in [0, 360) "
                "= (90 - degrees(yaw_enu_rad)) mod 360"),
}
