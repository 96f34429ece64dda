"""Gyroscope calibration from the rotations between static poses: scale and full misalignment.

Derivation
----------
Between two static poses i and i+1 the body turns by R_i,i+1 (body at i+1 → body at i). Integrating the
corrected rate ω̂ = C (y − b_i(t)) from the end anchor of pose i to the start anchor of pose i+1 gives the
quaternion q(C) = ⊗_k exp(ω̄̂_k Δt_k / 2) (the exact rotation of a constant rate over each sample interval,
ω̄ the mean of the interval's two end samples; applied in body order, q ← q ⊗ exp(·), as the filter's
``quat_times_exp``). The calibrated accelerometer gives the up direction u (unit specific force) at both
anchors; a correct C carries one to the other [Tedaldi2014, eq. 13]::

    r_i(C) = R(q)ᵀ u_i − u_{i+1} = 0                        (3 components, 2 independent)

Gravity cannot see a rotation about the vertical, so a full turn of the boot flat on a table (start and end
anchors show the same u) says nothing through r_i. It is the same pose before and after, though, so the
angle turned about the vertical is 2πn (n = round(angle / 2π)) up to how well the person put the boot back
(``turn_heading_sigma_rad``)::

    r_turn(C) = (Σ_k (ω̄̂_k · u_i) Δt_k − 2πn) / σ_turn · σ_dir

(u_i is fixed in the body during a flat turn). n turns observe the scale about the axis that was vertical to
σ_turn / (2πn); the cross-axis terms of that axis need rotations about it while it is horizontal.

The bias b_i(t) is not fitted here: it is the mean rate of the two poses around the motion, interpolated
linearly in time (a slow drift from warm-up or bias instability cancels), so each motion carries its own
bias and C alone (9 parameters, a full matrix: it also rotates the gyro's axes into the accelerometer's
frame) is estimated by nonlinear least squares, from C = I. Σ_C = s² (JᵀJ)⁻¹ as in ``accel_fit``.

Rotation about axis a observes column a of C only when axis a is not vertical; ``axis_coverage`` measures
that (the integrated |rate| about each axis times the sine of its angle to the vertical) to name the
missing rotation in an error message.

References: [Tedaldi2014], [imu_tk], [Skog2006].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..ins.kernels import quat_times_exp, rotmat_into
from .accel_fit import AXES, _pinv_normal


@njit(cache=True)
def integrate_segments(omega, dt, seg_start, seg_stop):  # pragma: no cover - numba
    """Quaternion (wxyz) of each segment: q = ⊗ exp(ω̄_k Δt_k / 2) over samples [start, stop), ω̄ the mean
    of samples k and k+1, Δt_k = dt[k] (so ``stop`` is the index of the last sample + 0 and the segment ends
    at sample ``stop``)."""
    k_seg = seg_start.shape[0]
    out = np.empty((k_seg, 4))
    for s in range(k_seg):
        qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
        for k in range(seg_start[s], seg_stop[s]):
            h = 0.5 * dt[k]
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, h * (omega[k, 0] + omega[k + 1, 0]),
                                            h * (omega[k, 1] + omega[k + 1, 1]), h * (omega[k, 2] + omega[k + 1, 2]))
        out[s, 0], out[s, 1], out[s, 2], out[s, 3] = qw, qx, qy, qz
    return out


@njit(cache=True)
def rotmats(q):  # pragma: no cover - numba
    out = np.empty((q.shape[0], 3, 3))
    for i in range(q.shape[0]):
        rotmat_into(out[i], q[i, 0], q[i, 1], q[i, 2], q[i, 3])
    return out


@dataclass
class Motions:
    """The motions between consecutive static poses, concatenated over sessions.

    y: (M, 3) raw rate minus the interpolated bias, for every sample of every motion (rad/s); dt: (M,) s;
    start, stop: (K,) segment index ranges into y (integration runs over [start, stop] inclusive);
    u_from, u_to: (K, 3) unit up vectors at the anchors (calibrated accelerometer); turn_n: (K,) number of
    full turns (0 = not a turn); label: (K,) text naming the motion (session and poses).
    """

    y: np.ndarray
    dt: np.ndarray
    start: np.ndarray
    stop: np.ndarray
    u_from: np.ndarray
    u_to: np.ndarray
    turn_n: np.ndarray
    label: list
    acc_from: np.ndarray | None = None  # (K, 3) raw anchor specific force (m/s²) behind u_from
    acc_to: np.ndarray | None = None
    dtemp_from: np.ndarray | None = None  # (K,) T − T_ref at the anchors (°C)
    dtemp_to: np.ndarray | None = None


@dataclass
class GyroFit:
    matrix: np.ndarray  # (3, 3) C
    names: list
    cov: np.ndarray  # (9, 9)
    residual_rad: np.ndarray  # (K,) angle between predicted and measured up direction per motion
    turn_residual_rad: np.ndarray  # (K,) heading error after full turns (NaN for other motions)
    sigma0: float

    def sigma(self) -> dict:
        sd = np.sqrt(np.maximum(np.diag(self.cov), 0.0))
        return {k: float(v) for k, v in zip(self.names, sd)}


def param_names() -> list[str]:
    return [f"C_{AXES[i]}{AXES[j]}" for i in range(3) for j in range(3)]


def _predict(c: np.ndarray, mo: Motions):
    w = mo.y @ c.T
    q = integrate_segments(w, mo.dt, mo.start, mo.stop)
    r = rotmats(q)
    u_pred = np.einsum("kji,kj->ki", r, mo.u_from)  # Rᵀ u_from
    yaw = np.full(mo.start.shape, np.nan)
    turns = np.flatnonzero(mo.turn_n != 0)
    if turns.size:
        cs = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (w[:-1] + w[1:]) * mo.dt[:-1, None], axis=0)])
        ang = cs[mo.stop[turns]] - cs[mo.start[turns]]  # ∫ω̂ dt per turn (rad, body axes)
        yaw[turns] = np.einsum("ij,ij->i", ang, mo.u_from[turns])
    return u_pred, yaw


def fit_gyroscope(mo: Motions, pose_sigma_rad: float, turn_sigma_rad: float, accel=None) -> GyroFit:
    """Nonlinear least squares for the full C (module docstring).

    ``accel`` (an ``accel_fit.AccelFit``) adds the accelerometer's uncertainty to C's covariance: the up
    directions come from the calibrated accelerometer, so its errors move every u alike and do not average
    out over the motions (``_accel_propagation``).
    """
    from scipy.optimize import least_squares

    turns = mo.turn_n != 0
    target = 2.0 * math.pi * mo.turn_n[turns]
    wt = pose_sigma_rad / turn_sigma_rad

    def resid(theta):
        u_pred, yaw = _predict(theta.reshape(3, 3), mo)
        r = (u_pred - mo.u_to).ravel()
        return np.concatenate([r, wt * (yaw[turns] - target)])

    sol = least_squares(resid, np.eye(3).ravel(), method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14,
                        gtol=1e-14, max_nfev=100)
    r = sol.fun
    n_obs = 2 * mo.start.shape[0] + int(turns.sum())  # a unit-vector difference has 2 degrees of freedom
    s2 = float(r @ r) / max(n_obs - 9, 1)
    inv_n = _pinv_normal(sol.jac)
    cov = s2 * inv_n
    if accel is not None and mo.acc_from is not None:
        cov = cov + _accel_propagation(sol, inv_n, mo, accel, resid)
    c = sol.x.reshape(3, 3)
    u_pred, yaw = _predict(c, mo)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", u_pred, mo.u_to) /
                            (np.linalg.norm(u_pred, axis=1) * np.linalg.norm(mo.u_to, axis=1)), -1.0, 1.0))
    turn_res = np.full(mo.start.shape, np.nan)
    turn_res[turns] = yaw[turns] - target
    return GyroFit(matrix=c, names=param_names(), cov=cov, residual_rad=ang, turn_residual_rad=turn_res,
                   sigma0=float(np.sqrt(s2)))


def _accel_propagation(sol, inv_n, mo: Motions, accel, resid) -> np.ndarray:
    """A Σ_a Aᵀ with A = ∂C/∂θ_a = −(JᵀJ)⁻¹ Jᵀ ∂r/∂θ_a (implicit function theorem at the optimum;
    ∂r/∂θ_a by central differences of the up vectors), Σ_a the accelerometer fit's covariance."""
    from .accel_fit import unpack

    fit_temp = accel.theta.shape[0] > 9
    cov_a = accel.cov
    if not np.all(np.isfinite(cov_a)):
        return np.zeros((9, 9))
    saved = (mo.u_from, mo.u_to)
    cols = []
    try:
        for j in range(accel.theta.shape[0]):
            h = max(1e-7, 1e-3 * math.sqrt(cov_a[j, j]))
            rs = []
            for sgn in (1.0, -1.0):
                th = accel.theta.copy()
                th[j] += sgn * h
                c, b, k = unpack(th, fit_temp)
                mo.u_from = _unit_rows((mo.acc_from - b - mo.dtemp_from[:, None] * k) @ c.T)
                mo.u_to = _unit_rows((mo.acc_to - b - mo.dtemp_to[:, None] * k) @ c.T)
                rs.append(resid(sol.x))
            cols.append((rs[0] - rs[1]) / (2 * h))
    finally:
        mo.u_from, mo.u_to = saved
    dr = np.column_stack(cols)
    a = -(inv_n @ sol.jac.T) @ dr
    return a @ cov_a @ a.T


def _unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def axis_coverage(mo: Motions) -> np.ndarray:
    """(3,) rad: per body axis, Σ over non-turn motions of |∫ω_a dt| × sin(angle of axis a to the vertical at
    the start): how much rotation about that axis gravity could see."""
    if mo.start.size == 0:
        return np.zeros(3)
    cs = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (mo.y[:-1] + mo.y[1:]) * mo.dt[:-1, None], axis=0)])
    ang = np.abs(cs[mo.stop] - cs[mo.start])
    sin_tilt = np.sqrt(np.maximum(1.0 - mo.u_from**2, 0.0))
    sin_tilt_end = np.sqrt(np.maximum(1.0 - mo.u_to**2, 0.0))
    use = (mo.turn_n == 0)[:, None]
    return (ang * np.maximum(sin_tilt, sin_tilt_end) * use).sum(axis=0)
