"""The frames, units and sign conventions (documented in ``bootnav``'s docstring) and the software version,
written into every output file. A leaf module: every layer imports these from here, so that the package
root can expose the Python API (``bootnav.api``) without an import cycle."""

__version__ = "0.1.0"

#: Standard gravity, m/s² (CGPM 1901): the unit "g" and the gravity assumed where none is given.
STANDARD_GRAVITY_MPS2 = 9.80665

#: ``summary.json["software"]`` of every kind of run (one shape: docs/summary.schema.json)
SOFTWARE = {"name": "bootnav", "version": __version__}

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
