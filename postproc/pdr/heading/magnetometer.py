"""Magnetometer heading with tilt compensation.

Tilt-compensated (engineered, standard vector form): with u = up direction in the body frame (the
accelerometer at rest reads +g along up, bootnav.CONVENTIONS) and m the calibrated field,

    e = m x u  (east),  n = u x e  (north),  heading = atan2(f . e, f . n)

where f is the body axis that points forward (phone: +y, towards the top of the screen). Without tilt
(a level device, u = +z) this reduces to heading = atan2(-m_x, m_y).

seed-003 §1.5 step 9 / R16 (literal): theta = atan2(B_x, B_y) (counter-clockwise from north, [0, 360) deg);
bearing = -theta. Test T7: B = (-17.9375, -21.0625) uT -> theta = 220.419 deg, bearing 139.581 deg.
"""

from __future__ import annotations

import numpy as np


def seed003_theta_deg(bx, by) -> np.ndarray:
    """seed-003 literal: theta = mod(degrees(atan2(Bx, By)), 360), counter-clockwise from north."""
    return np.mod(np.degrees(np.arctan2(bx, by)), 360.0)


def tilt_compensated_heading(mag_b: np.ndarray, up_b: np.ndarray, forward_b=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Bearing (rad, clockwise from magnetic north, in (-pi, pi]) of the body ``forward_b`` axis.

    mag_b: (N, 3) field in the body frame (any unit); up_b: (N, 3) or (3,) up direction in the body frame
    (e.g. normalised low-passed accelerometer)."""
    m = np.atleast_2d(np.asarray(mag_b, float))
    u = np.atleast_2d(np.asarray(up_b, float))
    u = u / np.linalg.norm(u, axis=1, keepdims=True)
    e = np.cross(m, u)
    e /= np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-12)
    n = np.cross(u, e)
    f = np.asarray(forward_b, float)
    return np.arctan2(e @ f, n @ f)
