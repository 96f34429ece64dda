"""The footprints' horizontal covariance: the filter's, plus what the sensor's scale errors do to the path.

The filter's state carries white noise and bias random walks, not the inertial unit's scale-factor errors
(constant over a mission: ±3 % for an uncalibrated MPU-6050 [InvenSense2013], about 0.1 % left after a
calibration). Its position covariance therefore describes a perfectly scaled unit, and its ellipse was
≈ 12× too small on uncalibrated missions (docs/floors.md). The scale errors are constants, so to first order
the footprint error they cause is LINEAR in them and follows from the path itself:

* **distance scale** s_a (accelerometer scale along the walking direction: a stride measured (1 + s_a) long):
  δp_k = s_a (p_k − p_0);
* **turn scale** s_g (gyro scale about the vertical: every turn measured (1 + s_g) times its angle): the heading
  of stride j is off by s_g (ψ_j − ψ_0), which turns that stride: δp_k = s_g Σ_{j≤k} (ψ_j − ψ_0) e_z × Δp_j,
  ψ the foot's unwrapped yaw (every turn counts, in place or walking; the initial heading is the frame's).

* **cross-axis** m (the accelerometer's horizontal axes turned by m against the gyro's, the datasheet's
  cross-axis sensitivity read as an angle): every stride turned by m, δp_k = m e_z × (p_k − p_0).

With s_a, s_g independent, zero mean, standard deviation σ_s each, the added covariance of footprint k is
σ_s² (J_a J_aᵀ + J_g J_gᵀ) + σ_m² J_m J_mᵀ with J_m = e_z × J_a, J_a = p_k − p_0 and J_g = Σ_{j≤k} (ψ_j − ψ_0) e_z × Δp_j (2-vectors), the
first-order propagation of a constant parameter error [Groves2013, ch. 14 "error budgets"]. The filter's
gains are untouched (the path does not change); only the reported uncertainty does. Over a stride J_g and
J_a hardly change, so this is per footprint, one vector operation over all of them (no per-sample loop).

σ_s: the datasheet's ±3 % scale tolerance read as ±3σ (σ = 1 %, as the simulator's profile reads it) when no
sensor calibration is applied, and σ_m = ±2 % cross-axis as ±3σ (0.67 %); 0.1 % for both when one is (the
scale and cross-axis error left after ``bootnav calibrate``, issue 24). Settings: ``ProcessSettings.ellipse_*``.
"""

from __future__ import annotations

import numpy as np

from bootnav.core.rotations import euler_zyx_from_quat


def unwrapped_yaw(q_nb: np.ndarray) -> np.ndarray:
    """The body's yaw (rad, ENU, about the vertical) of every sample, unwrapped (a continuous angle: turns add)."""
    return np.unwrap(np.asarray(euler_zyx_from_quat(np.asarray(q_nb, float)), float)[..., 2])


def scale_error_covariance(fp_en: np.ndarray, yaw_fp: np.ndarray, sigma_scale: float,
                           sigma_cross: float = 0.0) -> np.ndarray:
    """The horizontal covariance (K, 3) = (EE, NN, EN), m², that scale errors of ``sigma_scale`` (1σ, relative)
    and a horizontal cross-axis angle of ``sigma_cross`` (1σ, rad) add to each footprint (module docstring).

    Parameters
    ----------
    fp_en : (K, 2) or (K, 3) footprints, m (east, north first), in walking order.
    yaw_fp : (K,) unwrapped yaw of the foot at each footprint, rad.
    sigma_scale : standard deviation of the distance and turn scale errors (dimensionless).
    sigma_cross : standard deviation of the accelerometer's horizontal cross-axis angle, rad.
    """
    return ScaleErrorAccumulator(sigma_scale, sigma_cross).push(fp_en, yaw_fp)


class ScaleErrorAccumulator:
    """``scale_error_covariance`` of footprints pushed in consecutive batches (the live view: causal, the same
    numbers for any batching; memory: the running J_g and the first and last footprint)."""

    def __init__(self, sigma_scale: float, sigma_cross: float = 0.0):
        self.s2, self.c2 = float(sigma_scale) ** 2, float(sigma_cross) ** 2
        self._first: np.ndarray | None = None  # (x, y, yaw) of the first footprint
        self._last: np.ndarray | None = None  # (x, y, yaw) of the last footprint pushed
        self._j_g = np.zeros(2)

    def push(self, fp_en: np.ndarray, yaw_fp: np.ndarray) -> np.ndarray:
        """The (m, 3) added covariance of the next m footprints (``scale_error_covariance``'s parameters)."""
        fp = np.asarray(fp_en, float).reshape(len(yaw_fp), -1)[:, :2]
        yaw = np.asarray(yaw_fp, float)
        out = np.zeros((len(fp), 3))
        if len(fp) == 0:
            return out
        if self._first is None:
            self._first = np.array([fp[0, 0], fp[0, 1], yaw[0]])
            self._last = self._first.copy()
        x0, y0, yaw0 = self._first
        prev = np.vstack((self._last[None, :2], fp[:-1]))
        prev_yaw = np.concatenate(([self._last[2]], yaw[:-1]))
        step = fp - prev
        turn = 0.5 * (yaw + prev_yaw) - yaw0  # the heading change (from the start) of each step
        perp = np.column_stack((-step[:, 1], step[:, 0]))  # e_z × Δp
        j_g = self._j_g + np.cumsum(turn[:, None] * perp, axis=0)
        j_a = fp - np.array([x0, y0])
        j_m = np.column_stack((-j_a[:, 1], j_a[:, 0]))  # e_z × (p_k − p_0): every stride turned by the angle
        for col, (u, v) in enumerate(((0, 0), (1, 1), (0, 1))):
            out[:, col] = self.s2 * (j_a[:, u] * j_a[:, v] + j_g[:, u] * j_g[:, v]) + self.c2 * j_m[:, u] * j_m[:, v]
        self._j_g = j_g[-1].copy()
        self._last = np.array([fp[-1, 0], fp[-1, 1], yaw[-1]])
        return out


def scale_sigmas(settings, calibrated: bool) -> tuple[float, float]:
    """(σ_scale, σ_cross) of ``ProcessSettings.ellipse_*`` for a run with or without a sensor calibration."""
    if calibrated:
        return float(settings.ellipse_calibrated_sigma), float(settings.ellipse_calibrated_sigma)
    return float(settings.ellipse_scale_sigma), float(settings.ellipse_cross_axis_rad)


def stride_scale_covariance(t_s: np.ndarray, pos_n: np.ndarray, stance: np.ndarray, q_nb: np.ndarray, settings,
                            calibrated: bool) -> np.ndarray:
    """``scale_error_covariance`` of every stance phase of a path (K, 3), with the σ's of ``settings``
    (``ProcessSettings.ellipse_*``; ``calibrated``: a sensor calibration was applied)."""
    from bootnav.postproc.strides import footprints, phase_ends

    _, fp = footprints(np.asarray(t_s, float), np.asarray(pos_n, float), stance)
    if len(fp) == 0:
        return np.zeros((0, 3))
    yaw = unwrapped_yaw(q_nb)[phase_ends(np.asarray(stance, bool))]
    return scale_error_covariance(fp, yaw, *scale_sigmas(settings, calibrated))
