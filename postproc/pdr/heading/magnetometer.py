"""Magnetometer heading with tilt compensation.

Tilt-compensated (engineered, standard vector form): with u = up direction in the body frame (the
accelerometer at rest reads +g along up, bootnav.CONVENTIONS) and m the calibrated field,

    e = m x u  (east),  n = u x e  (north),  heading = atan2(f . e, f . n)

where f is the body axis that points forward (phone: +y, towards the top of the screen). Without tilt
(a level device, u = +z) this reduces to heading = atan2(-m_x, m_y).

[Lazarevskiy2021, §3.1.10] (literal): theta = atan2(B_x, B_y) (counter-clockwise from north, [0, 360) deg);
bearing = -theta. Example (the thesis's Fig. 4.5 first row): B = (-17.9375, -21.0625) uT -> theta = 220.419
deg, bearing 139.581 deg.

[NKUA2009, §4.2] tilt weights (``tilt_weight_heading``): moving-average the compass components and the
accelerations (8 samples at 20 Hz), w = a_bar / |a_bar| ("the influence of each axis", literal); the final
equations are unreadable in the thesis except the fragment "+ w_z Z_bar" [reconstructed]: we read it as the
projection of the field on the plane normal to w, H^ = H_bar - (w_x X_bar + w_y Y_bar + w_z Z_bar) w, whose
bearing is then taken as above.
"""

from __future__ import annotations

import numpy as np


def seed003_theta_deg(bx, by) -> np.ndarray:
    """[Lazarevskiy2021] literal: theta = mod(degrees(atan2(Bx, By)), 360), counter-clockwise from north."""
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


def tilt_weight_heading(t_s, mag_b, acc_b, forward_b=(0.0, 1.0, 0.0), window_s: float = 0.4) -> np.ndarray:
    """Bearing (rad, clockwise from magnetic north) with the [NKUA2009, §4.2] tilt-weight correction.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, s (set the moving-average length in samples).
    mag_b, acc_b : array_like, shape (N, 3)
        Field (any unit) and specific force (gravity included) in the sensor frame.
    forward_b : sequence of 3 float
        Body axis pointing forward.
    window_s : float
        Length of the causal moving average, s: the thesis' 8 samples at its 20 Hz = 0.4 s.

    Returns
    -------
    ndarray, shape (N,)
        Bearing in (-pi, pi].
    """
    from bootnav.postproc.pdr.signals import causal_moving_average, nominal_rate_hz

    n = max(1, int(round(window_s * nominal_rate_hz(np.asarray(t_s, float)))))
    m_bar = np.column_stack([causal_moving_average(c, n) for c in np.asarray(mag_b, float).T])
    a_bar = np.column_stack([causal_moving_average(c, n) for c in np.asarray(acc_b, float).T])
    w = a_bar / np.linalg.norm(a_bar, axis=1, keepdims=True)
    h_corr = m_bar - np.sum(m_bar * w, axis=1, keepdims=True) * w
    return tilt_compensated_heading(h_corr, w, forward_b)


def untilted_heading(mag_b, forward_b=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Bearing (rad) of a device assumed level (no tilt compensation): [Lazarevskiy2021, eq. 3.2 / §3.1.10]
    theta = atan2(B_x, B_y), bearing = -theta, for the forward axis +y; other forward axes turn the same
    level-device formula."""
    return tilt_compensated_heading(mag_b, (0.0, 0.0, 1.0), forward_b)
