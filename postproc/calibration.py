"""Calibration and initial alignment: normal gravity, initial still period, roll/pitch, gyro bias.

Equations
---------
WGS-84 normal gravity on the ellipsoid (Somigliana's closed formula [NIMA2000, eq. 4-1])::

    g0(φ) = g_e (1 + k sin²φ) / sqrt(1 − e² sin²φ),   k = b g_p / (a g_e) − 1

with g_e = 9.7803253359 m/s² (equator), g_p = 9.8321849378 m/s² (pole), a = 6378137 m,
b = 6356752.3142 m, e² = 6.69437999014e-3. Free-air (height) correction, second order [NIMA2000, eq. 4-3]::

    g(φ, h) = g0 [1 − 2/a (1 + f + m − 2 f sin²φ) h + 3 h²/a²]

with flattening f = 1/298.257223563 and m = ω² a² b / GM = 0.00344978650684.

Initial alignment (levelling [Groves2013, §5.6.2]): at rest the accelerometer measures the specific force
f_b = C_bn [0, 0, g]; with q_nb = Rz(ψ) Ry(θ) Rx(φ) (z-y-x Euler angles)::

    φ (roll)  = atan2(f_y, f_z)
    θ (pitch) = atan2(−f_x, sqrt(f_y² + f_z²))
    ψ (yaw)   = 0   (heading is not observable from gravity; the nav frame is defined by the start)

Gyro bias: b_g = mean ω_b over the still period's quiet core (``quiet_core``: windows whose rate variance is
within ``still_quiet_ratio`` of the quietest; a small motion inside the period is not bias). The true rate
at rest is Earth rotation, < 7.3e-5 rad/s, below MEMS bias stability, so it is absorbed into the bias.

Sensor calibration (issue 23; the model and file format are ``bootnav.core.sensorcal``)::

    x̂ = C (y − b − k (T − T_ref))          for the accelerometer and the gyroscope

C holds scale factors on its diagonal and misalignment / cross-axis terms off it, b the bias, k its
temperature coefficient (``bootnav calibrate``: multi-position fit [Skog2006], rotations between poses
[Tedaldi2014]). It is applied here, to the raw samples and before anything else reads them (stance
detection, alignment, filter), with the recording's temperature channel when it has one. Which calibration
applies is decided by ``resolve_calibration`` and nothing else: ``--calibration FILE`` (setting
``sensor_calibration``) > the store's newest calibration of the recording's device id > none;
``--no-calibration`` (``sensor_calibration = "none"``) disables it. The older accelerometer file
(``{"bias_mps2": [bx, by, bz], "matrix": [[...3x3...]]}``, f = M (f_raw − b), e.g. from a six-position test,
the model of [IEEE1293] inverted) is the same model with C = M, k = 0 and no gyroscope part; it is read by the
same function (``accel_calibration_file``, ``--accel-calibration``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core.rotations import euler_zyx_from_quat, quat_conjugate, quat_from_euler_zyx, quat_multiply
from bootnav.core.runs import runs
from bootnav.core.timebase import sample_period

from bootnav.core.arrays import moving_mean, row_norm, rows_finite
from bootnav.core.conventions import STANDARD_GRAVITY_MPS2

# WGS-84 constants [NIMA2000, tables 3.1-3.4]
WGS84_A_M = 6378137.0
WGS84_B_M = 6356752.3142
WGS84_F = 1.0 / 298.257223563
WGS84_E2 = 6.69437999014e-3
WGS84_GE_MPS2 = 9.7803253359
WGS84_GP_MPS2 = 9.8321849378
WGS84_M = 0.00344978650684


def normal_gravity(lat_deg: float = 45.0, height_m: float = 0.0) -> float:
    """WGS-84 normal gravity (m/s²) at geodetic latitude ``lat_deg`` and ellipsoidal height ``height_m``.

    Somigliana [NIMA2000, eq. 4-1] plus the second-order free-air correction (eq. 4-3); see module docstring.
    """
    if not -90.0 <= lat_deg <= 90.0:
        raise ValueError(f"latitude must be within [-90, 90] degrees, got {lat_deg}")
    s2 = math.sin(math.radians(lat_deg)) ** 2
    k = WGS84_B_M * WGS84_GP_MPS2 / (WGS84_A_M * WGS84_GE_MPS2) - 1.0
    g0 = WGS84_GE_MPS2 * (1.0 + k * s2) / math.sqrt(1.0 - WGS84_E2 * s2)
    h = float(height_m)
    return g0 * (
        1.0 - 2.0 / WGS84_A_M * (1.0 + WGS84_F + WGS84_M - 2.0 * WGS84_F * s2) * h + 3.0 * h * h / WGS84_A_M**2
    )


@dataclass
class CalibrationSettings:
    """Every tunable of calibration / alignment (saved with the results).

    still_window_s: moving window (s) for the still test.
    still_acc_std_mps2: max std of |f| inside the window (MEMS noise ~0.01-0.05 m/s²; walking ≫ 0.5).
    still_gyro_std_radps: max per-axis std of ω inside the window (a standing foot ≪ 0.05 rad/s; swing ≫ 1).
    still_gyro_max_radps: max |ω − window mean ω| inside the window (rejects slow rotations that have low std).
    still_acc_dev_mps2: max | |f| − g | (uncalibrated MEMS read 9.4-10.5 m/s² at rest, hence 1.0).
    still_search_s: the still period must start within this time from the first sample.
    min_still_s: shortest accepted still period.
    max_still_s: only this much of a longer still period is averaged (bias drifts with temperature).
    still_quiet_ratio: gyro bias and levelling average only the QUIET CORE of the still period: samples whose
        local (``still_window_s``) rate variance is at most this multiple of the quietest window's. A resting
        foot's gyro varies only by sensor noise; a window with more variance holds a small motion (a shifting
        foot passes the still thresholds), and the mean rate of a motion is not bias. 2 = std within √2 of
        the quietest window (``quiet_core``); 1.5-3 perform alike (pre-LODO; docs/tuning-log.md). 0 = off.
    rest_window_s, rest_gyro_max_radps: without a still period, roll/pitch come from the first foot-flat
        (``first_rest``): a window this long (s; a walking foot-flat lasts 0.1-0.4 s [Perry2010]) in which
        ‖ω‖ stays below this rate (rad/s; a resting foot turns at < 0.5 rad/s, ``InputChecks``' stance bound).
    use_gyro_bias: subtract the still-period gyro mean as the initial gyro bias.
    tilt_bias: the horizontal part (at right angles to gravity) of the initial gyro bias from the whole still
        period with its rotation taken out: the accelerometer sees the foot tilt (``still_tilt_bias``). A start
        that passes the still test can still turn slowly and steadily (tens of mrad/s with little variance,
        which ``quiet_core`` cannot tell from rest); the vertical part is not seen and stays the quiet core's.
    sensor_calibration: which sensor calibration is applied (``resolve_calibration``): "auto" = the stored
        calibration of the recording's device id, if there is one; "none" = no calibration; anything else is
        a calibration file (``bootnav calibrate``'s JSON, or the accelerometer file). "given" marks a
        calibration object passed by the API (its provenance is in the summary).
    accel_calibration_file: the older accelerometer-only file (module docstring), or None; a calibration file
        like ``sensor_calibration`` (setting both is an error).
    latitude_deg, height_m: for WGS-84 normal gravity.
    gravity_mps2: explicit gravity; None -> normal_gravity(latitude_deg, height_m).
    """

    still_window_s: float = 0.25
    still_acc_std_mps2: float = 0.15
    still_gyro_std_radps: float = 0.05
    still_gyro_max_radps: float = 0.15
    still_acc_dev_mps2: float = 1.0
    still_search_s: float = 10.0
    min_still_s: float = 0.5
    max_still_s: float = 30.0
    still_quiet_ratio: float = 2.0
    rest_window_s: float = 0.1
    rest_gyro_max_radps: float = 0.5
    use_gyro_bias: bool = True
    tilt_bias: bool = False
    sensor_calibration: str = "auto"
    accel_calibration_file: str | None = None
    latitude_deg: float = 45.0
    height_m: float = 0.0
    gravity_mps2: float | None = None

    def gravity(self) -> float:
        return float(self.gravity_mps2) if self.gravity_mps2 is not None else normal_gravity(self.latitude_deg, self.height_m)


@dataclass
class InitialState:
    q_nb: np.ndarray  # (4,) wxyz, body -> nav, yaw = 0
    gyro_bias_b: np.ndarray  # (3,) rad/s
    acc_mean_b: np.ndarray  # (3,) m/s², mean specific force used for levelling
    still: slice | None  # initial still period (sample slice) or None
    gravity: float  # m/s²
    warnings: list[str] = field(default_factory=list)
    roll_rad: float = 0.0
    pitch_rad: float = 0.0


@dataclass
class AccelCalibration:
    bias_mps2: np.ndarray  # (3,)
    matrix: np.ndarray  # (3, 3)
    source: str = ""


def still_mask(t_s, acc_b, gyro_b, settings: CalibrationSettings | None = None,
               gravity: float = STANDARD_GRAVITY_MPS2, *, dt_s: float | None = None) -> np.ndarray:
    """Samples whose centred window (``still_window_s``) passes every still test (bool (N,)); ``dt_s``: the
    sample period the window is counted in (default: ``sample_period(t_s)``)."""
    from scipy.ndimage import maximum_filter1d

    s = settings or CalibrationSettings()
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    n = still_window_samples(s, sample_period(t_s) if dt_s is None else dt_s)
    amag = row_norm(acc_b)
    a_mean = moving_mean(amag, n)
    a_std = np.sqrt(np.maximum(moving_mean(amag**2, n) - a_mean**2, 0.0))
    g_mean = moving_mean(gyro_b, n)
    g_sd = np.sqrt(np.maximum(moving_mean(gyro_b**2, n) - g_mean**2, 0.0))
    g_std = np.maximum(np.maximum(g_sd[:, 0], g_sd[:, 1]), g_sd[:, 2])  # max(axis=1), on columns (faster)
    # peak deviation of the rate from the window mean (window max of |ω - local mean|)
    g_dev = maximum_filter1d(row_norm(gyro_b - g_mean), size=n, mode="nearest")
    ok = (
        (a_std < s.still_acc_std_mps2)
        & (g_std < s.still_gyro_std_radps)
        & (g_dev < s.still_gyro_max_radps)
        & (np.abs(a_mean - gravity) < s.still_acc_dev_mps2)
    )
    return ok & np.isfinite(amag) & rows_finite(gyro_b)


def still_window_samples(settings: CalibrationSettings, dt_s: float) -> int:
    """Samples of the still test's window (``still_window_s``) at sample period ``dt_s``, at least 3."""
    return max(3, int(round(settings.still_window_s / dt_s)))


def find_still_period(t_s, acc_b, gyro_b, *, min_duration_s: float = 0.5, settings: CalibrationSettings | None = None,
                      gravity: float = STANDARD_GRAVITY_MPS2, dt_s: float | None = None) -> slice | None:
    """The initial still period: the first run of still samples that starts within ``still_search_s`` of
    the start and lasts at least ``min_duration_s`` (truncated to ``max_still_s``). None if there is none.

    Only the first ``still_search_s`` + max(``max_still_s``, ``min_duration_s``) of the record can decide it,
    so the still test runs over those seconds and two windows more (a moving mean's value depends on the
    samples within half a window of it, and on the running sum before it, which a prefix leaves as it is):
    the same period as over the whole record, for the cost of its first seconds. ``dt_s``: the record's sample
    period when ``t_s`` is only its first seconds (default: ``sample_period(t_s)``)."""
    s = settings or CalibrationSettings()
    t_s = np.asarray(t_s, dtype=np.float64)
    dt = sample_period(t_s) if dt_s is None else dt_s
    n = still_window_samples(s, dt)
    k = int(np.searchsorted(t_s, t_s[0] + s.still_search_s + max(s.max_still_s, min_duration_s) + dt)) + 2 * n + 2
    k_valid = len(t_s) if k >= len(t_s) else k - n - 1  # beyond: the prefix's edge, not the record, decides
    ok = still_mask(t_s[:k], acc_b[:k], gyro_b[:k], s, gravity, dt_s=dt)[:k_valid]
    if not ok.any():
        return None
    starts, stops = runs(ok)  # stops exclusive
    dur = t_s[stops - 1] - t_s[starts] + dt
    good = (dur >= min_duration_s) & (t_s[starts] - t_s[0] <= s.still_search_s)
    if not good.any():
        return None
    i = int(np.flatnonzero(good)[0])
    start, stop = int(starts[i]), int(stops[i])
    stop = min(stop, int(np.searchsorted(t_s, t_s[start] + s.max_still_s)))
    return slice(start, max(stop, start + 1))


def quiet_core(t_s, gyro_b, still: slice, settings: CalibrationSettings | None = None, *,
               dt_s: float | None = None) -> np.ndarray:
    """Bool mask over the samples of ``still``: local rate variance (summed over axes, centred window of
    ``still_window_s``) <= ``still_quiet_ratio`` × its minimum over the period (all True when the ratio is 0)."""
    s = settings or CalibrationSettings()
    g = np.asarray(gyro_b, dtype=np.float64)[still]
    if s.still_quiet_ratio <= 0 or g.shape[0] < 3:
        return np.ones(g.shape[0], dtype=bool)
    n = max(3, int(round(s.still_window_s / (sample_period(t_s) if dt_s is None else dt_s))))
    m = moving_mean(g, n)
    var = np.maximum(moving_mean(g**2, n) - m**2, 0.0).sum(axis=1)
    return var <= s.still_quiet_ratio * var.min()


def still_tilt_bias(t_s, acc_b, gyro_b, still: slice, bias_b, settings: CalibrationSettings | None = None) -> np.ndarray:
    """``bias_b`` (3,) rad/s with its part at right angles to gravity replaced by the still period's mean rate
    less the rotation the accelerometer saw.

    Gravity is fixed in the navigation frame, so its body-frame reading turns as ḟ = f × ω and a small net
    rotation changes it by f × θ. With Θ(t) = ∫ω_meas dt, f(t) − f̄ × Θ(t) = f₀ − (f̄ × b) t: a straight line
    whose slope (least squares over every sample of the period: a constant accelerometer bias goes into f₀)
    gives f̄ × b, i.e. the bias at right angles to gravity b⊥ = f̄ × slope / |f̄|², whatever slow motion the
    foot made (the part about gravity is not seen). A period shorter than three ``still_window_s`` returns
    ``bias_b`` unchanged."""
    s = settings or CalibrationSettings()
    t = np.asarray(t_s, dtype=np.float64)[still]
    f = np.asarray(acc_b, dtype=np.float64)[still]
    w = np.asarray(gyro_b, dtype=np.float64)[still]
    bias_b = np.asarray(bias_b, dtype=np.float64)
    n = still_window_samples(s, sample_period(t_s))
    if t.shape[0] < 3 * n:
        return bias_b
    f_mean = f.mean(axis=0)
    f2 = float(f_mean @ f_mean)
    up = f_mean / math.sqrt(f2)
    dt = np.diff(t)
    theta = np.vstack([np.zeros(3), np.cumsum((w[1:] + w[:-1]) * 0.5 * dt[:, None], axis=0)])  # ∫ω dt
    z = f - np.cross(f_mean, theta)  # = f0 − (f × b) t
    tc = t - t.mean()
    slope = (tc[:, None] * (z - z.mean(axis=0))).sum(axis=0) / float(tc @ tc)
    horiz = np.cross(f_mean, slope) / f2
    horiz -= (horiz @ up) * up
    return horiz + (bias_b @ up) * up


def roll_pitch_from_specific_force(f_b) -> tuple[float, float]:
    """Roll and pitch (rad) that make C_nb f_b point up (module docstring)."""
    fx, fy, fz = (float(v) for v in f_b)
    return math.atan2(fy, fz), math.atan2(-fx, math.hypot(fy, fz))


def initial_alignment(t_s, acc_b, gyro_b, settings: CalibrationSettings | None = None,
                      gravity: float | None = None, *, dt_s: float | None = None) -> InitialState:
    """Roll/pitch from the mean specific force of the initial still period, yaw = 0, gyro bias = its mean
    rate (both over its quiet core, ``quiet_core``). The attitude is the first sample's: when the still period
    starts later (the recording starts in motion), the levelled attitude is carried back to the start by the
    gyro increments in between (``gyro_rotation``). Without a still period: levelling on the first foot-flat
    (``first_rest``), carried back the same way, zero bias and a warning; without a foot-flat either, on the
    first ``min_still_s`` of data. ``dt_s``: the record's sample period when ``t_s`` holds only its first
    seconds (the block passes of ``pipeline``; default: ``sample_period(t_s)``)."""
    s = settings or CalibrationSettings()
    g = s.gravity() if gravity is None else float(gravity)
    t_s = np.asarray(t_s, dtype=np.float64)
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    if acc_b.ndim != 2 or acc_b.shape[1] != 3 or gyro_b.shape != acc_b.shape or t_s.shape[0] != acc_b.shape[0]:
        raise ValueError(f"expected t_s (N,), acc_b and gyro_b (N, 3); got {t_s.shape}, {acc_b.shape}, {gyro_b.shape}")
    if t_s.shape[0] < 3:
        raise ValueError(f"too few samples for alignment ({t_s.shape[0]})")
    warnings: list[str] = []
    still = find_still_period(t_s, acc_b, gyro_b, min_duration_s=s.min_still_s, settings=s, gravity=g, dt_s=dt_s)
    q_start = None
    if still is None:
        bias = np.zeros(3)
        rest = first_rest(t_s, acc_b, gyro_b, s, g, dt_s=dt_s)
        if rest is not None:  # level on the first foot-flat, rotated back to the first sample by the gyro
            a, b = rest
            f_mean = acc_b[a:b].mean(axis=0)
            roll_r, pitch_r = roll_pitch_from_specific_force(f_mean)
            q_rest = quat_from_euler_zyx(roll_r, pitch_r, 0.0)
            q_move = gyro_rotation(t_s[: a + 1], gyro_b[: a + 1])
            q_start = tuple(float(x) for x in euler_zyx_from_quat(quat_multiply(q_rest, quat_conjugate(q_move)))[:2])
            warnings.append(
                f"no initial still period (>= {s.min_still_s:g} s of rest within the first {s.still_search_s:g} s): "
                f"roll/pitch levelled on the first foot-flat (t = {t_s[a] - t_s[0]:.2f}-{t_s[b - 1] - t_s[0]:.2f} s) "
                "and carried back to the start by the gyro; gyro bias set to zero; start recordings with the foot "
                "at rest for a few seconds"
            )
        else:
            n = max(1, int(np.searchsorted(t_s, t_s[0] + s.min_still_s)))
            f_mean = np.nanmean(acc_b[:n], axis=0)
            warnings.append(
                f"no initial still period (>= {s.min_still_s:g} s of rest within the first {s.still_search_s:g} s) "
                f"and no foot-flat: roll/pitch levelled on the first {t_s[n - 1] - t_s[0]:.2f} s of motion data "
                "(may be wrong by degrees) and gyro bias set to zero; start recordings with the foot at rest for a "
                "few seconds"
            )
    else:
        quiet = quiet_core(t_s, gyro_b, still, s, dt_s=dt_s)  # motion inside the still period is not bias
        f_mean = acc_b[still][quiet].mean(axis=0)
        bias = gyro_b[still][quiet].mean(axis=0) if s.use_gyro_bias else np.zeros(3)
        if s.use_gyro_bias and s.tilt_bias:
            bias = still_tilt_bias(t_s, acc_b, gyro_b, still, bias, s)
        dur = t_s[still.stop - 1] - t_s[still.start]
        if abs(np.linalg.norm(f_mean) - g) > 0.3:
            warnings.append(
                f"|specific force| at rest is {np.linalg.norm(f_mean):.3f} m/s^2 vs gravity {g:.3f} m/s^2: "
                "the accelerometer looks uncalibrated (consider an accel calibration file)"
            )
        if dur < 1.0:
            warnings.append(f"initial still period is short ({dur:.2f} s); gyro bias estimate is noisy")
        if still.start > 0:  # the foot moved before it rested: carry the levelled attitude back to the start
            roll_r, pitch_r = roll_pitch_from_specific_force(f_mean)
            q_rest = quat_from_euler_zyx(roll_r, pitch_r, 0.0)
            q_move = gyro_rotation(t_s[: still.start + 1], gyro_b[: still.start + 1] - bias)
            q_start = tuple(float(x) for x in euler_zyx_from_quat(quat_multiply(q_rest, quat_conjugate(q_move)))[:2])
    roll, pitch = roll_pitch_from_specific_force(f_mean) if q_start is None else q_start
    return InitialState(q_nb=quat_from_euler_zyx(roll, pitch, 0.0), gyro_bias_b=np.asarray(bias, dtype=np.float64),
                        acc_mean_b=np.asarray(f_mean, dtype=np.float64), still=still, gravity=g,
                        warnings=warnings, roll_rad=roll, pitch_rad=pitch)


def first_rest(t_s, acc_b, gyro_b, settings: CalibrationSettings | None = None,
               gravity: float = STANDARD_GRAVITY_MPS2, *, dt_s: float | None = None) -> tuple[int, int] | None:
    """The first foot-flat within ``still_search_s`` of the start: (start, stop) sample indices, or None.

    A recording that starts in motion has no still period, and levelling on its first samples (a swing)
    tilts the start by tens of degrees, which the filter, believing its initial attitude to
    ``init_att_sigma_rad``, carries through the whole walk (height and stride flags run away, docs/tuning-log.md
    2026-12-02). A walking foot rests flat once per stride: a window of ``rest_window_s`` whose ‖ω‖ stays
    below ``rest_gyro_max_radps`` and whose mean ‖f‖ is within ``still_acc_dev_mps2`` of gravity. Of the first
    run of such windows, the one with the least mean ‖ω‖ is taken.
    """
    s = settings or CalibrationSettings()
    t_s = np.asarray(t_s, dtype=np.float64)
    n = max(3, int(round(s.rest_window_s / (sample_period(t_s) if dt_s is None else dt_s))))
    # only the first still_search_s can hold it: the windows over that prefix (memory flat in the record)
    k_end = min(len(t_s), int(np.searchsorted(t_s, t_s[0] + s.still_search_s, side="right")) + 2 * n)
    t_s, acc_b, gyro_b = t_s[:k_end], np.asarray(acc_b)[:k_end], np.asarray(gyro_b)[:k_end]
    if t_s.shape[0] < n:
        return None
    from scipy.ndimage import maximum_filter1d

    w = row_norm(np.asarray(gyro_b, dtype=np.float64))
    w_max = maximum_filter1d(w, size=n, mode="nearest")  # centred, as moving_mean: index k + n//2 = [k, k + n)
    w_mean = moving_mean(w, n)
    f_mag = moving_mean(row_norm(np.asarray(acc_b, dtype=np.float64)), n)
    k = np.arange(t_s.shape[0] - n + 1)
    c = k + n // 2  # centre of window k (moving_mean is centred)
    ok = ((w_max[c] < s.rest_gyro_max_radps) & (np.abs(f_mag[c] - gravity) < s.still_acc_dev_mps2)
          & (t_s[k] - t_s[0] <= s.still_search_s))
    starts, stops = runs(ok)
    if starts.size == 0:
        return None
    cand = np.arange(starts[0], stops[0])
    best = int(cand[np.argmin(w_mean[cand + n // 2])])
    return best, best + n


def gyro_rotation(t_s, gyro_b) -> np.ndarray:
    """q_b0_bk (wxyz): the body rotation from the first to the last sample, the product of the per-sample
    increments exp(ω_k Δt_k / 2) (as the strapdown integrates them), in log2(N) vectorised rounds."""
    t_s = np.asarray(t_s, dtype=np.float64)
    theta = np.asarray(gyro_b, dtype=np.float64)[1:] * np.diff(t_s)[:, None]
    if theta.shape[0] == 0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    a = row_norm(theta)
    half = np.where(a > 1e-8, np.sin(0.5 * a) / np.where(a > 1e-8, a, 1.0), 0.5 - a * a / 48.0)
    q = np.column_stack([np.cos(0.5 * a), half[:, None] * theta])
    while q.shape[0] > 1:  # ordered pairwise products: (q1 q2)(q3 q4)...
        if q.shape[0] % 2:
            q = np.vstack([q, [1.0, 0.0, 0.0, 0.0]])
        q = quat_multiply(q[0::2], q[1::2])
        q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q[0]


def stance_reference(init: InitialState, gravity: float) -> tuple[np.ndarray, float]:
    """What the stance detector compares the samples with: (gyro bias, rad/s; gravity, m/s²) as THIS sensor
    read them at the initial rest, i.e. ``init.gyro_bias_b`` and ``|init.acc_mean_b|``.

    A zero-velocity detector tests "the rate is zero and the specific force is gravity" [Skog2010]. Given the
    raw rate of an uncalibrated MEMS gyro, a turn-on bias of 0.1-0.4 rad/s (MPU6050: ±20 °/s) is read as
    motion: the adaptive detector's noise floor rose by three decades, its floor rule then took slow foot
    motion (shuffling, stair descent) for stance, and a simulated 30-minute mission lost 2.5 % of its distance
    (docs/tuning-log.md, 2026-12-02). Likewise a scale or bias error makes ``|f|`` at rest differ from the true
    gravity by 0.1-1 m/s² (50-80 mg turn-on offsets), which the accelerometer term reads as motion. Both are
    what the initial alignment measured at rest; without a still period: (init's zero bias, ``gravity``).
    """
    bias = np.asarray(init.gyro_bias_b, dtype=np.float64)
    if init.still is None:
        return bias, float(gravity)
    g_rest = float(np.linalg.norm(init.acc_mean_b))
    return bias, (g_rest if np.isfinite(g_rest) and g_rest > 0 else float(gravity))


def load_accel_calibration(path: str | Path) -> AccelCalibration:
    """Read the accelerometer part of a calibration file (either format, ``SensorCalibration.load``);
    one-line InputError naming the file otherwise."""
    from bootnav.core.sensorcal import SensorCalibration
    from bootnav.errors import InputError

    cal = SensorCalibration.load(path)
    if cal.acc is None:
        raise InputError(f"{path}: has no accelerometer calibration")
    return AccelCalibration(bias_mps2=np.array(cal.acc.bias), matrix=np.array(cal.acc.matrix), source=str(path))


def apply_accel_calibration(acc_b, calib: AccelCalibration | dict | str | Path) -> np.ndarray:
    """f_corrected = M (f_raw − b), row-wise for (N, 3) ``acc_b``. ``calib`` may be a file path or a dict.

    The accelerometer part of ``SensorCalibration.apply`` (the one implementation of the correction)."""
    from bootnav.core.sensorcal import TriadCalibration

    if isinstance(calib, (str, Path)):
        calib = load_accel_calibration(calib)
    elif isinstance(calib, dict):
        calib = AccelCalibration(np.asarray(calib["bias_mps2"], float), np.asarray(calib["matrix"], float))
    return TriadCalibration(calib.matrix, calib.bias_mps2).apply(acc_b)


# ---------------------------------------------------------------------------------------------------------------
# Sensor calibration: which one applies, and applying it (module docstring)


@dataclass
class AppliedCalibration:
    """Which sensor calibration a run used (``resolve_calibration``) and what applying it said.

    calibration: the ``bootnav.core.sensorcal.SensorCalibration`` applied, or None.
    provenance: JSON-able dict for summary.json / results.h5: ``status`` ("applied" or "none"), ``how``
        (file / store / given) or ``reason`` (why none), and the calibration's own provenance (file, device id,
        date, residuals, temperature range).
    warnings: e.g. the recording's temperature leaves the calibrated range, or the file is another device's.
    """

    calibration: object | None
    provenance: dict
    warnings: list[str] = field(default_factory=list)


NO_CALIBRATION = ("none", "off", "false", "")


def resolve_calibration(settings: CalibrationSettings | None = None, device_id=None,
                        given=None) -> AppliedCalibration:
    """The sensor calibration that applies to a recording (module docstring: file > store > none).

    Parameters
    ----------
    settings
        ``sensor_calibration`` ("auto", "none" or a file) and the older ``accel_calibration_file``.
    device_id
        The recording's device id (its ``/meta`` ``device_id``), any form ``normalize_device_id`` reads; None
        when the recording has none (an imported file).
    given
        A ``SensorCalibration`` object (the Python API's ``calibration=``): used as it is; False disables.

    Returns
    -------
    AppliedCalibration
        Without samples applied yet (``apply_calibration`` adds the temperature warning).

    Raises
    ------
    InputError
        An unreadable calibration file (also a corrupt newest file in the store), or both settings set.
    """
    from bootnav.core.sensorcal import find_calibration, normalize_device_id, store_dir
    from bootnav.errors import InputError

    s = settings or CalibrationSettings()
    try:
        dev = normalize_device_id(device_id)
    except (ValueError, TypeError):
        dev = None
    choice = str(s.sensor_calibration if s.sensor_calibration is not None else "auto").strip()
    if s.accel_calibration_file:
        if choice.lower() not in ("auto",) + NO_CALIBRATION and choice != s.accel_calibration_file:
            raise InputError(f"settings calibration: both sensor_calibration ({choice}) and accel_calibration_file "
                             f"({s.accel_calibration_file}) are set; give one calibration file")
        choice = str(s.accel_calibration_file)
    warnings: list[str] = []
    if given is False:
        return AppliedCalibration(None, {"status": "none", "reason": "disabled (calibration=False)"})
    if given is not None:
        cal, how = given, "given"
    elif choice.lower() in NO_CALIBRATION:
        return AppliedCalibration(None, {"status": "none", "reason": "disabled (--no-calibration)"})
    elif choice.lower() == "given":
        raise InputError("settings calibration.sensor_calibration 'given' needs a calibration object "
                         "(bootnav.process(..., calibration=...)); use a file, 'auto' or 'none'")
    elif choice.lower() == "auto":
        if dev is None:
            return AppliedCalibration(None, {"status": "none", "reason": "the recording has no device id"})
        cal, how = find_calibration(dev), "store"
        if cal is None:
            return AppliedCalibration(None, {"status": "none", "device_id": dev,
                                             "reason": f"no calibration of device {dev} in {store_dir()}"})
    else:
        from bootnav.core.sensorcal import SensorCalibration

        cal, how = SensorCalibration.load(choice), "file"
    if how != "store" and dev is not None and cal.device_id and cal.device_id != dev:
        warnings.append(f"calibration {cal.source or ''} is of device {cal.device_id}, the recording of device "
                        f"{dev}: check that it belongs to this boot")
    prov = {"status": "applied", "how": how, **cal.provenance()}
    if dev is not None:
        prov["recording_device_id"] = dev
    return AppliedCalibration(cal, prov, warnings)


def apply_calibration(applied: AppliedCalibration, acc_b, gyro_b, temp_degc=None):
    """``(acc_b, gyro_b)`` corrected by ``applied.calibration`` (the inputs themselves when there is none).

    ``temp_degc``: the recording's sensor temperature per sample (°C) or None; the bias temperature term is
    applied with it, and a temperature outside the calibrated range adds a warning to ``applied``.
    """
    cal = applied.calibration
    if cal is None:
        return acc_b, gyro_b
    from bootnav.core.sensorcal import temperature_warning

    acc, gyro = cal.apply(acc_b, gyro_b, temp_degc)
    if temp_degc is not None:
        w = temperature_warning(cal, temp_degc)
        if w and w not in applied.warnings:
            applied.warnings.append(w)
        t = np.asarray(temp_degc, dtype=np.float64)
        t = t[np.isfinite(t)]
        if t.size:
            applied.provenance["recording_temp_range_degc"] = [float(t.min()), float(t.max())]
    applied.provenance["temperature_applied"] = temp_degc is not None
    return acc, gyro
