"""[NKUA2009, §2.2] zero-crossing detector: a step each time the filtered vertical acceleration goes
from negative to positive, with the §2.1 false-step checks.

    f = MA_8(a_v) - mean_local(a_v)        (8-sample moving average as §3.1; gravity removed)
    step at n  if  f[n-1] < 0 <= f[n]  and  n - n_prev >= min_interval  and  range(a_v over the step) >= min_range

The source gives NO numbers for this method ([NKUA2009, §2.2] gives no numeric parameter). Defaults:
fs 20 Hz, MA 8 and the 0.20 g range gate are borrowed from the same thesis' ch.6 system [literal there];
gravity removal by a 2-s centred mean and the 0.25 s minimum interval are ENGINEERED. ``literal=True``
uses the sensor z axis (belt mount); ``literal=False`` the gravity-projected vertical.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors._axes import to_unit, vertical_and_horizontal
from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import causal_moving_average, centered_moving_average, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


@register("zero_crossing")
@dataclass
class ZeroCrossingDetector(StepDetector):
    literal: bool = True
    fs_hz: float = 20.0
    n_ma: int = 8
    mean_window_s: float = 2.0
    min_interval_s: float = 0.25
    min_range: float = 0.20
    acc_unit: str = "g"

    def detect(self, t_s, acc_b) -> StepEvents:
        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        v, _, _ = vertical_and_horizontal(a, self.fs_hz, "sensor" if self.literal else "gravity")
        v = to_unit(v, self.acc_unit)
        f = causal_moving_average(v, self.n_ma)
        f = f - centered_moving_average(v, max(3, int(self.mean_window_s * self.fs_hz)))
        cross = np.nonzero((f[:-1] < 0) & (f[1:] >= 0))[0] + 1
        steps, prev = [], -10**9
        min_gap = int(round(self.min_interval_s * self.fs_hz))
        for n in cross:
            if n - prev < min_gap:
                continue
            seg = v[max(prev, n - 2 * min_gap * 2, 0):n + 1]
            if seg.size and seg.max() - seg.min() >= self.min_range:
                steps.append(n)
                prev = n
        idx = np.array(steps, int)
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": f, "signal_label": f"filtered vertical acc - mean ({self.acc_unit})"})
