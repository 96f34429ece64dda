"""x-io filtered-magnitude detector [Madgwick] (xioTechnologies/Gait-Tracking-With-x-IMU, Script.m), the
template the source paper's processing resembles [Heidari2019, §3]: on the accelerometer magnitude in g,

    m = ‖f‖ / g0;  m_hp = filtfilt(Butterworth high-pass 1st order, 0.001 Hz, m);  a = |m_hp|;
    T = filtfilt(Butterworth low-pass 1st order, 5 Hz, a);   stance ⇔ T < 0.05 (g)

Butterworth design via scipy.signal.butter (second-order sections) at the recording's median sample rate.
g0 = the gravity in use (x-io's script works in g of its sensor).

The 0.001 Hz high-pass is an offset removal (its time constant, 160 s, exceeds any walk): it is meant to
take out the 1 g the magnitude holds at rest. ``filtfilt`` starts each pass from the signal's end value,
so a recording cut in mid-stride (x-io's own spiral-stairs window, 4-47 s) gets the end sample's offset
instead, and nothing is stance (0.3 %). Here the high-pass filters m − m_rest (m_rest =
``_paper.rest_magnitude`` / g0) continued by one rest sample (0) at each end, so that each pass starts
from rest. Stance runs shorter than ``min_stance_s`` and swing gaps shorter than
``min_swing_s`` are cleaned as for the paper's detectors (``_paper``); the threshold stays x-io's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from bootnav.core.arrays import row_norm
from ._paper import PaperRule, rest_magnitude
from .base import POSITIVE, ThresholdDetector, register


def xio_statistic(acc_b: np.ndarray, dt: float, gravity: float, *, highpass_hz: float = 0.001,
                  lowpass_hz: float = 5.0) -> np.ndarray:
    """Filtered |‖f‖/g − 1| (N,), in g, both filters from rest (module docstring); the low-pass corner is
    capped at 0.45 fs."""
    from scipy.signal import butter, sosfiltfilt

    fs = 1.0 / dt
    m = row_norm(acc_b) / gravity
    if m.size < 16:
        return np.abs(m - 1.0)
    hp = butter(1, highpass_hz, btype="highpass", fs=fs, output="sos")
    lp = butter(1, min(lowpass_hz, 0.45 * fs), btype="lowpass", fs=fs, output="sos")
    rest = np.zeros(1)  # m − m_rest of a foot at rest
    m_hp = sosfiltfilt(hp, np.concatenate([rest, m - rest_magnitude(acc_b, dt) / gravity, rest]), padtype=None)[1:-1]
    return sosfiltfilt(lp, np.abs(m_hp))


@register("xio")
@dataclass(kw_only=True)
class XioDetector(PaperRule, ThresholdDetector):
    """x-io Gait-Tracking: band-filtered accelerometer magnitude, threshold in g [Madgwick]

    threshold: in g; default 0.05 g, x-io's published value [Madgwick].
    highpass_hz, lowpass_hz: corners of the two first-order Butterworth filters (x-io: 0.001 Hz, 5 Hz).
    min_stance_s, min_swing_s: 0.05 s and 0.2 s (x-io's script has none; without them x-io's spiral
        stairs split into 41 stance phases for 34 steps).
    """

    DEFAULT_THRESHOLD = 0.05
    BOUNDS: ClassVar[dict] = {"highpass_hz": POSITIVE, "lowpass_hz": POSITIVE}

    min_stance_s: float = 0.05
    min_swing_s: float = 0.2

    highpass_hz: float = 0.001
    lowpass_hz: float = 5.0

    def statistic(self, acc_b, gyro_b, dt):
        return xio_statistic(acc_b, dt, self.gravity_mps2, highpass_hz=self.highpass_hz, lowpass_hz=self.lowpass_hz)
