"""Li et al. (UbiComp 2012) step detector, as evaluated in [Bayindir2014, Table 1].

    a = ||f||, then FIR low-pass: order 30 (31 taps), cut-off 3 Hz, fs 50 Hz             [literal]
        (Hamming firwin [engineered]; causal as on the phone, times corrected by the 15-sample group delay)
    peaks of a - g with prominence >= 2 m/s^2 and spacing >= 0.3 s (scipy find_peaks)   [literal values]
        The paper's "minimum peak magnitude" may be the height above g or the prominence; it does not say.
        Prominence is the reading chosen by the rule used for every open value (leave-one-dataset-out over
        the developer PDR sets, ``benchmarks/pdr_crossval.py``, docs/tuning-log.md); ``peak_mode="height"``
        is the other reading.
    steps = segments between consecutive surviving peaks; keep step i if
        duration <= 1 s  and  0.2 g <= max - min of a within the step <= 2 g             [literal]
    DTW check: keep S_i if DTW(S_i, S_{i-2}) <= 3 or DTW(S_i, S_{i+2}) <= 3              [literal threshold]
        DTW = L1 local cost, cumulative cost divided by the warping-path length
        [the paper does not define it; ``dtw_norm="znorm"`` z-normalises the segments first, ``"none"`` uses
        (approximately) the total cost; the same rule keeps the per-sample cost, which "znorm" ties and
        "none" is far worse than]; steps without a neighbour at +-2 are kept.
    g = 9.8 (the paper's value) in literal mode; ``literal=False``: g = median |a| of the recording
    [engineered].
A rejected step removes its END peak from the count (the paper does not say) [engineered].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.postproc.pdr.detectors.base import StepDetector, register
from bootnav.postproc.pdr.signals import magnitude, resample_uniform
from bootnav.postproc.pdr.steps import StepEvents


def dtw_distance(a: np.ndarray, b: np.ndarray) -> float:
    """DTW with |a_i - b_j| local cost, normalised by the length of the optimal warping path."""
    if a.size == 0 or b.size == 0:
        return float("inf")
    return float(_dtw_kernel()(np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)))


_KERNEL = None


def _path_length(n: int, m: int) -> int:
    """Lower bound used to convert back to a total cost when dtw_norm == "none": max(n, m)."""
    return max(n, m)


def _dtw_kernel():
    """numba-compiled O(n m) recursion (compiled lazily so importing stays fast)."""
    global _KERNEL
    if _KERNEL is None:
        import numba

        @numba.njit(cache=True)
        def kernel(a, b):
            n, m = a.size, b.size
            D = np.full((n + 1, m + 1), np.inf)
            L = np.zeros((n + 1, m + 1))
            D[0, 0] = 0.0
            for i in range(1, n + 1):
                for j in range(1, m + 1):
                    best, pi, pj = D[i - 1, j - 1], i - 1, j - 1
                    if D[i - 1, j] < best:
                        best, pi, pj = D[i - 1, j], i - 1, j
                    if D[i, j - 1] < best:
                        best, pi, pj = D[i, j - 1], i, j - 1
                    D[i, j] = abs(a[i - 1] - b[j - 1]) + best
                    L[i, j] = L[pi, pj] + 1
            return D[n, m] / L[n, m]

        _KERNEL = kernel
    return _KERNEL


@register("li")
@dataclass
class LiDetector(StepDetector):
    literal: bool = True
    fs_hz: float = 50.0
    fir_order: int = 30
    cutoff_hz: float = 3.0
    min_peak_mps2: float = 2.0
    min_peak_interval_s: float = 0.3
    max_step_s: float = 1.0
    min_change_g: float = 0.2
    max_change_g: float = 2.0
    dtw_threshold: float = 3.0
    use_dtw: bool = True
    g_mps2: float = 9.8
    zero_phase: bool = False  # filtfilt instead of the phone's causal filter
    dtw_norm: str = "path_length"  # "path_length", "none" or "znorm" (z-normalised segments)
    peak_mode: str = "prominence"  # or "height" (above g): the paper's open reading (module docstring)

    def __post_init__(self):
        if self.peak_mode not in ("prominence", "height"):
            raise ValueError(f"peak_mode {self.peak_mode!r}: choose prominence or height")
        if self.dtw_norm not in ("path_length", "none", "znorm"):
            raise ValueError(f"dtw_norm {self.dtw_norm!r}: choose path_length, none or znorm")

    def _dtw(self, a, b) -> float:
        d = dtw_distance(a, b)
        if self.dtw_norm == "none":  # undo the path-length normalisation: total cost
            return d * _path_length(a.size, b.size)
        return d

    def detect(self, t_s, acc_b) -> StepEvents:
        from scipy import signal

        tg, a = resample_uniform(t_s, acc_b, self.fs_hz)
        n = magnitude(a)
        taps = signal.firwin(self.fir_order + 1, self.cutoff_hz, fs=self.fs_hz)
        d = self.fir_order // 2
        if self.zero_phase:
            f = signal.filtfilt(taps, [1.0], n)
        else:
            # causal FIR as on the phone; linear phase, so removing the d-sample delay aligns it with the input
            f = signal.lfilter(taps, [1.0], np.r_[n, np.full(d, n[-1])])[d:]
        g = self.g_mps2 if self.literal else float(np.median(n))
        crit = {self.peak_mode: self.min_peak_mps2}
        pk, _ = signal.find_peaks(f - g, distance=max(1, int(round(self.min_peak_interval_s * self.fs_hz))), **crit)
        if pk.size == 0:
            return StepEvents(np.zeros(0), self.name, {"t_s": tg, "signal": f - g})
        keep = np.ones(pk.size, bool)
        for i in range(1, pk.size):
            dur = (pk[i] - pk[i - 1]) / self.fs_hz
            seg = f[pk[i - 1]:pk[i] + 1]
            rng = seg.max() - seg.min()
            # a step longer than max_step is the first of a new bout: its end peak stays (boundary)
            if dur <= self.max_step_s and not (self.min_change_g * g <= rng <= self.max_change_g * g):
                keep[i] = False
        if self.use_dtw and pk.size >= 3:
            segs = [f[pk[i - 1]:pk[i] + 1] for i in range(1, pk.size)]
            if self.dtw_norm == "znorm":
                segs = [(x - x.mean()) / (x.std() + 1e-9) for x in segs]
            ok = np.ones(len(segs), bool)
            for i, s in enumerate(segs):
                nb = [j for j in (i - 2, i + 2) if 0 <= j < len(segs)]
                if nb:
                    ok[i] = any(self._dtw(s, segs[j]) <= self.dtw_threshold for j in nb)
            keep[1:] &= ok
        idx = pk[keep]
        return StepEvents(tg[idx], self.name, {"t_s": tg, "signal": f - g, "signal_label": "LPF |a| - g (m/s^2)"})
