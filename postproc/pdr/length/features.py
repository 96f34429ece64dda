"""Per-step features for the step-length models (computed once, shared by every model).

Step i runs from t_start_i = t_{i-1} to t_end_i = t_i (bootnav.postproc.pdr.steps.step_intervals).
    freq_hz      f_i = 1 / (t_end_i - t_start_i)            ([Bayindir2014] leaves f undefined; 1 / step duration)
    vert_range   A_max - A_min of the vertical specific force within the step, m/s^2 ([NKUA2009, §5.2];
                 vertical = projection on the low-passed gravity direction, so any mounting works)
    mag_std      sqrt((1/N) sum (a(i) - a_m)^2) of |a| within the step, m/s^2  ([Bayindir2014, eq. 5])
    mag_var      mag_std^2, m^2/s^4
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.signals import butter_filter, magnitude, resample_uniform, vertical_acc
from bootnav.postproc.pdr.steps import step_intervals


@dataclass
class StepFeatures:
    t_s: np.ndarray
    t_start_s: np.ndarray
    freq_hz: np.ndarray
    vert_range_mps2: np.ndarray
    mag_std_mps2: np.ndarray

    @property
    def mag_var(self) -> np.ndarray:
        return self.mag_std_mps2 ** 2

    def __len__(self) -> int:
        return int(self.t_s.size)


def step_features(t_steps, t_s, acc_b, fs_hz: float = 50.0, lowpass_hz: float = 5.0,
                  max_step_s: float = 1.5) -> StepFeatures:
    t_steps = np.asarray(t_steps, float)
    t0, t1 = step_intervals(t_steps, max_step_s)
    if t_steps.size == 0:
        z = np.zeros(0)
        return StepFeatures(z, z, z, z, z)
    tg, a = resample_uniform(t_s, acc_b, fs_hz)
    a = butter_filter(a, fs_hz, lowpass_hz, "low", order=2)
    v = vertical_acc(a, fs_hz)
    m = magnitude(a)
    i0 = np.clip(np.searchsorted(tg, t0), 0, tg.size - 1)
    i1 = np.clip(np.searchsorted(tg, t1, side="right"), 1, tg.size)
    vr = np.array([np.ptp(v[a_:b_]) if b_ > a_ else 0.0 for a_, b_ in zip(i0, i1)])
    ms = np.array([np.std(m[a_:b_]) if b_ > a_ else 0.0 for a_, b_ in zip(i0, i1)])
    return StepFeatures(t_steps, t0, 1.0 / np.maximum(t1 - t0, 1e-3), vr, ms)
