"""x-io filtered-magnitude detector (Madgwick, xioTechnologies/Gait-Tracking-With-x-IMU, Script.m;
seed-004 §3 "[INF]"): on the accelerometer magnitude in g,

    m = ‖f‖ / g0;  m_hp = filtfilt(Butterworth high-pass 1st order, 0.001 Hz, m);  a = |m_hp|;
    T = filtfilt(Butterworth low-pass 1st order, 5 Hz, a);   stance ⇔ T < 0.05 (g)

Butterworth design via scipy.signal.butter (second-order sections, zero-phase sosfiltfilt) at the
recording's median sample rate. g0 = the gravity in use (x-io's script works in g of its sensor).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import butter, sosfiltfilt


def xio_statistic(acc_b: np.ndarray, dt: float, gravity: float, *, highpass_hz: float = 0.001,
                  lowpass_hz: float = 5.0) -> np.ndarray:
    fs = 1.0 / dt
    m = np.linalg.norm(np.asarray(acc_b, dtype=np.float64), axis=1) / gravity
    if m.size < 16:
        return np.abs(m - 1.0)
    hp = butter(1, highpass_hz, btype="highpass", fs=fs, output="sos")
    lp = butter(1, min(lowpass_hz, 0.45 * fs), btype="lowpass", fs=fs, output="sos")
    return sosfiltfilt(lp, np.abs(sosfiltfilt(hp, m)))
