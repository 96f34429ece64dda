"""Signal helpers shared by every PDR method: uniform resampling, moving averages, filters, magnitudes.

Phones deliver event-driven samples (duplicates, gaps, jitter; as in the Oxford step-counting recordings
and the phone data of [Lazarevskiy2021]), while every source method is defined at a fixed rate (20 Hz
[NKUA2009], 30/50 Hz [Bayindir2014, Table 1], ~100 Hz [Lazarevskiy2021]). ``resample_uniform`` is the one
place where the raw clock is turned into such a grid.
"""

from __future__ import annotations

import numpy as np

from bootnav.core.conventions import STANDARD_GRAVITY_MPS2

G0 = STANDARD_GRAVITY_MPS2  # standard gravity, m/s^2 (bootnav.core.conventions)


def clean_time(t_s: np.ndarray, *arrays: np.ndarray):
    """Sort by time and drop repeated timestamps (keep the LAST row of each time: sample-and-hold rows
    repeat older values, the last one is the newest). Returns (t_s, *arrays) without non-finite times."""
    t_s = np.asarray(t_s, dtype=float)
    ok = np.isfinite(t_s)
    order = np.argsort(t_s[ok], kind="stable")
    t = t_s[ok][order]
    arrs = [np.asarray(a)[ok][order] for a in arrays]
    keep = np.ones(t.size, bool)
    keep[:-1] = np.diff(t) > 0
    return (t[keep], *[a[keep] for a in arrs])


def resample_uniform(t_s: np.ndarray, x: np.ndarray, fs_hz: float, hold: bool = False):
    """Resample ``x`` (N,) or (N, k) onto a uniform grid ``t0 + n/fs`` (linear interpolation, or
    zero-order hold with ``hold=True``, which mimics an app timer sampling the latest value).

    Returns (t_grid, x_grid)."""
    t, x = clean_time(t_s, np.asarray(x, dtype=float))
    if t.size < 2:
        raise ValueError("need at least two samples with distinct times to resample")
    n = int(np.floor((t[-1] - t[0]) * fs_hz)) + 1
    tg = t[0] + np.arange(n) / fs_hz
    if hold:
        idx = np.clip(np.searchsorted(t, tg, side="right") - 1, 0, t.size - 1)
        return tg, x[idx]
    if x.ndim == 1:
        return tg, np.interp(tg, t, x)
    return tg, np.column_stack([np.interp(tg, t, x[:, k]) for k in range(x.shape[1])])


def nominal_rate_hz(t_s: np.ndarray) -> float:
    """1 / median positive sample interval."""
    dt = np.diff(np.asarray(t_s, float))
    dt = dt[np.isfinite(dt) & (dt > 0)]
    return float(1.0 / np.median(dt)) if dt.size else float("nan")


def magnitude(acc: np.ndarray) -> np.ndarray:
    """[Bayindir2014, eq. 1] / [Lazarevskiy2021, eq. 3.1]: a = sqrt(ax^2 + ay^2 + az^2)."""
    return np.linalg.norm(np.asarray(acc, float), axis=1)


def causal_moving_average(x: np.ndarray, n: int) -> np.ndarray:
    """Causal mean of the last ``n`` samples including the current one ([NKUA2009, §3.1], documented
    form); the first n-1 outputs average the samples available so far."""
    x = np.asarray(x, float)
    c = np.cumsum(np.insert(x, 0, 0.0))
    idx = np.arange(1, x.size + 1)
    lo = np.maximum(idx - n, 0)
    return (c[idx] - c[lo]) / (idx - lo)


def centered_moving_average(x: np.ndarray, n: int) -> np.ndarray:
    """Zero-lag moving average of ``n`` samples (edges use the samples available)."""
    x = np.asarray(x, float)
    k = np.ones(n)
    num = np.convolve(x, k, mode="same")
    den = np.convolve(np.ones_like(x), k, mode="same")
    return num / den


def butter_filter(x: np.ndarray, fs_hz: float, cutoff_hz, btype: str = "low", order: int = 2,
                  zero_phase: bool = True) -> np.ndarray:
    """Butterworth filter (scipy SOS), zero-phase by default (offline post-processing)."""
    from scipy import signal

    sos = signal.butter(order, cutoff_hz, btype=btype, fs=fs_hz, output="sos")
    x = np.asarray(x, float)
    if zero_phase:
        padlen = min(3 * (2 * sos.shape[0] + 1), x.shape[0] - 1)
        return signal.sosfiltfilt(sos, x, axis=0, padlen=max(padlen, 0))
    return signal.sosfilt(sos, x, axis=0)


def ema(x: np.ndarray, alpha: float) -> np.ndarray:
    """Exponential filter y <- y + alpha (x - y) (FootPath's low-pass as [Bayindir2014] evaluates it)."""
    from scipy import signal

    x = np.asarray(x, float)
    if x.ndim > 1:
        return np.column_stack([ema(x[:, k], alpha) for k in range(x.shape[1])])
    # y[n] = alpha x[n] + (1 - alpha) y[n-1], started at y[-1] = x[0] (no start-up transient)
    y, _ = signal.lfilter([alpha], [1.0, alpha - 1.0], x, zi=[(1.0 - alpha) * x[0]])
    return y


def gravity_direction(acc: np.ndarray, fs_hz: float, cutoff_hz: float = 0.3) -> np.ndarray:
    """Unit gravity ("up") direction in the body frame per sample: low-passed specific force, normalised
    ([Lazarevskiy2021, §2.2]: "the mean acceleration vector is approximately the gravity vector")."""
    lp = butter_filter(acc, fs_hz, cutoff_hz, "low", order=2)
    return lp / np.maximum(np.linalg.norm(lp, axis=1, keepdims=True), 1e-9)


def vertical_acc(acc: np.ndarray, fs_hz: float, cutoff_hz: float = 0.3) -> np.ndarray:
    """Specific force projected on the local "up" direction (orientation-independent vertical axis)."""
    up = gravity_direction(acc, fs_hz, cutoff_hz)
    return np.einsum("ij,ij->i", np.asarray(acc, float), up)
