"""FootPath step detector (Bitsch Link et al., IPIN 2011), as evaluated in [Bayindir2014].

    a_z low-passed by an exponential filter  y <- y + alpha (x - y), alpha = 0.5   [external: FootPath code]
    sampled at 30 Hz (zero-order hold, like the app timer)                           [literal 30 Hz]
    step at i if  hist[i-k] - hist[i] > threshold  for some k = 1..5                [literal 5; signed "drop"
                                                                                     as in the code]
    then detection disabled for 10 samples (= 0.333 s)                              [literal 10]

threshold: not in the paper; 1.5 m/s^2, chosen by leave-one-dataset-out over the developer PDR sets
(benchmarks/pdr_crossval.py, every fold picks 1.5 of 0.5-3) [engineered]; the FootPath code's 0.5 m/s^2
[external] is ``threshold_mps2=0.5``. The 10-sample lockout (0.33 s) is literal and shorter than a step
(0.54-0.56 s on the Oxford walks): a second drop in the same step re-triggers. ``mode="abs"`` uses |difference|
(what the Turkish wording literally allows). ``literal=True`` uses the device z axis (phone held flat,
screen up); ``literal=False`` the gravity-projected vertical (any orientation) [engineered].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors._axes import vertical_and_horizontal
from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import clean_time, ema, nominal_rate_hz, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


@register("footpath")
@dataclass
class FootPathDetector(StepDetector):
    literal: bool = True
    fs_hz: float = 30.0
    alpha: float = 0.5
    history: int = 5
    threshold_mps2: float = 1.5
    lockout_samples: int = 10
    mode: str = "drop"

    def detect(self, t_s, acc_b) -> StepEvents:
        t, a = clean_time(t_s, np.asarray(acc_b, float))
        fs_raw = nominal_rate_hz(t)
        v, _, _ = vertical_and_horizontal(a, fs_raw, "sensor" if self.literal else "gravity")
        y = ema(v, self.alpha)  # at the sensor rate, as the app's listener does
        tg, h = resample_uniform(t, y, self.fs_hz, hold=True)
        k = self.history
        d = np.full((h.size, k), -np.inf)
        for j in range(1, k + 1):
            d[j:, j - 1] = h[:-j] - h[j:]
        d = np.abs(d) if self.mode == "abs" else d
        cand = np.nonzero(np.max(d, axis=1) > self.threshold_mps2)[0]
        steps, nxt = [], -1
        for i in cand:  # lockout: a short loop over candidate samples only
            if i >= nxt:
                steps.append(i)
                nxt = i + self.lockout_samples + 1
        idx = np.array(steps, int)
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": h, "signal_label": "EMA-filtered a_z (m/s^2)"})
