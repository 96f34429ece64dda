"""Gait cycle: one foot's stride period from the autocorrelation of ‖ω‖ (``gait_period``), and the same from a
record pushed in chunks (``GaitPeriodAccumulator``); see ``bootnav.postproc.selftune``."""

from __future__ import annotations

import numpy as np

from bootnav.core.arrays import row_norm
from bootnav.core.peaks import local_maxima
from bootnav.core.timebase import sample_period

#: lag range (s) searched for a stride period (one definition for the whole-record and the chunked estimate)
PERIOD_MIN_S, PERIOD_MAX_S = 0.4, 3.0


def gait_period(t_s: np.ndarray, gyro_b: np.ndarray, min_s: float = PERIOD_MIN_S,
                max_s: float = PERIOD_MAX_S) -> float:
    """One foot's stride period (s) from the autocorrelation of ‖ω‖, or NaN without a periodic gait.

    Parameters
    ----------
    t_s : (N,) sample times, s.
    gyro_b : (N, 3) angular rate, rad/s.
    min_s, max_s : lag range searched (s).

    Returns
    -------
    The lag of the highest autocorrelation peak in [min_s, max_s] whose normalised value is >= 0.2; NaN
    when there is none (no motion, or motion without a rhythm).
    """
    dt = sample_period(t_s)
    w = row_norm(gyro_b)
    w = w - w.mean()
    n = len(w)
    if n < 4 or not np.any(w):
        return float("nan")
    from scipy.fft import irfft, next_fast_len, rfft

    m = next_fast_len(2 * n, real=True)  # zero padding >= n: the circular correlation is the linear one
    f = rfft(w, m)
    ac = irfft(f * np.conj(f), m)[:n]
    return _period_from_autocorrelation(ac, n, dt, min_s, max_s)


def _period_from_autocorrelation(ac: np.ndarray, n: int, dt: float, min_s: float, max_s: float) -> float:
    """``gait_period``'s choice from the autocorrelation ``ac`` (lags 0, 1, ... at least up to ``max_s``) of a
    signal of ``n`` samples: the highest normalised peak >= 0.2 in [min_s, max_s], s; NaN without one."""
    ac = ac / ac[0]
    lo, hi = int(min_s / dt), min(int(max_s / dt), n - 1)
    if hi <= lo + 2:
        return float("nan")
    peaks = local_maxima(ac[lo:hi])
    peaks = peaks[ac[lo:hi][peaks] >= 0.2]
    if peaks.size == 0:
        return float("nan")
    return float((lo + peaks[np.argmax(ac[lo:hi][peaks])]) * dt)


def _convolve_full(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The full linear convolution of two non-empty 1-D float arrays by FFT: ``scipy.signal.fftconvolve(a, b)``
    bit for bit (its steps: real FFTs of the next fast length, product, inverse, cut), without importing
    ``scipy.signal`` (0.3 s of CPU at the start of every run)."""
    from scipy import fft

    if len(a) == 1 or len(b) == 1:  # fftconvolve multiplies along an axis of length 1
        return a * b
    n = len(a) + len(b) - 1
    f = [fft.next_fast_len(n, True)]
    return fft.irfftn(fft.rfftn(a, f, axes=[0]) * fft.rfftn(b, f, axes=[0]), f, axes=[0])[:n].copy()


class GaitPeriodAccumulator:
    """``gait_period`` of a record pushed in consecutive chunks, at a given sample period (bounded memory: the
    last ``max_s`` of samples and one sum per lag).

    The autocorrelation of w = ‖ω‖ − mean is expanded in sums of the raw x = ‖ω‖, so the mean need not be
    known beforehand: Σᵢ wᵢ wᵢ₊ₗ = Sₗ − μ (Σ x − tailₗ + Σ x − headₗ) + (n − l) μ², with Sₗ = Σᵢ xᵢ xᵢ₊ₗ
    accumulated chunk by chunk (each chunk's products with the carried tail) and headₗ, tailₗ the sums of the
    first and last l samples. Equal to ``gait_period``'s to rounding, given the same sample period."""

    def __init__(self, dt_s: float, min_s: float = PERIOD_MIN_S, max_s: float = PERIOD_MAX_S):
        self.dt, self.min_s, self.max_s = float(dt_s), float(min_s), float(max_s)
        self.lags = int(max_s / self.dt) + 1
        self._s = np.zeros(self.lags)
        self._tail = np.zeros(0)
        self._head = np.zeros(0)
        self._sum = 0.0
        self._n = 0

    def push(self, gyro_b: np.ndarray) -> None:
        """The angular rate of the next samples, rad/s (m, 3)."""
        x = row_norm(np.asarray(gyro_b, float))
        m = len(x)
        if m == 0:
            return
        z = np.concatenate((self._tail, x))
        c = len(self._tail)
        # S_l += sum over the new samples j of z[j] z[j - l]: the correlation of z with the new part
        full = _convolve_full(z, x[::-1])  # full[(m - 1) + k] = sum_j x[j] z[j + k]
        for_lag = full[m - 1 + c - np.arange(self.lags)] if c + m - self.lags >= 0 else None
        if for_lag is None:  # fewer samples than lags so far: the direct sums
            for lag in range(min(self.lags, c + m)):
                j = np.arange(max(c, lag), c + m)
                self._s[lag] += float(np.dot(z[j], z[j - lag]))
        else:
            valid = c - np.arange(self.lags) >= -(m - 1)
            self._s[valid] += for_lag[valid]
        if len(self._head) < self.lags:
            self._head = np.concatenate((self._head, x[: self.lags - len(self._head)]))
        self._tail = z[-self.lags:]
        self._sum += float(x.sum())
        self._n += m

    def finish(self) -> float:
        """The gait period, s (NaN without a periodic gait)."""
        n = self._n
        if n < 4:
            return float("nan")
        mu = self._sum / n
        lag = np.arange(min(self.lags, n))
        head = np.concatenate(([0.0], np.cumsum(self._head)))[lag]
        tail = np.concatenate(([0.0], np.cumsum(self._tail[::-1])))[lag]
        ac = self._s[lag] - mu * (2 * self._sum - tail - head) + (n - lag) * mu * mu
        if not ac[0] > 1e-12 * max(self._s[0], 1e-300):  # a constant rate: no rhythm
            return float("nan")
        return _period_from_autocorrelation(ac, n, self.dt, self.min_s, self.max_s)
