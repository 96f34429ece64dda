"""Pan–Tompkins step detector (ECG R-peak method applied to acceleration), [NKUA2009, §2.3] after
Ying et al. 2007 [13]: band-pass -> derivative -> squaring -> moving-window integration -> peak search.

    derivative  y(n) = (1/8) [2x(n) + x(n-1) - x(n-3) - 2x(n-4)]        ([NKUA2009, §2.3])
    squaring    y(n) = x(n)^2
    MWI         y(n) = (1/N) sum_{k=0..N-1} x(n-k),   N = 20             [literal]
    fiducial    code rises of the MWI output as +1 and falls as -1; a (+1,-1) pair is a hump; a gait
                cycle is two pairs [(1,-1),(1,-1)] (the rising and the falling slope of the acceleration
                each give one hump of the squared derivative); the step is the maximum of the ORIGINAL
                signal inside the SECOND pair's interval [literal].

Band-pass: the thesis' low-pass equation is unrecoverable [R]; default = 2nd-order Butterworth
0.5–5 Hz [engineered]; ``lowpass="pan_tompkins"`` uses the original integer low-pass
y(n) = 2y(n-1) - y(n-2) + x(n) - 2x(n-6) + x(n-12) (NOT confirmed by the text). fs 20 Hz, the rate of
the thesis' system ([NKUA2009, §6.2]; it states none for this method), so N = 20 spans 1 s and the
4-sample derivative 0.2 s. The literal hump coding pairs every sign change of the MWI output, so the rate
matters beyond the window length: at 50 Hz the shorter derivative passes more ripple and every step gets
extra humps, even with N = 50 (docs/tuning-log.md). ``literal=False`` additionally ignores humps lower than
``min_rel_height`` x the 5-s local maximum of the MWI output before pairing (Pan–Tompkins' adaptive
threshold, [engineered 0.2]), so noise wiggles do not shift the pairing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import butter_filter, magnitude, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents

DERIVATIVE_TAPS = np.array([2.0, 1.0, 0.0, -1.0, -2.0]) / 8.0


def pt_derivative(x: np.ndarray) -> np.ndarray:
    """y(n) = (2x(n) + x(n-1) - x(n-3) - 2x(n-4)) / 8 (causal FIR; impulse response DERIVATIVE_TAPS)."""
    from scipy import signal

    return signal.lfilter(DERIVATIVE_TAPS, [1.0], np.asarray(x, float))


def pt_lowpass_integer(x: np.ndarray) -> np.ndarray:
    """Original Pan–Tompkins low-pass (gain 36, delay 5 samples), normalised to unit DC gain."""
    from scipy import signal

    b = np.zeros(13)
    b[0], b[6], b[12] = 1.0, -2.0, 1.0
    return signal.lfilter(b, [1.0, -2.0, 1.0], np.asarray(x, float)) / 36.0


def mwi(x: np.ndarray, n: int) -> np.ndarray:
    """Moving-window integrator y(n) = (1/N) sum of the last N samples (causal)."""
    from scipy import signal

    return signal.lfilter(np.ones(n) / n, [1.0], np.asarray(x, float))


def humps(y: np.ndarray) -> list[tuple[int, int]]:
    """(+1,-1) pairs: [start of a rise, end of the following fall] index intervals of y."""
    d = np.sign(np.diff(y))
    d[d == 0] = 1
    change = np.nonzero(np.diff(d))[0] + 1
    seg_start = np.r_[0, change]
    seg_sign = d[seg_start]
    seg_end = np.r_[change, d.size]
    out = []
    for k in range(len(seg_start) - 1):
        if seg_sign[k] > 0 and seg_sign[k + 1] < 0:
            out.append((int(seg_start[k]), int(seg_end[k + 1])))
    return out


@register("pan_tompkins")
@dataclass
class PanTompkinsDetector(StepDetector):
    literal: bool = True
    fs_hz: float = 20.0
    lowpass: str = "butter"
    band_hz: tuple = (0.5, 5.0)
    mwi_n: int = 20
    min_rel_height: float = 0.2
    local_window_s: float = 5.0

    def detect(self, t_s, acc_b) -> StepEvents:
        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        x0 = magnitude(a)
        if self.lowpass == "pan_tompkins":
            x = pt_lowpass_integer(x0 - np.mean(x0))
            delay = 5
        else:
            x = butter_filter(x0, self.fs_hz, list(self.band_hz), "band", order=2)
            delay = 0
        y = mwi(pt_derivative(x) ** 2, self.mwi_n)
        delay += 2 + (self.mwi_n - 1) / 2.0  # derivative + MWI group delay, samples
        h = humps(y)
        if not self.literal and h:
            from scipy.ndimage import maximum_filter1d

            ref = maximum_filter1d(y, int(self.local_window_s * self.fs_hz))
            h = [(s, e) for s, e in h if y[s:e + 1].max() >= self.min_rel_height * ref[(s + e) // 2]]
        chosen = h[1::2]
        shift = int(round(delay))
        steps = []
        for s, e in chosen:
            a0, b0 = max(s - shift, 0), max(e - shift, 0) + 1
            if b0 - a0 >= 1:
                steps.append(a0 + int(np.argmax(x[a0:b0])))
        idx = np.unique(np.array(steps, int))
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": x, "signal_label": "filtered |a| (m/s^2)", "mwi": y})
