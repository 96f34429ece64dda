"""Shared helpers of the stance detectors: sample rate, windows in seconds, centred moving means,
saturation / clipping masks. Vectorised with scipy.ndimage (no per-sample Python loop); scipy is imported
where it is used, so that importing the detector registry stays light (``bootnav process --help``)."""

from __future__ import annotations

import numpy as np

from bootnav.core.timebase import sample_period


def as_imu_arrays(t_s, acc_b, gyro_b) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """float64 arrays t_s (N,), acc_b (N, 3), gyro_b (N, 3); ValueError naming the shapes otherwise."""
    t_s = np.asarray(t_s, dtype=np.float64)
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    n_samples = t_s.shape[0]
    if acc_b.shape != (n_samples, 3) or gyro_b.shape != (n_samples, 3):
        raise ValueError(f"expected acc_b and gyro_b of shape ({n_samples}, 3); got {acc_b.shape}, {gyro_b.shape}")
    return t_s, acc_b, gyro_b


median_dt = sample_period  # the one definition lives in bootnav.core.timebase


def window_samples(window_s: float, dt: float, minimum: int = 1) -> int:
    """Window length in samples for a window defined in seconds at the recording's own rate."""
    return max(minimum, int(round(window_s / dt)))


def moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving mean over ``n`` samples along axis 0 (edges: nearest value repeated)."""
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(np.asarray(x, dtype=np.float64), size=int(n), axis=0, mode="nearest")


def clipped_samples(x: np.ndarray, *, min_repeats: int = 3, rel_tol: float = 1e-6) -> np.ndarray:
    """Samples of an (N, k) signal that sit at a per-axis full-scale plateau (bool (N,)).

    A clipped axis repeats its extreme value exactly; an unclipped one reaches its extreme once or twice.
    Each sign is tested on its own, because the two rails of a two's-complement sensor differ by one LSB
    (MPU6050: −32768 and +32767 counts, i.e. 3e-5 relative — more than ``rel_tol``): flags
    x >= (1 − rel_tol) max x (and likewise x <= (1 − rel_tol) min x) on an axis whose extreme on that side
    is hit ``min_repeats`` times or more, but by less than half of the samples (a constant axis is not
    clipping), and is not exceeded in magnitude by the other side (a full-scale range is symmetric: a
    plateau below the opposite extreme is a repeated value, e.g. a duplicated row, not a rail).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    out = np.zeros(x.shape[0], dtype=bool)
    pos_peak = np.nanmax(x, axis=0)
    neg_peak = -np.nanmin(x, axis=0)
    for y, peak, other in ((x, pos_peak, neg_peak), (-x, neg_peak, pos_peak)):
        at_peak = y >= peak * (1.0 - rel_tol)
        count = at_peak.sum(axis=0)
        rail = (count >= min_repeats) & (count < 0.5 * x.shape[0]) & (peak > 0) & (peak >= other * (1.0 - 1e-3))
        out |= np.any(at_peak & rail, axis=1)
    return out


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
    from scipy.ndimage import binary_dilation

    if n <= 0 or not mask.any():
        return mask.copy()
    return binary_dilation(mask, structure=np.ones(2 * n + 1, dtype=bool))
