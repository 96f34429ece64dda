"""Leppäkoski et al. (ICASSP 2012) step detector, as evaluated in seed-002 §1.2, Table 1, §7.2(b).

    each axis low-passed (1st order) then a[i] = ||LPF(f)[i]||             [literal: order 1, filter first]
    start candidates: upward crossings of g by a                           [literal]
    valid if within ``timeout`` after the crossing both
        a[i] - g > peak_thr            (1.7 m/s^2)                          [literal value; "relative to g"
                                                                             is the digest's inference]
        (a[i] - a[i-1]) fs > rise_thr  (10 m/s^3)                           [literal]
    timeout 0.9 s, fs 30 Hz                                                 [literal]
    (whether both must hold at the same sample is not said: ``same_sample`` option, default False)
    step i runs from its accepted crossing to the next accepted crossing.

Cut-off: not given; 3 Hz (1st-order Butterworth) [engineered, seed-002 §7.6]. g: 9.80665 in literal mode;
``literal=False`` uses the recording's median |a| (sensors read 9.6–10.4 m/s^2 at rest, see the
datasets' READMEs) [engineered].
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from bootnav.postproc.pdr.signals import G0, butter_filter, magnitude, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


@dataclass
class LeppakoskiDetector:
    literal: bool = True
    fs_hz: float = 30.0
    cutoff_hz: float = 3.0
    filter_order: int = 1
    peak_thr_mps2: float = 1.7
    rise_rate_thr_mps3: float = 10.0
    timeout_s: float = 0.9
    g_mps2: float = G0
    same_sample: bool = False  # both conditions at one sample instead of anywhere within the timeout

    name = "leppakoski"

    def to_dict(self) -> dict:
        return asdict(self)

    def detect(self, t_s, acc_b) -> StepEvents:
        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        lp = butter_filter(a, self.fs_hz, self.cutoff_hz, "low", order=self.filter_order, zero_phase=False)
        n = magnitude(lp)
        g = self.g_mps2 if self.literal else float(np.median(n))
        cross = np.nonzero((n[:-1] < g) & (n[1:] >= g))[0] + 1
        rise = np.r_[0.0, np.diff(n)] * self.fs_hz
        w = int(round(self.timeout_s * self.fs_hz))
        steps = []
        for c in cross:
            seg = slice(c, min(c + w + 1, n.size))
            peak_ok = n[seg] - g > self.peak_thr_mps2
            rise_ok = rise[seg] > self.rise_rate_thr_mps3
            if (np.any(peak_ok & rise_ok) if self.same_sample else (np.any(peak_ok) and np.any(rise_ok))):
                steps.append(c)
        idx = np.array(steps, int)
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": n - g, "signal_label": "|LPF(a)| - g (m/s^2)"})
