"""[Lazarevskiy2021] phone magnitude peak-group detector with the 1.2 g clamp, thesis §3.1.4–3.1.9.

    A_m = sqrt(Ax^2 + Ay^2 + Az^2)   in g                                    (eq. 3.1)
    clamp  A_c(i) = 1  if A_m(i) <= A_filter  else A_m(i),  A_filter = 1.2 g  (§3.1.5; the thesis prints
           "m/s^2" but the data are in g: the unit is a strong inference)
    candidates: local maxima of A_c (A_c(i+1) - A_c(i) < 0 after a rise); plateau = its LAST sample in
           literal mode, the middle otherwise
    groups: consecutive candidates closer than A_LocalPeaksStep belong to one step; main peak = highest
    steps: main peaks at least A_LocalDistancePeaks apart (tallest first, MATLAB MinPeakDistance)

The two coefficients have NO values in the thesis (hand-tuned per file with sliders). Defaults
[engineered]: A_LocalPeaksStep = 0.15 s, A_LocalDistancePeaks = 0.3 s (in seconds, converted
with the measured rate). Literal mode processes the rows as recorded (no resampling, no smoothing);
``literal=False`` resamples to 100 Hz and low-passes at 5 Hz (not in the thesis, off in faithful mode).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.peaks import local_maxima
from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import G0, butter_filter, clean_time, magnitude, nominal_rate_hz, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


def clamp(a_g: np.ndarray, a_filter: float = 1.2) -> np.ndarray:
    """A_c = 1 where A_m <= A_filter (inclusive), unchanged elsewhere (thesis §3.1.5)."""
    a = np.asarray(a_g, float).copy()
    a[a <= a_filter] = 1.0
    return a


def candidate_peaks(a: np.ndarray, plateau: str = "last") -> np.ndarray:
    """Local maxima: rise then fall; flat runs resolved to their last ('last') or middle sample."""
    return local_maxima(np.asarray(a, float), plateau)


def group_main_peaks(idx: np.ndarray, height: np.ndarray, gap: float) -> np.ndarray:
    """Split sorted candidate indices into groups at gaps > ``gap`` samples; return each group's highest."""
    if idx.size == 0:
        return idx
    br = np.r_[0, np.nonzero(np.diff(idx) > gap)[0] + 1, idx.size]
    return np.array([idx[a + int(np.argmax(height[a:b]))] for a, b in zip(br[:-1], br[1:])], int)


def min_distance_tallest_first(idx: np.ndarray, height: np.ndarray, dist: float) -> np.ndarray:
    keep = np.zeros(idx.size, bool)
    for i in np.argsort(-height, kind="stable"):
        if not np.any(keep & (np.abs(idx - idx[i]) < dist)):
            keep[i] = True
    return idx[keep]


@register("peak_group")
@dataclass
class PeakGroupDetector(StepDetector):
    literal: bool = True
    a_filter_g: float = 1.2
    local_peaks_step_s: float = 0.15
    local_distance_peaks_s: float = 0.3
    resample_hz: float = 100.0
    lowpass_hz: float = 5.0

    def detect(self, t_s, acc_b) -> StepEvents:
        if self.literal:
            t, a = np.asarray(t_s, float), np.asarray(acc_b, float)  # rows as recorded (faithful)
            fs = (t.size - 1) / (t[-1] - t[0]) if t.size > 1 and t[-1] > t[0] else 100.0  # effective rate of the rows
            am = magnitude(a) / G0
        else:
            t, a = resample_uniform(t_s, acc_b, self.resample_hz)
            fs = self.resample_hz
            am = butter_filter(magnitude(a) / G0, fs, self.lowpass_hz, "low", order=4)
        ac = clamp(am, self.a_filter_g)
        cand = candidate_peaks(ac, "last" if self.literal else "middle")
        cand = cand[ac[cand] > self.a_filter_g]
        main = group_main_peaks(cand, ac[cand], self.local_peaks_step_s * fs)
        steps = np.sort(min_distance_tallest_first(main, ac[main], self.local_distance_peaks_s * fs))
        return StepEvents(t[steps] if steps.size else np.zeros(0), self.name,
                          {"t_s": t, "signal": ac, "signal_label": "clamped |a| (g)", "magnitude_g": am,
                           "candidates_t_s": t[cand], "fs_hz": fs})
