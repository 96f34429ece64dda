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

Accelerometer calibration (optional JSON file ``{"bias_mps2": [bx, by, bz], "matrix": [[...3x3...]]}``)::

    f_corrected = M (f_raw − b)

M holds scale factors on its diagonal and misalignment / cross-axis terms off it (e.g. from a six-position
test: the model of [IEEE1293], inverted).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core.rotations import quat_from_euler_zyx
from bootnav.core.runs import runs
from bootnav.core.timebase import sample_period

from bootnav.core.arrays import moving_mean, row_norm, rows_finite

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
    use_gyro_bias: subtract the still-period gyro mean as the initial gyro bias.
    accel_calibration_file: JSON file with bias_mps2 and matrix (see module docstring), or None.
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
    use_gyro_bias: bool = True
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


def still_mask(t_s, acc_b, gyro_b, settings: CalibrationSettings | None = None, gravity: float = 9.80665) -> np.ndarray:
    """Samples whose centred window (``still_window_s``) passes every still test (bool (N,))."""
    from scipy.ndimage import maximum_filter1d

    s = settings or CalibrationSettings()
    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    n = max(3, int(round(s.still_window_s / sample_period(t_s))))
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


def find_still_period(t_s, acc_b, gyro_b, *, min_duration_s: float = 0.5, settings: CalibrationSettings | None = None,
                      gravity: float = 9.80665) -> slice | None:
    """The initial still period: the first run of still samples that starts within ``still_search_s`` of
    the start and lasts at least ``min_duration_s`` (truncated to ``max_still_s``). None if there is none."""
    s = settings or CalibrationSettings()
    t_s = np.asarray(t_s, dtype=np.float64)
    ok = still_mask(t_s, acc_b, gyro_b, s, gravity)
    if not ok.any():
        return None
    starts, stops = runs(ok)  # stops exclusive
    dt = sample_period(t_s)
    dur = t_s[stops - 1] - t_s[starts] + dt
    good = (dur >= min_duration_s) & (t_s[starts] - t_s[0] <= s.still_search_s)
    if not good.any():
        return None
    i = int(np.flatnonzero(good)[0])
    start, stop = int(starts[i]), int(stops[i])
    stop = min(stop, int(np.searchsorted(t_s, t_s[start] + s.max_still_s)))
    return slice(start, max(stop, start + 1))


def quiet_core(t_s, gyro_b, still: slice, settings: CalibrationSettings | None = None) -> np.ndarray:
    """Bool mask over the samples of ``still``: local rate variance (summed over axes, centred window of
    ``still_window_s``) <= ``still_quiet_ratio`` × its minimum over the period (all True when the ratio is 0)."""
    s = settings or CalibrationSettings()
    g = np.asarray(gyro_b, dtype=np.float64)[still]
    if s.still_quiet_ratio <= 0 or g.shape[0] < 3:
        return np.ones(g.shape[0], dtype=bool)
    n = max(3, int(round(s.still_window_s / sample_period(t_s))))
    m = moving_mean(g, n)
    var = np.maximum(moving_mean(g**2, n) - m**2, 0.0).sum(axis=1)
    return var <= s.still_quiet_ratio * var.min()


def roll_pitch_from_specific_force(f_b) -> tuple[float, float]:
    """Roll and pitch (rad) that make C_nb f_b point up (module docstring)."""
    fx, fy, fz = (float(v) for v in f_b)
    return math.atan2(fy, fz), math.atan2(-fx, math.hypot(fy, fz))


def initial_alignment(t_s, acc_b, gyro_b, settings: CalibrationSettings | None = None,
                      gravity: float | None = None) -> InitialState:
    """Roll/pitch from the mean specific force of the initial still period, yaw = 0, gyro bias = its mean
    rate (both over its quiet core, ``quiet_core``). Without a still period: levelling on the first ``min_still_s`` of data, zero bias, and a warning."""
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
    still = find_still_period(t_s, acc_b, gyro_b, min_duration_s=s.min_still_s, settings=s, gravity=g)
    if still is None:
        n = max(1, int(np.searchsorted(t_s, t_s[0] + s.min_still_s)))
        f_mean = np.nanmean(acc_b[:n], axis=0)
        bias = np.zeros(3)
        warnings.append(
            f"no initial still period (>= {s.min_still_s:g} s of rest within the first {s.still_search_s:g} s): "
            f"roll/pitch levelled on the first {t_s[n - 1] - t_s[0]:.2f} s of motion data (may be wrong by "
            "degrees) and gyro bias set to zero; start recordings with the foot at rest for a few seconds"
        )
    else:
        quiet = quiet_core(t_s, gyro_b, still, s)  # motion inside the still period is not bias
        f_mean = acc_b[still][quiet].mean(axis=0)
        bias = gyro_b[still][quiet].mean(axis=0) if s.use_gyro_bias else np.zeros(3)
        dur = t_s[still.stop - 1] - t_s[still.start]
        if abs(np.linalg.norm(f_mean) - g) > 0.3:
            warnings.append(
                f"|specific force| at rest is {np.linalg.norm(f_mean):.3f} m/s^2 vs gravity {g:.3f} m/s^2: "
                "the accelerometer looks uncalibrated (consider an accel calibration file)"
            )
        if dur < 1.0:
            warnings.append(f"initial still period is short ({dur:.2f} s); gyro bias estimate is noisy")
    roll, pitch = roll_pitch_from_specific_force(f_mean)
    return InitialState(q_nb=quat_from_euler_zyx(roll, pitch, 0.0), gyro_bias_b=np.asarray(bias, dtype=np.float64),
                        acc_mean_b=np.asarray(f_mean, dtype=np.float64), still=still, gravity=g,
                        warnings=warnings, roll_rad=roll, pitch_rad=pitch)


def load_accel_calibration(path: str | Path) -> AccelCalibration:
    """Read ``{"bias_mps2": [3 numbers], "matrix": [[3x3 numbers]]}``; clear error naming the file otherwise."""
    from bootnav.errors import InputError

    from bootnav.core.jsonio import read_json_file

    path = Path(path)
    doc = read_json_file(path, "accelerometer calibration file")
    try:
        bias = np.asarray(doc["bias_mps2"], dtype=np.float64)
        mat = np.asarray(doc["matrix"], dtype=np.float64)
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"{path}: needs keys 'bias_mps2' (3 numbers) and 'matrix' (3x3 numbers): {e}") from None
    if bias.shape != (3,) or mat.shape != (3, 3) or not (np.all(np.isfinite(bias)) and np.all(np.isfinite(mat))):
        raise InputError(f"{path}: 'bias_mps2' must be 3 finite numbers and 'matrix' 3x3 finite numbers; "
                         f"got shapes {bias.shape} and {mat.shape}")
    if abs(np.linalg.det(mat)) < 1e-6:
        raise InputError(f"{path}: 'matrix' is singular (det {np.linalg.det(mat):.3g})")
    return AccelCalibration(bias_mps2=bias, matrix=mat, source=str(path))


def apply_accel_calibration(acc_b, calib: AccelCalibration | dict | str | Path) -> np.ndarray:
    """f_corrected = M (f_raw − b), row-wise for (N, 3) ``acc_b``. ``calib`` may be a file path or a dict."""
    if isinstance(calib, (str, Path)):
        calib = load_accel_calibration(calib)
    elif isinstance(calib, dict):
        calib = AccelCalibration(np.asarray(calib["bias_mps2"], float), np.asarray(calib["matrix"], float))
    acc_b = np.asarray(acc_b, dtype=np.float64)
    return np.ascontiguousarray((acc_b - calib.bias_mps2) @ calib.matrix.T)
