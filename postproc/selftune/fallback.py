"""The truth-free stance fallback's "cycle minimum" candidate: when the configured detector fails, the candidate
masks (adaptive α's, SHOE, cycle minimum) are scored by their ZUPT innovations and stride flags in passes over
the blocks (``passes.BlockPasses.select_fallback``); see ``bootnav.postproc.selftune``."""

from __future__ import annotations

import numpy as np

from bootnav.core.timebase import sample_period

from .settings import SelfTuneSettings


def cycle_minimum_stance(t_s, acc_b, gyro_b, gravity: float, period_s: float, detector_settings,
                         settings: SelfTuneSettings | None = None, bad: np.ndarray | None = None) -> np.ndarray:
    """Stance windows at the lowest-energy instant of every gait cycle.

    The SHOE statistic (window and σ's of the adaptive detector: the configured one's parameters, or its
    defaults when another detector is configured) is taken in log10; its
    minima at least 0.6 gait periods apart and at least one decade below their neighbouring swing peaks are
    the moments the foot moves least; each gets the samples within ``cycle_depth_decades`` of the minimum
    and within ± ``cycle_window_fraction`` × period of it. Such a window exists in every stride, resting or
    rolling, so a ZUPT (with the rolling-foot noise of the filter) aids every stride.

    Parameters
    ----------
    t_s, acc_b, gyro_b : samples (s, m/s², rad/s).
    gravity : m/s².
    period_s : gait period (``gait_period``); NaN gives an empty mask.
    detector_settings : ``DetectorSettings`` (window and σ's of the SHOE statistic).
    settings : ``SelfTuneSettings``.
    bad : optional (N,) mask of samples that may never be stance (saturated).

    Returns
    -------
    (N,) bool stance mask.
    """
    from scipy.ndimage import label
    from scipy.signal import find_peaks

    from bootnav.postproc.detectors.shoe import shoe_statistic

    s = settings or SelfTuneSettings()
    n = len(t_s)
    if not np.isfinite(period_s):
        return np.zeros(n, bool)
    dt = sample_period(t_s)
    adaptive = detector_settings.with_method("adaptive").params  # the configured one's, or the defaults
    win = max(3, int(round(adaptive["window_s"] / dt)))
    T = shoe_statistic(acc_b, gyro_b, win, adaptive["sigma_acc_mps2"], adaptive["sigma_gyro_radps"], gravity)
    L = np.log10(np.maximum(T, 1e-300))
    minima, _ = find_peaks(-L, distance=max(1, int(0.6 * period_s / dt)), prominence=1.0)
    if minima.size == 0:
        return np.zeros(n, bool)
    # nearest minimum of every sample (midpoints between consecutive minima split the record)
    edges = (minima[1:] + minima[:-1]) // 2
    nearest = minima[np.searchsorted(edges, np.arange(n), side="right")]
    near = np.abs(t_s - t_s[nearest]) <= s.cycle_window_fraction * period_s
    low = (L <= L[nearest] + s.cycle_depth_decades) & near
    if bad is not None:
        low &= ~bad
    lab, _ = label(low)
    keep = np.zeros(lab.max() + 1, bool)
    keep[lab[minima]] = True
    keep[0] = False
    return keep[lab]


def cycle_minimum_candidate(t_s, acc_b, gyro_det, g_det: float, period_s: float, detector_settings,
                            settings: SelfTuneSettings, bad: np.ndarray, configured: np.ndarray) -> np.ndarray | None:
    """The "cycle minimum" candidate of the fallback: the configured mask plus the cycle-minimum windows
    (``cycle_minimum_stance``) of the cycles it missed (none of its samples within half a gait period); None
    when it misses none. ``gyro_det``, ``g_det``: the rates and gravity as the detectors see them."""
    cyc = cycle_minimum_stance(t_s, acc_b, gyro_det, g_det, period_s, detector_settings, settings, bad)
    cyc = _uncovered(cyc, configured, t_s, 0.5 * period_s)
    return configured | cyc if cyc.any() else None


def _uncovered(windows: np.ndarray, stance: np.ndarray, t_s: np.ndarray, half_s: float) -> np.ndarray:
    """The runs of ``windows`` with no ``stance`` sample within ± half_s of them (cycles the mask missed)."""
    from scipy.ndimage import label

    if not windows.any() or not np.isfinite(half_s):
        return np.zeros_like(windows)
    st_t = t_s[stance]
    lab, n = label(windows)
    idx = np.flatnonzero(windows)
    first = np.full(n + 1, np.inf)
    last = np.full(n + 1, -np.inf)
    np.minimum.at(first, lab[idx], t_s[idx])
    np.maximum.at(last, lab[idx], t_s[idx])
    if st_t.size == 0:
        return windows.copy()
    # any stance sample in [first - half, last + half]? count via searchsorted on the sorted stance times
    hit = np.searchsorted(st_t, last[1:] + half_s, side="right") - np.searchsorted(st_t, first[1:] - half_s)
    keep = np.concatenate(([False], hit == 0))
    return keep[lab]
