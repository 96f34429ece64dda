"""Template-matching step detector, [NKUA2009, §2.4] after Ying et al. 2007 [13].

    blocks of 10 s [literal]; low-pass 20 Hz [literal; only applied when fs > 40 Hz];
    NCC  R^_xy[k] = <X, Y_k> / (||X|| ||Y_k||)  (zero-mean segments), max 1           [literal]
    steps = local maxima of the signal inside the intervals where NCC >= ``ncc_threshold``
    template refresh: if the block's maximum NCC peaks are < 0.55, rebuild the template as the mean of the
    block's detected steps, aligned on their peaks                                         [literal 0.55]

Not given by the source [engineered]: the NCC detection threshold (0.6), the template length (one step
period from the autocorrelation of the first block, 0.3–1.2 s), the signal (band-passed |a| 0.3–5 Hz, so
any carrying position works; the thesis' figure uses one axis), fs 50 Hz, and the initial template
(the segment centred on the largest peak of the first block: "parameters are approximate at first"), and
a minimum peak height of 0.5 m/s^2 (standing still gives no steps).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import butter_filter, magnitude, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


def ncc(signal_x: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Normalised cross-correlation of a zero-mean template with every zero-mean window of x
    (centred on each sample; edges 0)."""
    from numpy.lib.stride_tricks import sliding_window_view

    m = template.size
    tz = template - template.mean()
    tn = np.linalg.norm(tz)
    out = np.zeros(signal_x.size)
    if signal_x.size < m or tn == 0:
        return out
    w = sliding_window_view(signal_x, m)
    wz = w - w.mean(axis=1, keepdims=True)
    r = wz @ tz / np.maximum(np.linalg.norm(wz, axis=1) * tn, 1e-12)
    out[m // 2:m // 2 + r.size] = r
    return out


def step_period_samples(x: np.ndarray, fs: float, lo_s: float = 0.3, hi_s: float = 1.2) -> int:
    """Lag of the autocorrelation maximum within [lo_s, hi_s]."""
    x = x - x.mean()
    r = np.correlate(x, x, mode="full")[x.size - 1:]
    lo, hi = int(lo_s * fs), min(int(hi_s * fs), r.size - 1)
    if hi <= lo:
        return int(0.55 * fs)
    return lo + int(np.argmax(r[lo:hi]))


@register("template")
@dataclass
class TemplateDetector(StepDetector):
    fs_hz: float = 50.0
    block_s: float = 10.0
    lowpass_hz: float = 20.0
    band_hz: tuple = (0.3, 5.0)
    ncc_threshold: float = 0.6
    refresh_below: float = 0.55
    min_interval_s: float = 0.25
    min_peak_mps2: float = 0.5

    def detect(self, t_s, acc_b) -> StepEvents:
        from scipy import signal

        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        m = magnitude(a)
        if self.fs_hz > 2 * self.lowpass_hz:
            m = butter_filter(m, self.fs_hz, self.lowpass_hz, "low", order=2)
        x = butter_filter(m, self.fs_hz, list(self.band_hz), "band", order=2)
        nb = int(self.block_s * self.fs_hz)
        template = None
        steps, r_all = [], np.zeros(x.size)
        for b0 in range(0, x.size, nb):
            blk = x[b0:b0 + nb]
            if blk.size < int(1.5 * self.fs_hz):
                continue
            if template is None:
                L = step_period_samples(blk, self.fs_hz)
                c = int(np.argmax(blk[L // 2: blk.size - L // 2])) + L // 2
                template = blk[c - L // 2:c - L // 2 + L].copy()
            r = ncc(blk, template)
            r_all[b0:b0 + blk.size] = r
            above = r >= self.ncc_threshold
            pk, _ = signal.find_peaks(np.where(above, blk, -np.inf), distance=max(1, int(self.min_interval_s * self.fs_hz)))
            pk = pk[above[pk] & (blk[pk] >= self.min_peak_mps2)]
            steps.extend((b0 + pk).tolist())
            rp, _ = signal.find_peaks(r)
            if (rp.size == 0 or np.max(r[rp]) < self.refresh_below) and pk.size >= 2:
                L = template.size
                segs = [blk[p - L // 2:p - L // 2 + L] for p in pk if p - L // 2 >= 0 and p - L // 2 + L <= blk.size]
                if segs:
                    template = np.mean(segs, axis=0)
        idx = np.unique(np.array(steps, int))
        return StepEvents(tg[idx] if idx.size else np.zeros(0), self.name,
                          {"t_s": tg, "signal": x, "signal_label": "band-passed |a| (m/s^2)", "ncc": r_all})
