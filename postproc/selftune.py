"""Truth-free choice of the stance detection per recording, per-stride quality flags, and a level-stride
timing self-calibration of the vertical channel; ``bootnav.postproc.pipeline.process`` calls them (stage
"navigation").

Why: the best stance detector setting varies between people, gaits and sensors (fast walks and runs have a
foot-flat of a few tens of milliseconds, or none), and a fixed default either misses the short stances (the
path between two ZUPTs is unaided drift) or declares stance on a moving foot. The filter runs at over a
million samples per second, so a few candidate masks can be tried per recording and judged by what the
data say about them.

Candidates (``select_stance``): the configured detector (default: adaptive, α = 0.3), the adaptive rule
with α = 0.2 and 0.4, fixed-threshold SHOE [Skog2010], and "cycle minimum": the configured mask plus, in
every gait cycle it missed, the lowest-energy window of the SHOE statistic (``cycle_minimum_stance``), so
that every stride gets at least one zero-velocity update even when the foot never rests (running, fast
walks). The other candidates are scored only when the configured one fails (below): a recording the
default handles costs one extra forward filter run.

Criterion, computed from the data alone. For candidate c, run the filter (no smoother) and take at each
zero-velocity-update onset k (the first sample the filter aids, after the onset delay) the velocity the
unaided strapdown integration predicts there, v_k: it is the ZUPT innovation, z_k = 0 − v̂_k [Foxlin2005].
A good mask makes it small: a missed stance lets the velocity error grow over two strides, a stance
declared on a moving foot makes v̂_k the foot's true velocity::

    e_c  = sqrt( mean_k ‖v_k‖² )                                 (m/s; RMS ZUPT innovation at onsets)
    b_c  = fraction of strides flagged implausible (below)
    J_c  = e_c + v_pen · b_c,     v_pen = 1 m/s                   (a flagged stride costs like 1 m/s)

The configured detector is kept unless it FAILS: more than ``max_bad_fraction`` (10 %, the pipeline's own
``max_long_stride_fraction``) of its strides are implausible, or its stance samples turn at a median
‖ω − b̂‖ above ``fail_stance_rate_radps`` (1.5 rad/s, above the ≈ 1 rad/s of a running foot; the pipeline's
0.5 rad/s refusal is what turned away the fast walks of issue 11). Then the candidate with the smallest J_c
is taken. So a recording the default handles is processed exactly as before; J is only trusted for the
large differences of a real failure (a factor 2-10), not to rank candidates that all work.

A normalised innovation squared ε_k = z_kᵀ S_k⁻¹ z_k against its χ²(3) expectation [Groves2013, §17.3] would
make e_c comparable between recordings; it needs the innovation covariance S_k = P_vv + R_k, which
``run_filter`` does not expose yet, so the criterion compares raw innovations between the candidates of ONE
recording only.

Per-stride plausibility flags (``stride_quality``; bitmask, any set bit = implausible):

* ``FAST`` (1): stride length > ``max_stride_m`` or mean speed > ``max_speed_mps`` (a foot cannot);
* ``MISSED`` (2): the swing (end of one stance phase to the start of the next) lasts > ``missed_factor``
  gait cycles while the foot moves > 0.1 m: a stance was missed in between and the path there is unaided
  drift (a swing takes 0.6-0.9 of a cycle, from walking to running without foot-flat; a missed stance ≈ 2);
* ``VERTICAL`` (4): |Δz| > ``max_dz_m`` (a stair stride climbs at most two risers, ≈ 0.4 m);
* ``ROLLING`` (8): the foot turns at a median ‖ω − b̂‖ > ``max_stance_rate_radps`` over the stance phase
  that ends the stride (a zero-velocity update on a rolling foot: informative, not implausible: a running
  foot rolls at ≈ 1 rad/s through its short stance, pyshoe_vicon's running trials, and the filter's
  rolling-foot ZUPT noise accounts for it);
* ``TINY`` (16): horizontal length < ``min_stride_m`` (shuffling or standing, not a stride; informative).

Confidence of the chosen mask, in [0, 1]: (1 − b) · exp(−e / v_scale), v_scale = 0.5 m/s.

Gait cycle (``gait_period``): the lag of the highest autocorrelation peak of ‖ω‖ between 0.4 and 3 s (one
foot's stride period); no peak above 0.2 means no periodic gait (the confidence is then 0).

Vertical channel (``level_timing_offset``): the height error of a ZUPT-aided path behaves like a small
timing offset τ between the specific force and the attitude it is rotated with (sensor-specific filter delays;
about 0.1 m of vertical closure per ms over a 60-80 m loop on the developer data). The half-sample offset
of the strapdown step itself, Δt/2, which grows as the rate falls, is not left to τ: the default step
rotates f_b with the attitude at the middle of its interval (``FilterSettings.strapdown``), so τ is the
sensor's own offset, the same at every rate (docs/tuning-log.md, "Height at low rates"). The rotation of f_b by −ω τ, f_b' = exp(−[ω_b×] τ) f_b (first order
f_b − τ ω_b × f_b, the rotation-compensation term of [Savage1998]), shifts it; τ is chosen so that the
median height change of the level strides (|Δz| < 0.1 m, length > 0.3 m) is zero, assuming most walking is on
level floors: m(τ) is nearly linear, so two filter runs at ±δ give its zero crossing, clipped to ±τ_max.
A walk with fewer than ``timing_min_level_strides`` (200) level strides is not calibrated (τ = 0): there τ*
scatters more between recordings of one sensor than any sensor offset (``SelfTuneSettings``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from bootnav.core.peaks import local_maxima
from bootnav.core.runs import runs
from bootnav.core.timebase import sample_period
from bootnav.errors import InputError
from bootnav.core.arrays import row_dot, row_norm
from bootnav.postproc.detectors.shoe import ShoeDetector
from bootnav.postproc.strides import footprints

FAST, MISSED, VERTICAL, ROLLING, TINY = 1, 2, 4, 8, 16
IMPLAUSIBLE = FAST | MISSED | VERTICAL
FLAG_NAMES = {FAST: "fast", MISSED: "missed_stance", VERTICAL: "vertical", ROLLING: "rolling", TINY: "tiny"}


@dataclass
class SelfTuneSettings:
    """Tunables of the self-tuning (physical bounds, not fitted to data, except where said).

    alphas: extra adaptive α candidates; shoe_threshold: fixed SHOE γ candidate (None = no SHOE candidate).
    max_bad_fraction, fail_stance_rate_radps: when the configured detector counts as failed (module docstring).
    v_pen_mps, v_scale_mps: criterion and confidence scales (module docstring).
    max_stride_m, max_speed_mps, missed_factor, max_dz_m, max_stance_rate_radps, min_stride_m: stride flags.
    split_factor, max_split_fraction: a stride shorter in time than ``split_factor`` gait periods (footprint to
        footprint) has a stance detected inside a swing; more than ``max_split_fraction`` of such strides is a
        warning (``split_strides``).
    cycle_window_fraction: half-width of a cycle-minimum stance window, as a fraction of the gait period.
    cycle_depth_decades: a cycle-minimum window covers the samples within this many decades of the minimum.
    fallback: when the configured detector fails (a fatal stance finding of ``checks.stance_findings``, or
        more than ``max_bad_fraction`` implausible strides), choose among the candidates instead of
        refusing the recording (``bootnav process`` refuses only what cannot be a walking foot).
    timing_calibration: estimate the specific-force/attitude timing offset τ from the level strides
        (``level_timing_offset``) and rotate f_b by it before the final run.
    timing_probe_s, timing_max_abs_s: the probe offsets ±δ and the bound of τ, s. The bound was chosen by
        leave-one-dataset-out validation among ±1.5 / 3 / 5 ms (docs/tuning-log.md).
    timing_min_level_strides: fewer level strides than this: τ = 0 (no calibration). 200: τ is a property of the
        sensor, but on a short walk the criterion measures the walk more than the sensor: the τ* of ONE sensor
        scatters between its recordings of 15-30 level strides with a standard deviation of 6 / 10 / 14 ms
        (voisard_ipol 44 files / pyshoe_vicon 16 trials / iez_mpu6050 14 files, median τ* −4.8 / +2.7 /
        −16 ms), 2-5 times the bound ±τ_max; shrinking as 1/√K, that scatter falls within the bound only past
        K ≈ 65-380 level strides. So the short walks (every public recording: at most 73 level strides) keep
        the sensor's samples as they are, and a mission calibrates. Leave-one-dataset-out (10 / 50 / 100 /
        200): a bound of 50 or more is chosen in every fold, held-out / default 0.978; voisard 4.63 → 4.04 %
        beyond its spread, pyshoe_vicon 0.0736 → 0.0686 m (docs/tuning-log.md, "Timing calibration on short
        walks").
    timing_max_level_strides: τ is estimated from the first this many level strides (None: all), so the probe
        filters of a long recording run over its first part only (``level_timing_offset``). τ is a property
        of the sensor, constant over a recording, and 500 level strides make the standard error of τ*,
        1.2533 σ_dz / (√K |dm/dτ|) (of a median), 0.1-0.3 ms with the public foot walks' spread of level-stride
        height changes (σ_dz 6-10 mm) and slopes (dm/dτ 1.9-3.2 mm per ms): 5-15 % of the probe offset δ
        (docs/tuning-log.md, "Long recordings"). No public recording has as many strides: their results do
        not depend on it.
    """

    alphas: tuple[float, ...] = (0.2, 0.4)
    shoe_threshold: float | None = ShoeDetector.DEFAULT_THRESHOLD
    max_bad_fraction: float = 0.10
    fail_stance_rate_radps: float = 1.5
    v_pen_mps: float = 1.0
    v_scale_mps: float = 0.5
    max_stride_m: float = 6.0
    max_speed_mps: float = 8.0
    missed_factor: float = 1.4
    max_dz_m: float = 0.5
    max_stance_rate_radps: float = 1.0
    min_stride_m: float = 0.05
    split_factor: float = 0.5
    max_split_fraction: float = 0.5
    cycle_window_fraction: float = 0.06
    cycle_depth_decades: float = 0.5
    fallback: bool = True
    timing_calibration: bool = True
    timing_probe_s: float = 0.002
    timing_max_abs_s: float = 0.003
    timing_min_level_strides: int = 200
    timing_max_level_strides: int | None = 500


@dataclass
class StrideQuality:
    """Per stride (rows of ``segment_strides``): flags bitmask; and the share of implausible strides."""

    flags: np.ndarray
    duration_s: np.ndarray  # footprint to footprint (mid-stance to mid-stance)
    swing_s: np.ndarray  # end of the previous stance phase to the start of this one (unaided interval)
    stance_rate_radps: np.ndarray
    bad_fraction: float


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


# --------------------------------------------------------------------------------------------- gait cycle
def gait_period(t_s: np.ndarray, gyro_b: np.ndarray, min_s: float = 0.4, max_s: float = 3.0) -> float:
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

    def __init__(self, dt_s: float, min_s: float = 0.4, max_s: float = 3.0):
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


# ---------------------------------------------------------------------------------------- stride quality
def stride_quality(t_s, pos_n, stance, gyro_b, gyro_bias_b, period_s: float,
                   settings: SelfTuneSettings | None = None) -> StrideQuality:
    """Per-stride plausibility flags (module docstring) for the strides of ``segment_strides``.

    Parameters
    ----------
    t_s, pos_n, stance : the path and its stance mask.
    gyro_b : (N, 3) rad/s; gyro_bias_b : (3,) or (N, 3) estimated bias, rad/s.
    period_s : gait period (NaN: the MISSED flag is not evaluated).
    settings : ``SelfTuneSettings``.

    Returns
    -------
    ``StrideQuality`` with one flag word per stride.
    """
    stance = np.asarray(stance, bool)
    starts, stops = runs(stance)
    if starts.size < 2:
        return stride_flags(np.zeros(0), np.zeros((0, 3)), np.zeros(0), np.zeros(0), np.zeros(0), period_s, settings)
    t_mid, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), stance)
    rate = row_norm(gyro_b - gyro_bias_b)
    # median turning rate over each stance phase (sorted per phase via a lexsort on (phase, rate))
    ph = np.zeros(len(stance), np.int64)
    ph[starts[1:]] = 1
    ph = np.cumsum(ph)
    sel = stance
    order = np.lexsort((rate[sel], ph[sel]))
    r_sorted = rate[sel][order]
    counts = stops - starts
    offs = np.concatenate(([0], np.cumsum(counts)))
    med = 0.5 * (r_sorted[offs[:-1] + (counts - 1) // 2] + r_sorted[offs[:-1] + counts // 2])
    return stride_flags(t_mid, fp, t_s[starts], t_s[stops - 1], med, period_s, settings)


def stride_flags(t_mid, fp, t_first, t_last, med_rate, period_s: float,
                 settings: SelfTuneSettings | None = None) -> StrideQuality:
    """``stride_quality`` from per-stance-phase figures (K phases): mid times and footprints (``footprints``),
    the times of each phase's first and last sample, s, and its median turning rate ‖ω − b_g‖, rad/s. The one
    definition of the flags: the whole path gives them through ``stride_quality``, a path pushed in blocks
    through ``StrideQualityAccumulator``."""
    s = settings or SelfTuneSettings()
    if len(t_mid) < 2:
        return StrideQuality(np.zeros(0, np.uint8), np.zeros(0), np.zeros(0), np.zeros(0), 1.0)
    fp = np.asarray(fp, float)
    d = np.diff(fp, axis=0)
    length = np.hypot(d[:, 0], d[:, 1])
    dur = np.diff(np.asarray(t_mid, float))
    swing = np.asarray(t_first, float)[1:] - np.asarray(t_last, float)[:-1]
    med = np.asarray(med_rate, float)
    flags = np.zeros(len(length), np.uint8)
    flags[(length > s.max_stride_m) | (length > s.max_speed_mps * np.maximum(dur, 1e-9))] |= FAST
    if np.isfinite(period_s):
        flags[(swing > s.missed_factor * period_s) & (length > 0.1)] |= MISSED
    flags[np.abs(d[:, 2]) > s.max_dz_m] |= VERTICAL
    flags[med[1:] > s.max_stance_rate_radps] |= ROLLING
    flags[length < s.min_stride_m] |= TINY
    bad = float(np.mean((flags & IMPLAUSIBLE) > 0)) if len(flags) else 1.0
    return StrideQuality(flags, dur, swing, med[1:], bad)


class StrideQualityAccumulator:
    """The per-stance-phase figures of ``stride_flags`` from a path pushed in consecutive chunks (bounded
    memory: the turning rates of the open stance phase). ``finish`` gives what ``stride_quality`` gives on the
    whole path (the same medians; footprints to rounding: ``strides.FootprintAccumulator``)."""

    def __init__(self):
        from bootnav.postproc.strides import FootprintAccumulator

        self._fp = FootprintAccumulator()
        self._first: list[float] = []  # per stance phase: ~100 B each, 9 MB at 24 h of walking
        self._last: list[float] = []
        self._med: list[float] = []
        self._open: list[np.ndarray] = []  # turning rates of the open phase, chunk by chunk
        self._open_t: tuple[float, float] | None = None

    def push(self, t_s, pos_n, stance, gyro_b, gyro_bias_b) -> None:
        """Consecutive rows: s, m ENU, bool, rad/s (N, 3), rad/s ((3,) or (N, 3))."""
        m = len(t_s)
        if m == 0:
            return
        stance = np.asarray(stance, bool)
        self._fp.push(t_s, pos_n, stance)
        rate = row_norm(np.asarray(gyro_b) - gyro_bias_b)
        starts, stops = runs(stance)
        if self._open_t is not None and (starts.size == 0 or starts[0] > 0):
            self._close()
        for a, b in zip(starts.tolist(), stops.tolist()):  # one iteration per stance phase
            if a == 0 and self._open_t is not None:
                self._open_t = (self._open_t[0], float(t_s[b - 1]))
            else:
                self._open_t = (float(t_s[a]), float(t_s[b - 1]))
            self._open.append(rate[a:b])
            if b < m:
                self._close()

    def _close(self) -> None:
        if self._open_t is None:
            return
        r = np.sort(np.concatenate(self._open))
        c = len(r)
        self._med.append(0.5 * (r[(c - 1) // 2] + r[c // 2]))
        self._first.append(self._open_t[0])
        self._last.append(self._open_t[1])
        self._open, self._open_t = [], None

    def finish(self, period_s: float, settings: SelfTuneSettings | None = None) -> StrideQuality:
        """The flags of every stride pushed (``stride_flags``)."""
        self._close()
        t_mid, fp = self._fp.finish()
        return stride_flags(t_mid, fp, self._first, self._last, self._med, period_s, settings)


def split_strides(quality: StrideQuality, period_s: float, settings: SelfTuneSettings | None = None) -> str | None:
    """A warning when most strides are split: a foot rests once per gait cycle, so footprints closer in time
    than ``split_factor`` (1/2) of the gait period are a stance detected inside a swing (or a turn on the spot).
    A zero-velocity update there stops a moving foot, so every split stride is shortened and the distance comes
    out short without any stride looking implausible (each piece is an ordinary short stride, or a TINY one,
    which is informative only). A minority is normal (turns on the spot, the first and last step); when more than
    ``max_split_fraction`` (1/2) of the strides contradict the gait rhythm, the stance sequence itself is wrong.
    None without a gait period or when the strides fit the rhythm."""
    s = settings or SelfTuneSettings()
    dur = np.asarray(quality.duration_s, float)
    if not np.isfinite(period_s) or dur.size < 4:
        return None
    split = float(np.mean(dur < s.split_factor * period_s))
    if split <= s.max_split_fraction:
        return None
    return (f"{split:.0%} of the {dur.size} strides last less than half the gait cycle ({period_s:.2f} s): the stance "
            "detector finds rests inside the swings, which stops the foot mid-stride, so the distance is likely too "
            "short; try another --detector (e.g. shoe) or a higher --threshold")


# ---------------------------------------------------------------------------------------------- criterion
def onset_innovations(t_s, vel_n, stance, filter_settings) -> np.ndarray:
    """Predicted velocity at each zero-velocity-update onset after a swing (the ZUPT innovation, negated).

    The onset is the first aided sample after the onset delay (``ins.filter.delay_zupt_onsets``), and the
    value is the unaided prediction one sample before it. The initial still period (a phase starting at
    sample 0) has no swing before it and is skipped.

    Parameters
    ----------
    t_s : (N,) sample times, s.
    vel_n : (N, 3) velocity of a filter run WITHOUT smoother, m/s.
    stance : (N,) bool stance mask given to that run.
    filter_settings : its ``FilterSettings`` (onset delay and cap).

    Returns
    -------
    (K, 3) velocities, one per update onset, m/s.
    """
    from bootnav.postproc.ins.filter import delay_zupt_onsets

    aided = delay_zupt_onsets(t_s, stance, filter_settings.zupt_onset_delay_s,
                              filter_settings.zupt_onset_max_fraction)
    k0, _ = runs(aided)
    k0 = k0[k0 > 0]
    return np.asarray(vel_n)[k0 - 1]


def innovation_rms(t_s, acc_b, gyro_b, stance, init, gravity: float, filter_settings, saturated=None) -> float:
    """RMS ZUPT-onset innovation (m/s) of one forward filter run (no smoother): e_c of the module docstring."""
    from bootnav.postproc.ins import run_filter

    nav = run_filter(t_s, acc_b, gyro_b, stance, init, gravity, replace(filter_settings, smoother="none"),
                     saturated=saturated)
    v = onset_innovations(t_s, nav.vel_n, stance, filter_settings)
    return float(np.sqrt(np.mean(np.sum(v**2, axis=1)))) if len(v) else float("inf")


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


def confidence(innovation_rms_mps: float, bad_fraction: float, period_s: float,
               settings: SelfTuneSettings | None = None) -> float:
    """Confidence in [0, 1] of a path: (1 − b) · exp(−e / v_scale); 0 without a periodic gait (module docstring)."""
    s = settings or SelfTuneSettings()
    if not (np.isfinite(period_s) and np.isfinite(innovation_rms_mps)):
        return 0.0
    return float(np.clip((1.0 - bad_fraction) * np.exp(-innovation_rms_mps / s.v_scale_mps), 0.0, 1.0))


# --------------------------------------------------------------------------------------- vertical channel
def rotate_specific_force(acc_b: np.ndarray, gyro_b: np.ndarray, tau_s: float) -> np.ndarray:
    """f_b' = exp(−[ω_b×] τ) f_b per sample: the specific force as seen at the attitude of time t − τ.

    Parameters
    ----------
    acc_b : (N, 3) specific force, m/s²; gyro_b : (N, 3) angular rate, rad/s; tau_s : offset τ, s.

    Returns
    -------
    (N, 3) rotated specific force (exact rotation by the angle ‖ω‖ τ, Rodrigues' formula).
    """
    even, odd, axial = _rotation_terms(acc_b, gyro_b, tau_s)
    return even + odd + axial


def _rotation_terms(acc_b, gyro_b, tau_s: float):
    """The terms f c, (u × f) s and u (u·f)(1 − c) of ``rotate_specific_force`` (angle ‖ω τ‖ about
    u = −ω τ / ‖ω τ‖): their sum is the rotation by τ; negating the odd one gives the rotation by −τ, bit for bit
    (IEEE rounding is symmetric in sign), for the price of one."""
    th = -np.asarray(gyro_b, float) * tau_s
    a = row_norm(th)
    u = th / np.where(a > 0, a, 1.0)[:, None]
    c, sn = np.cos(a)[:, None], np.sin(a)[:, None]
    f = np.asarray(acc_b, float)
    return f * c, np.cross(u, f) * sn, u * row_dot(u, f)[:, None] * (1.0 - c)


def level_stride_dz(t_s, pos_n, stance, max_dz_m: float = 0.1, min_length_m: float = 0.3,
                    max_level_strides: int | None = None) -> tuple[float, int]:
    """Median height change of the level strides (|Δz| < max_dz_m, length > min_length_m) and their count.

    Parameters
    ----------
    t_s, pos_n, stance : a path and its stance mask (``segment_strides`` gives the strides).
    max_dz_m, min_length_m : what counts as a level stride (m).
    max_level_strides : only the first this many level strides count (None: all).

    Returns
    -------
    (median Δz in m, NaN without level strides; number of level strides counted).
    """
    from bootnav.postproc.strides import footprints

    return footprint_level_dz(*footprints(t_s, pos_n, stance), max_dz_m, min_length_m, max_level_strides)


def footprint_level_dz(t_mid, fp, max_dz_m: float = 0.1, min_length_m: float = 0.3,
                       max_level_strides: int | None = None) -> tuple[float, int]:
    """``level_stride_dz`` from the stance phases' mid times and footprints (``strides.footprints``)."""
    from bootnav.postproc.strides import footprint_strides

    st = footprint_strides(t_mid, fp)
    lev = (np.abs(st["dz_m"]) < max_dz_m) & (st["stride_length_m"] > min_length_m)
    if max_level_strides is not None:
        lev &= np.cumsum(lev) <= max_level_strides
    return (float(np.median(st["dz_m"][lev])) if lev.sum() else float("nan")), int(lev.sum())


def level_timing_offset(t_s, acc_b, gyro_b, stance, init, gravity: float, filter_settings, *, saturated=None,
                        delta_s: float = 0.002, max_abs_s: float = 0.003, min_level_strides: int = 10,
                        max_level_strides: int | None = None) -> dict:
    """Timing offset τ (s) that zeroes the median height change of the level strides (module docstring).

    Two forward filter runs (no smoother: it moves τ* by < 0.3 ms and triples the cost) at τ = ±``delta_s``
    give the line m(τ); τ* is its zero crossing, clipped to ±``max_abs_s``. Apply it with
    ``rotate_specific_force(acc_b, gyro_b, tau_s)`` before the final filter run. The two runs are independent
    and run in two threads (the filter kernel releases the GIL): two free cores give both for about the time
    of one.

    With ``max_level_strides`` = K, m(τ) is the median of the first K level strides, and the probes run over
    the first 2K + 1 stance phases only (whole phases and the swing after the last), a part twice as long
    while it holds fewer than K level strides, up to the whole recording: a long recording costs the probes
    of its first part. A recording with at most 2K + 1 stance phases is probed whole, as with K = None.

    Parameters
    ----------
    t_s, acc_b, gyro_b : calibrated samples (s, m/s², rad/s).
    stance : (N,) bool stance mask; init : ``calibration.InitialState``; gravity : m/s².
    filter_settings : ``FilterSettings`` (the smoother and the level-stride height hold are switched off for
        the two runs).
    saturated : optional saturation mask (as ``run_filter`` takes it).
    delta_s : the two probe offsets ±δ, s; max_abs_s : bound of τ*, s.
    min_level_strides : fewer level strides than this: no calibration (τ* = 0).
    max_level_strides : only the first this many level strides count (None: all; see above).

    Returns
    -------
    dict with ``tau_s`` (τ*), ``m_minus`` / ``m_plus`` (median level-stride Δz at −δ / +δ, m), ``n_level``
    (level strides counted), ``innovation_rms_mps`` (RMS ZUPT-onset innovation of the two runs, for
    ``confidence``), ``probe_s`` (seconds of the recording the probes ran over) and ``applied`` (False when
    τ* = 0 for lack of level strides or a flat m(τ)).
    """
    import os
    from concurrent.futures import ThreadPoolExecutor

    from bootnav.postproc.ins import run_filter

    if max_level_strides is not None and max_level_strides < 1:
        raise InputError(f"settings selftune.timing_max_level_strides: {max_level_strides} level strides; give at "
                         "least 1, or null for all of them")
    # the probes measure the level strides' height drift: the height hold (level_height) would erase it
    probe_settings = replace(filter_settings, smoother="none", level_height=False)
    starts = runs(np.asarray(stance, bool))[0]
    phases = len(starts) if max_level_strides is None else 2 * max_level_strides + 1
    while True:
        cut = int(starts[phases]) if phases < len(starts) else len(t_s)  # whole stance phases and the swing after
        t, g, st = t_s[:cut], gyro_b[:cut], stance[:cut]
        sat = None if saturated is None else saturated[:cut]
        even, odd, axial = _rotation_terms(acc_b[:cut], g, -delta_s)  # sum: τ = −δ; odd term negated: τ = +δ

        def probe(sign: int) -> tuple[float, int, float]:
            f = (even + odd if sign < 0 else even - odd) + axial
            nav = run_filter(t, f, g, st, init, gravity, probe_settings, saturated=sat)
            m, n_level = level_stride_dz(t, np.asarray(nav.pos_n), st, max_level_strides=max_level_strides)
            v = onset_innovations(t, nav.vel_n, st, filter_settings)
            return m, n_level, (float(np.mean(np.sum(v**2, axis=1))) if len(v) else float("inf"))

        with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:  # one CPU: one after the other
            (m_minus, n_minus, e2_minus), (m_plus, n_level, e2_plus) = pool.map(probe, (-1, 1))
        if cut == len(t_s) or min(n_minus, n_level) >= max_level_strides:
            break
        phases *= 2  # too few level strides in this part (stairs, shuffling): probe a part twice as long
    out = {"m_minus": m_minus, "n_level": n_level, "m_plus": m_plus,
           "innovation_rms_mps": float(np.sqrt(np.mean([e2_minus, e2_plus]))),
           "probe_s": float(t_s[cut - 1] - t_s[0])}
    return timing_from_probes(out, delta_s, max_abs_s, min_level_strides)


def timing_from_probes(out: dict, delta_s: float, max_abs_s: float, min_level_strides: int) -> dict:
    """τ* (``tau_s``) and ``applied`` from the probes' ``m_minus``, ``m_plus``, ``n_level`` (``level_timing_offset``);
    updates and returns ``out``."""
    slope = (out["m_plus"] - out["m_minus"]) / (2 * delta_s)
    ok = out["n_level"] >= min_level_strides and np.isfinite(slope) and abs(slope) > 0
    m0 = 0.5 * (out["m_plus"] + out["m_minus"])
    out["tau_s"] = float(np.clip(-m0 / slope, -max_abs_s, max_abs_s)) if ok else 0.0
    out["applied"] = bool(ok)
    return out
