"""Shared helpers of the stance detectors: sample rate, windows in seconds, centred moving means,
saturation / clipping masks. Vectorised with scipy.ndimage (no per-sample Python loop)."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_dilation, uniform_filter1d


def median_dt(t_s: np.ndarray) -> float:
    """Robust sample period (s): median of the positive intervals (duplicates and gaps ignored)."""
    dt = np.diff(np.asarray(t_s, dtype=np.float64))
    dt = dt[np.isfinite(dt) & (dt > 0)]
    if dt.size == 0:
        raise ValueError("timestamps have no positive interval; cannot derive the sample rate")
    return float(np.median(dt))


def window_samples(window_s: float, dt: float, minimum: int = 1) -> int:
    """Window length in samples for a window defined in seconds at the recording's own rate."""
    return max(minimum, int(round(window_s / dt)))


def moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over ``n`` samples along axis 0 (edges: nearest value repeated)."""
    return uniform_filter1d(np.asarray(x, dtype=np.float64), size=int(n), axis=0, mode="nearest")


def clipped_samples(x: np.ndarray, *, min_repeats: int = 3, rel_tol: float = 1e-6) -> np.ndarray:
    """Samples of an (N, k) signal that sit at a per-axis full-scale plateau (bool (N,)).

    A clipped axis repeats its extreme value exactly; an unclipped one reaches its extreme once or twice.
    Flags |x| >= (1 - rel_tol) * max|x| on an axis whose extreme is hit ``min_repeats`` times or more,
    but by less than half of the samples (a constant axis is not clipping).
    """
    x = np.abs(np.asarray(x, dtype=np.float64))
    peak = np.nanmax(x, axis=0)
    at_peak = x >= peak * (1.0 - rel_tol)
    count = at_peak.sum(axis=0)
    clipped_axes = (count >= min_repeats) & (count < 0.5 * x.shape[0])
    return np.any(at_peak & clipped_axes & (peak > 0), axis=1)


def saturation_mask(saturated, n: int) -> np.ndarray:
    """bool (N,) from None, a bool array or a uint8 bitmask (recording's ``saturated``)."""
    if saturated is None:
        return np.zeros(n, dtype=bool)
    s = np.asarray(saturated)
    if s.shape[0] != n:
        raise ValueError(f"saturated mask has {s.shape[0]} samples, the signal {n}")
    return s.astype(bool) if s.ndim == 1 else np.any(s.astype(bool), axis=1)


def dilate(mask: np.ndarray, n: int) -> np.ndarray:
    """Grow a bool mask by ``n`` samples on both sides."""
    if n <= 0 or not mask.any():
        return mask.copy()
    return binary_dilation(mask, structure=np.ones(2 * n + 1, dtype=bool))
