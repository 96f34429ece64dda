"""The truth-free stance fallback: when the configured detector fails, the candidate masks (adaptive α's,
SHOE, cycle minimum) scored by their ZUPT innovations and stride flags (``select_stance``); see
``bootnav.postproc.selftune``."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from bootnav.core.arrays import row_norm
from bootnav.core.runs import runs
from bootnav.core.timebase import sample_period

from .gait import gait_period
from .quality import StrideQuality, stride_quality
from .scoring import confidence, onset_innovations
from .settings import SelfTuneSettings


@dataclass
class SelfTuneResult:
    """Outcome of ``select_stance``: the chosen mask and why."""

    stance: np.ndarray
    choice: str
    confidence: float
    gait_period_s: float
    quality: StrideQuality
    candidates: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    failed: str | None = None  # why the configured detector was not kept (None: it was)


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
    """The "cycle minimum" candidate of ``select_stance``: the configured mask plus the cycle-minimum windows
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


def _score(t_s, acc_b, gyro_b, stance, init, gravity, fsettings, saturated, period_s, s):
    from bootnav.postproc.ins import run_filter

    nav = run_filter(t_s, acc_b, gyro_b, stance, init, gravity, replace(fsettings, smoother="none"),
                     saturated=saturated)
    v = onset_innovations(t_s, nav.vel_n, stance, fsettings)
    e = float(np.sqrt(np.mean(np.sum(v**2, axis=1)))) if len(v) else float("inf")
    bias = nav.gyro_bias_b if nav.gyro_bias_b is not None else np.asarray(init.gyro_bias_b)
    q = stride_quality(t_s, np.asarray(nav.pos_n), stance, gyro_b, bias, period_s, s)
    if not np.all(np.isfinite(nav.pos_n)):
        e = float("inf")
    return e, q


def _row(name, mask, t_s, acc_b, gyro_b, init, gravity, fsettings, saturated, period, s) -> dict:
    """Criterion of one candidate mask (a mask without a stance-to-swing edge cannot be scored: J = inf)."""
    if runs(mask)[0].size < 2:
        return {"name": name, "innovation_rms_mps": float("inf"), "bad_fraction": 1.0, "J": float("inf"),
                "stance_fraction": float(mask.mean())}
    e, q = _score(t_s, acc_b, gyro_b, mask, init, gravity, fsettings, saturated, period, s)
    return {"name": name, "innovation_rms_mps": e, "bad_fraction": q.bad_fraction,
            "J": e + s.v_pen_mps * q.bad_fraction, "stance_fraction": float(mask.mean()), "_q": q}


def select_stance(t_s, acc_b, gyro_b, init, gravity: float, detector_settings, filter_settings, *,
                  saturated=None, settings: SelfTuneSettings | None = None, configured=None,
                  failed: str | None = None, period_s: float | None = None) -> SelfTuneResult:
    """Choose the stance mask of one recording among the candidates (module docstring); never raises on a
    recording with samples.

    Parameters
    ----------
    t_s, acc_b, gyro_b : calibrated samples (s, m/s², rad/s), as ``process`` passes them to the detector.
    init : ``calibration.InitialState``; gravity : m/s².
    detector_settings : the configured ``DetectorSettings`` (candidate "configured", and the σ's/windows
        of the others).
    filter_settings : ``FilterSettings`` used to score the candidates (the smoother is switched off).
    saturated : optional saturation mask/bitmask (as ``detect_stance`` and ``run_filter`` take it).
    settings : ``SelfTuneSettings``.
    configured : the configured detector's ``StanceResult`` when the caller already has it (else detected).
    failed : the reason the caller already found the configured mask to fail (a fatal stance or stride
        finding); the other candidates are then always tried.
    period_s : the gait period when the caller already has it (else ``gait_period``).

    Returns
    -------
    ``SelfTuneResult``: stance mask, the candidate chosen, a confidence in [0, 1], the gait period, the
    per-stride quality flags of the chosen mask, every candidate's criterion and warnings.
    """
    from bootnav.postproc.calibration import stance_reference
    from bootnav.postproc.detectors import detect_stance

    s = settings or SelfTuneSettings()
    t_s = np.asarray(t_s, float)
    bias_det, g_det = stance_reference(init, gravity)  # the detectors see the rest as this sensor reads it
    gyro_det = np.asarray(gyro_b, float) - bias_det
    period = gait_period(t_s, gyro_b) if period_s is None else period_s
    warnings = []
    if not np.isfinite(period):
        warnings.append("no periodic gait found (autocorrelation of |ω| below 0.2 at 0.4-3 s)")
    if configured is None:
        configured = detect_stance(t_s, acc_b, gyro_det, detector_settings, g_det, saturated=saturated)
    name0 = f"configured ({configured.method})"
    masks: dict[str, np.ndarray] = {name0: np.asarray(configured.stance, bool)}
    rows = [_row(name0, masks[name0], t_s, acc_b, gyro_b, init, gravity, filter_settings, saturated, period, s)]
    rate0 = row_norm(gyro_b[masks[name0]] - np.asarray(init.gyro_bias_b))
    if failed is None and not np.isfinite(rows[0]["J"]):
        failed = "no stride to score"
    if failed is None and rows[0]["bad_fraction"] > s.max_bad_fraction:
        failed = f"{rows[0]['bad_fraction']:.0%} implausible strides"
    if failed is None and rate0.size > 0 and float(np.median(rate0)) > s.fail_stance_rate_radps:
        failed = f"its stance turns at a median {float(np.median(rate0)):.2f} rad/s"
    if failed:  # only then are the other candidates worth their filter runs
        for a in s.alphas:
            ds = detector_settings.with_method("adaptive", alpha=a)
            masks[f"adaptive alpha={a:g}"] = np.asarray(detect_stance(t_s, acc_b, gyro_det, ds, g_det,
                                                                      saturated=saturated).stance, bool)
        if s.shoe_threshold:
            ds = detector_settings.with_method("shoe", threshold=s.shoe_threshold)
            masks[f"shoe {s.shoe_threshold:g}"] = np.asarray(detect_stance(t_s, acc_b, gyro_det, ds, g_det,
                                                                           saturated=saturated).stance, bool)
        bad = np.zeros(len(t_s), bool)
        if saturated is not None:
            sat = np.asarray(saturated)
            bad = sat.astype(bool) if sat.ndim == 1 else sat.any(axis=1)
        cyc = cycle_minimum_candidate(t_s, acc_b, gyro_det, g_det, period, detector_settings, s, bad, masks[name0])
        if cyc is not None:
            masks["cycle minimum"] = cyc
        rows += [_row(n, m, t_s, acc_b, gyro_b, init, gravity, filter_settings, saturated, period, s)
                 for n, m in list(masks.items())[1:]]
    best = int(np.argmin([r["J"] for r in rows])) if failed else 0
    chosen = rows[best]
    q = chosen.get("_q") or StrideQuality(np.zeros(0, np.uint8), np.zeros(0), np.zeros(0), np.zeros(0), 1.0)
    e = chosen["innovation_rms_mps"]
    conf = confidence(e, q.bad_fraction, period, s)
    if failed:
        warnings.append(f"stance detection: the configured detector fails ({failed}); fallback '{chosen['name']}' "
                        f"chosen (criterion {chosen['J']:.3f} m/s vs {rows[0]['J']:.3f} m/s)")
    for r in rows:
        r.pop("_q", None)
    return SelfTuneResult(masks[chosen["name"]], chosen["name"], conf, period, q,
                          rows, warnings, failed)
