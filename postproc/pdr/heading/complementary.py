"""Complementary fusion of gyro and magnetometer bearings [engineered, standard form]:

    psi = psi_gyro + LP_tau( unwrap(wrap(psi_mag - psi_gyro)) )

i.e. the gyro supplies the short-term changes (no magnetic disturbance) and the magnetometer the long-term
reference (no drift); first-order low-pass with time constant tau (default 10 s), which equals the
recursive form psi_k = psi_{k-1} + d psi_gyro + (dt/tau) wrap(psi_mag,k - psi_{k-1}) for dt << tau.
Zero-phase (filtfilt) in post-processing.
"""

from __future__ import annotations

import numpy as np


def complementary_heading(t_s, psi_gyro_rad, psi_mag_rad, tau_s: float = 10.0) -> np.ndarray:
    from scipy import signal

    t = np.asarray(t_s, float)
    d = np.unwrap(np.angle(np.exp(1j * (np.asarray(psi_mag_rad) - np.asarray(psi_gyro_rad)))))
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    alpha = dt / (tau_s + dt)
    b, a = [alpha], [1.0, alpha - 1.0]
    if d.size > 9:
        lp = signal.filtfilt(b, a, d, padlen=min(d.size - 1, int(3 * tau_s / dt)))
    else:
        lp = np.full(d.size, np.mean(d))
    return np.asarray(psi_gyro_rad) + lp
