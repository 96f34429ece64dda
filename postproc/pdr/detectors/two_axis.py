"""Combined 2-axis peak detector for a FOOT-mounted sensor, [NKUA2009, §2.5] after Ying et al. [13].

    1. band-pass each of two axes (X and Z of the sensor, as the thesis' figure names them)
    2. keep negative samples: n_k = min(x_k, 0)
    3. add: c = n_x + n_z
    4. moving-window integration (smoothing): s = MWI_N(c)
    5. square: p = s^2
    threshold = 1/4 max(p) [literal]; "peak detection intervals" = runs where p > threshold;
    step = the most negative sample of the ORIGINAL summed negative signal c inside each interval
    (the abrupt deceleration at ground contact; the thesis says "maximum of the original signal").

Not given by the source [engineered]: band 0.5–8 Hz, MWI 0.1 s, fs 100 Hz, axes (0, 2). Each
detection is one contact of the instrumented foot (a stride).

Quirk (literal): push-off gives a second, smaller hump above 1/4 max in every stride (Voisard foot IMUs:
about +50 % contacts). ``literal=False`` keeps only the larger of two intervals closer than
``min_interval_s`` = 0.6 s (one foot's stride lasts > 0.7 s even when running) [engineered].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.runs import runs
from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import butter_filter, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


@register("two_axis")
@dataclass
class TwoAxisFootDetector(StepDetector):
    fs_hz: float = 100.0
    axes: tuple = (0, 2)
    band_hz: tuple = (0.5, 8.0)
    mwi_s: float = 0.1
    threshold_fraction: float = 0.25
    literal: bool = True
    min_interval_s: float = 0.6

    def detect(self, t_s, acc_b) -> StepEvents:
        from scipy import signal

        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        c = np.zeros(tg.size)
        for k in self.axes:
            c += np.minimum(butter_filter(a[:, k], self.fs_hz, list(self.band_hz), "band", order=2), 0.0)
        n = max(1, int(round(self.mwi_s * self.fs_hz)))
        s = signal.filtfilt(np.ones(n) / n, [1.0], c) if c.size > 3 * n else c
        p = s ** 2
        thr = self.threshold_fraction * (p.max() if p.size else 0.0)
        starts, ends = runs(p > thr)
        idx = np.array([s0 + int(np.argmin(c[s0:e0])) for s0, e0 in zip(starts, ends) if e0 > s0], int)
        if not self.literal and idx.size:
            size = np.array([p[s0:e0].max() for s0, e0 in zip(starts, ends) if e0 > s0])
            keep = np.zeros(idx.size, bool)
            gap = self.min_interval_s * self.fs_hz
            for i in np.argsort(-size, kind="stable"):  # larger humps first
                if not np.any(keep & (np.abs(idx - idx[i]) < gap)):
                    keep[i] = True
            idx = idx[keep]
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": p, "signal_label": "combined (squared) signal", "threshold": thr})
