"""Leppäkoski et al. (ICASSP 2012) step detector, as evaluated in [Bayindir2014, Table 1].

    each axis low-passed (1st order) then a[i] = ||LPF(f)[i]||             [literal: order 1, filter first]
    start candidates: upward crossings of g by a                           [literal]
    valid if within ``timeout`` after the crossing, and before the next up-crossing, both
        a[i] - g > peak_thr            (1.7 m/s^2)                          [literal value; "relative to g"
                                                                             is an inference]
        (a[i] - a[i-1]) fs > rise_thr  (10 m/s^3)                           [literal]
    timeout 0.9 s, fs 30 Hz                                                 [literal]
    (whether both must hold at the same sample is not said: ``same_sample`` option, default False)
    step i runs from its accepted crossing to the next accepted crossing.

"Before the next up-crossing" (``own_crossing``): an up-crossing is a step START candidate, so a peak
validates only the candidate it follows; letting it also validate the crossing before it (the window
reaching past a new start) counts a step twice wherever |a| crosses g twice per step, as a phone in a
pocket does (1.49 crossings per true step on the Oxford pockets). ``own_crossing=False`` keeps that
earlier reading.
Cut-off: not given; 4 Hz (1st-order Butterworth), chosen by leave-one-dataset-out over the developer
PDR sets (benchmarks/pdr_crossval.py, every fold picks 4 Hz) [engineered]. g: 9.80665 in literal mode;
``literal=False`` uses the recording's median |a| (sensors read 9.6–10.4 m/s^2 at rest, see the
datasets' READMEs) [engineered].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import G0, butter_filter, magnitude, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


@register("leppakoski")
@dataclass
class LeppakoskiDetector(StepDetector):
    literal: bool = True
    fs_hz: float = 30.0
    cutoff_hz: float = 4.0
    filter_order: int = 1
    peak_thr_mps2: float = 1.7
    rise_rate_thr_mps3: float = 10.0
    timeout_s: float = 0.9
    g_mps2: float = G0
    same_sample: bool = False  # both conditions at one sample instead of anywhere within the timeout
    own_crossing: bool = True  # conditions must be met before the next up-crossing (a new start candidate)

    def detect(self, t_s, acc_b) -> StepEvents:
        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        lp = butter_filter(a, self.fs_hz, self.cutoff_hz, "low", order=self.filter_order, zero_phase=False)
        n = magnitude(lp)
        g = self.g_mps2 if self.literal else float(np.median(n))
        cross = np.nonzero((n[:-1] < g) & (n[1:] >= g))[0] + 1
        rise = np.r_[0.0, np.diff(n)] * self.fs_hz
        w = int(round(self.timeout_s * self.fs_hz))
        steps = []
        nxt = np.r_[cross[1:], n.size]
        for c, c2 in zip(cross, nxt):
            seg = slice(c, min(c + w + 1, n.size, c2 if self.own_crossing else n.size))
            peak_ok = n[seg] - g > self.peak_thr_mps2
            rise_ok = rise[seg] > self.rise_rate_thr_mps3
            if (np.any(peak_ok & rise_ok) if self.same_sample else (np.any(peak_ok) and np.any(rise_ok))):
                steps.append(c)
        idx = np.array(steps, int)
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": n - g, "signal_label": "|LPF(a)| - g (m/s^2)"})
