"""Gyro heading by integration of the rate about gravity, [Lazarevskiy2021, eqs. 2.5–2.6] (after Manos,
Klein & Hazan):

    omega_v(t) = u(t)^T omega(t)              (u: unit UP direction in the body frame; the thesis uses the
                                               gravity (down) direction, which flips the sign so that a
                                               right turn is positive -- the same as a bearing increase)
    psi(t) = psi_s - integral_{t_s}^{t} omega_v dtau     (bearing, clockwise from north)

Signed-magnitude variant (eq. 2.7–2.8): omega_sm = sgn(omega_v) ||omega||.
Integration: trapezoidal (scipy cumulative_trapezoid) on the recording's own clock.
"""

from __future__ import annotations

import numpy as np

from bootnav.postproc.pdr.signals import clean_time, gravity_direction, nominal_rate_hz


def gyro_heading(t_s, gyro_b, acc_b, psi0_rad: float = 0.0, signed_magnitude: bool = False,
                 gravity_cutoff_hz: float = 0.3):
    """Returns (t_s, bearing_rad unwrapped) per sample."""
    from scipy.integrate import cumulative_trapezoid

    t, w, a = clean_time(t_s, np.asarray(gyro_b, float), np.asarray(acc_b, float))
    up = gravity_direction(a, nominal_rate_hz(t), gravity_cutoff_hz)
    wv = np.einsum("ij,ij->i", w, up)
    if signed_magnitude:
        wv = np.sign(wv) * np.linalg.norm(w, axis=1)
    return t, psi0_rad - cumulative_trapezoid(wv, t, initial=0.0)
