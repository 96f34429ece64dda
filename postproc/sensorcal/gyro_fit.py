"""Gyroscope calibration from the rotations between static poses: scale, full misalignment and bias.

Derivation
----------
Between two static poses i and i+1 the body turns by R_i,i+1 (body at i+1 → body at i). Integrating the
corrected rate ω̂ = C (y − b(t)) over the samples from the middle of pose i to the middle of pose i+1 gives
the quaternion q = ⊗_k exp(ω̄̂_k Δt_k / 2) (the exact rotation of a constant rate over each sample interval,
ω̄ the mean of its two end samples, applied in body order q ← q ⊗ exp(·) as the filter's
``quat_times_exp``). The calibrated accelerometer gives the up direction u_i at the middle of each pose; a
correct C carries one to the next [Tedaldi2014, eq. 13]::

    r_i = R(q)ᵀ u_i − u_{i+1} = 0                      (3 components, 2 independent)

A boot held by hand is never still: it sways by a few tenths of a degree at 0.1–1 Hz and trembles at
8–12 Hz. So u_i is not a plain mean of the pose's specific force but a motion-compensated one: every sample
f̂_k of the pose is first rotated into the body frame at the pose's middle sample m by the gyro itself,
u_i ∝ Σ_k R(m←k) f̂_k, with R from the same integrator (the rotations are milliradians, so C's own error
hardly enters). A wrong bias makes the two halves of a pose disagree (the compensated gravity turns by
b × T/2), which gives a second residual per pose that observes the bias perpendicular to gravity::

    r_pose = unit(Σ_first half) − unit(Σ_second half)

and the bias is a parameter here: b_s + d_s (t − t̄_s) per session s (a constant and a linear drift, which
covers the die's warm-up over a few minutes), started from the median of the poses' mean rates.

Gravity cannot see a rotation about the vertical, so a full turn of the boot flat on a table (the same u
before and after) says nothing through r_i. The angle turned about the vertical, Σ_k (ω̄̂_k · u_i) Δt_k,
is 2πn (n = round(angle / 2π)) up to how well the person put the boot back, σ_turn
(``turn_heading_sigma_rad``)::

    r_turn = (Σ_k (ω̄̂_k · u_i) Δt_k − 2πn) σ_dir / σ_turn

so n turns observe the scale about the vertical axis to σ_turn / (2πn); the cross-axis terms of that axis
need rotations about it while it is horizontal.

All residuals are solved together for θ = (C (9, a full matrix: it also rotates the gyro's axes into the
accelerometer's frame), b_s, d_s) by nonlinear least squares from C = I. Σ_θ = s² (JᵀJ)⁻¹ as in
``accel_fit``, plus the accelerometer fit's covariance carried through the up vectors
(``_accel_propagation``): its errors move every u alike and do not average out over the motions.

A rotation about axis a observes column a of C only when axis a is not vertical; ``axis_coverage`` measures
that to name the missing rotation in an error message.

References: [Tedaldi2014], [imu_tk], [Skog2006].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..ins.kernels import quat_times_exp, rotmat_into
from .accel_fit import AXES, pinv_normal, unpack


@njit(cache=True)
def integrate_segments(omega, dt, seg_start, seg_stop):  # pragma: no cover - numba
    """Quaternion (wxyz) of each segment: q = ⊗ exp(ω̄_k Δt_k / 2) for k in [start, stop), ω̄_k the mean of
    samples k and k+1 (the segment runs from sample ``start`` to sample ``stop``)."""
    out = np.empty((seg_start.shape[0], 4))
    for s in range(seg_start.shape[0]):
        qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
        for k in range(seg_start[s], seg_stop[s]):
            h = 0.5 * dt[k]
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, h * (omega[k, 0] + omega[k + 1, 0]),
                                            h * (omega[k, 1] + omega[k + 1, 1]), h * (omega[k, 2] + omega[k + 1, 2]))
        out[s, 0], out[s, 1], out[s, 2], out[s, 3] = qw, qx, qy, qz
    return out


@njit(cache=True)
def pose_sums(omega, dt, f, start, mid, stop):  # pragma: no cover - numba
    """(P, 2, 3): Σ R(mid←k) f_k over k in [start, mid] and over [mid, stop) (the middle sample in both)."""
    out = np.zeros((start.shape[0], 2, 3))
    c = np.empty((3, 3))
    for p in range(start.shape[0]):
        m = mid[p]
        for half in range(2):
            qw, qx, qy, qz = 1.0, 0.0, 0.0, 0.0
            if half == 0:
                k, step, end = m, -1, start[p] - 1
            else:
                k, step, end = m, 1, stop[p]
            while k != end:
                if k != m:
                    if step == 1:
                        j = k - 1
                        h = 0.5 * dt[j]
                    else:
                        j = k
                        h = -0.5 * dt[j]
                    qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, h * (omega[j, 0] + omega[j + 1, 0]),
                                                    h * (omega[j, 1] + omega[j + 1, 1]),
                                                    h * (omega[j, 2] + omega[j + 1, 2]))
                rotmat_into(c, qw, qx, qy, qz)
                for i in range(3):
                    out[p, half, i] += c[i, 0] * f[k, 0] + c[i, 1] * f[k, 1] + c[i, 2] * f[k, 2]
                k += step
    return out


@njit(cache=True)
def corrected_rates(y, t_rel, sess, c, bias, drift):  # pragma: no cover - numba
    """ω̂_k = C (y_k − b_s − d_s t_k) for every sample (s = sess[k]): one pass, no temporaries."""
    out = np.empty_like(y)
    for k in range(y.shape[0]):
        s = sess[k]
        e0 = y[k, 0] - bias[s, 0] - drift[s, 0] * t_rel[k]
        e1 = y[k, 1] - bias[s, 1] - drift[s, 1] * t_rel[k]
        e2 = y[k, 2] - bias[s, 2] - drift[s, 2] * t_rel[k]
        for i in range(3):
            out[k, i] = c[i, 0] * e0 + c[i, 1] * e1 + c[i, 2] * e2
    return out


@njit(cache=True)
def rotmats(q):  # pragma: no cover - numba
    out = np.empty((q.shape[0], 3, 3))
    for i in range(q.shape[0]):
        rotmat_into(out[i], q[i, 0], q[i, 1], q[i, 2], q[i, 3])
    return out


@dataclass
class GyroData:
    """Every session's samples concatenated, with the poses and the motions between them.

    y: (N, 3) raw rate (rad/s); acc: (N, 3) raw specific force (m/s²); dtemp: (N,) T − T_ref (°C, 0 without);
    t_rel: (N,) time from the session's middle (s); dt: (N,) step to the next sample (0 at a session's end);
    sess: (N,) session index; pose_start, pose_mid, pose_stop: (P,) sample indices; mo_from, mo_to: (K,)
    pose indices of each motion; turn_n: (K,) full turns (0 = not a turn); label: (K,) text per motion.
    """

    y: np.ndarray
    acc: np.ndarray
    dtemp: np.ndarray
    t_rel: np.ndarray
    dt: np.ndarray
    sess: np.ndarray
    n_sessions: int
    pose_start: np.ndarray
    pose_mid: np.ndarray
    pose_stop: np.ndarray
    mo_from: np.ndarray
    mo_to: np.ndarray
    turn_n: np.ndarray
    label: list


@dataclass
class GyroFit:
    matrix: np.ndarray  # (3, 3) C
    bias: np.ndarray  # (S, 3) per-session bias at the session's middle (rad/s)
    bias_drift: np.ndarray  # (S, 3) rad/s per s
    names: list
    cov: np.ndarray
    residual_rad: np.ndarray  # (K,) angle between carried and measured up direction per motion
    pose_residual_rad: np.ndarray  # (P,) angle between the two halves of each pose
    turn_residual_rad: np.ndarray  # (K,) heading error after full turns (NaN for other motions)
    sigma0: float

    def sigma(self) -> dict:
        sd = np.sqrt(np.maximum(np.diag(self.cov), 0.0))
        return {k: float(v) for k, v in zip(self.names, sd)}


def param_names(n_sessions: int) -> list[str]:
    names = [f"C_{AXES[i]}{AXES[j]}" for i in range(3) for j in range(3)]
    for s in range(n_sessions):
        names += [f"session{s}_bias_{a}" for a in AXES] + [f"session{s}_bias_drift_{a}" for a in AXES]
    return names


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


class _Model:
    """Residuals of the module docstring for parameters θ = (C, b_s, d_s) and given accelerometer params."""

    def __init__(self, gd: GyroData, accel, acc_theta: np.ndarray, pose_sigma: float, turn_sigma: float):
        self.accel = accel
        self.gd = gd
        self.turns = np.flatnonzero(gd.turn_n != 0)
        self.target = 2.0 * math.pi * gd.turn_n[self.turns]
        self.wt = pose_sigma / turn_sigma
        self.w_pose = 1.0  # weight of the pose residuals relative to the motions (variance components)
        self.set_accel(acc_theta)

    def set_accel(self, acc_theta):
        a = self.accel
        c, _, k, _ = unpack(acc_theta, a.fit_temp, a.n_sessions)
        b_s = a.session_bias(acc_theta)  # (S, 3): each power-on's own bias
        self.f = np.ascontiguousarray((self.gd.acc - b_s[self.gd.sess] - self.gd.dtemp[:, None] * k) @ c.T)

    def omega(self, theta):
        gd = self.gd
        bd = theta[9:].reshape(gd.n_sessions, 2, 3)
        return corrected_rates(gd.y, gd.t_rel, gd.sess, np.ascontiguousarray(theta[:9].reshape(3, 3)),
                               np.ascontiguousarray(bd[:, 0]), np.ascontiguousarray(bd[:, 1]))

    def parts(self, theta):
        gd = self.gd
        w = self.omega(theta)
        sums = pose_sums(w, gd.dt, self.f, gd.pose_start, gd.pose_mid, gd.pose_stop)
        u = _unit(sums.sum(axis=1))
        r_pose = _unit(sums[:, 0]) - _unit(sums[:, 1])
        q = integrate_segments(w, gd.dt, gd.pose_mid[gd.mo_from], gd.pose_mid[gd.mo_to])
        rm = rotmats(q)
        u_from, u_to = u[gd.mo_from], u[gd.mo_to]
        u_pred = np.einsum("kji,kj->ki", rm, u_from)  # Rᵀ u_from
        yaw = np.full(gd.mo_from.shape, np.nan)
        if self.turns.size:
            cs = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (w[:-1] + w[1:]) * gd.dt[:-1, None], axis=0)])
            a, b = gd.pose_mid[gd.mo_from[self.turns]], gd.pose_mid[gd.mo_to[self.turns]]
            yaw[self.turns] = np.einsum("ij,ij->i", cs[b] - cs[a], u_from[self.turns])
        return u_pred, u_to, r_pose, yaw

    def __call__(self, theta):
        u_pred, u_to, r_pose, yaw = self.parts(theta)
        return np.concatenate([(u_pred - u_to).ravel(), self.w_pose * r_pose.ravel(),
                               self.wt * (yaw[self.turns] - self.target)])


def initial_theta(gd: GyroData, pose_rate_mean: np.ndarray) -> np.ndarray:
    """C = I, per-session bias = median of its poses' mean rates, drift 0."""
    th = [np.eye(3).ravel()]
    pose_sess = gd.sess[gd.pose_mid]
    for s in range(gd.n_sessions):
        sel = pose_sess == s
        b = np.median(pose_rate_mean[sel], axis=0) if sel.any() else np.zeros(3)
        th += [b, np.zeros(3)]
    return np.concatenate(th)


def fit_gyroscope(gd: GyroData, theta0: np.ndarray, accel, pose_sigma_rad: float, turn_sigma_rad: float) -> GyroFit:
    """Nonlinear least squares for C, b_s, d_s (module docstring); ``accel`` an ``accel_fit.AccelFit``."""
    from scipy.optimize import least_squares

    model = _Model(gd, accel, accel.theta, pose_sigma_rad, turn_sigma_rad)
    n_mo, n_po = 3 * gd.mo_from.shape[0], 3 * gd.pose_start.shape[0]
    theta = theta0
    for _ in range(3):  # variance components: weigh the pose halves by their own scatter against the motions'
        # a determined problem converges in < 10 evaluations (it is nearly linear near C = I); the cap
        # bounds the time spent on an undetermined one (the live mode refits after every pose)
        sol = least_squares(model, theta, method="trf", x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12,
                            max_nfev=30)
        theta = sol.x
        rm = sol.fun[:n_mo]
        rp = sol.fun[n_mo:n_mo + n_po] / model.w_pose
        # a unit-vector difference has 2 degrees of freedom in its 3 components
        var_m = float(rm @ rm) / max(2 * gd.mo_from.shape[0], 1)
        var_p = float(rp @ rp) / max(2 * gd.pose_start.shape[0], 1)
        w_new = math.sqrt(var_m / var_p) if var_p > 0 and var_m > 0 else 1.0
        if abs(w_new / model.w_pose - 1.0) < 0.05:
            break
        model.w_pose = w_new
    r = sol.fun
    n_obs = 2 * gd.mo_from.shape[0] + 2 * gd.pose_start.shape[0] + model.turns.size  # unit-vector diffs: 2 dof
    s2 = float(r @ r) / max(n_obs - theta0.shape[0], 1)
    inv_n = pinv_normal(sol.jac)
    cov = s2 * inv_n
    if np.all(np.isfinite(accel.cov_data)):
        cov = cov + _accel_propagation(sol, inv_n, model, accel)
    u_pred, u_to, r_pose, yaw = model.parts(sol.x)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", _unit(u_pred), u_to), -1.0, 1.0))
    pose_ang = np.linalg.norm(r_pose, axis=1)
    turn_res = np.full(gd.mo_from.shape, np.nan)
    turn_res[model.turns] = yaw[model.turns] - model.target
    bd = sol.x[9:].reshape(gd.n_sessions, 2, 3)
    return GyroFit(matrix=sol.x[:9].reshape(3, 3), bias=bd[:, 0].copy(), bias_drift=bd[:, 1].copy(),
                   names=param_names(gd.n_sessions), cov=cov, residual_rad=ang, pose_residual_rad=pose_ang,
                   turn_residual_rad=turn_res, sigma0=float(np.sqrt(s2)))


def _accel_propagation(sol, inv_n, model: _Model, accel) -> np.ndarray:
    """A Σ_a Aᵀ with A = ∂θ/∂θ_a = −(JᵀJ)⁻¹ Jᵀ ∂r/∂θ_a (implicit function theorem at the optimum;
    ∂r/∂θ_a by central differences), Σ_a the accelerometer fit's covariance."""
    cov_a = accel.cov_data
    cols = []
    try:
        for j in range(accel.theta.shape[0]):
            h = max(1e-7, 1e-2 * math.sqrt(cov_a[j, j]))
            rs = []
            for sgn in (1.0, -1.0):
                th = accel.theta.copy()
                th[j] += sgn * h
                model.set_accel(th)
                rs.append(model(sol.x))
            cols.append((rs[0] - rs[1]) / (2 * h))
    finally:
        model.set_accel(accel.theta)
    a = -(inv_n @ sol.jac.T) @ np.column_stack(cols)
    return a @ cov_a @ a.T


def detect_turns(gd: GyroData, theta0: np.ndarray, accel, turn_min_rad: float,
                 turn_max_tilt_rad: float) -> np.ndarray:
    """Full turns (n per motion, 0 for others): same up direction before and after (within
    ``turn_max_tilt_rad``), at least ``turn_min_rad`` turned about it, at the initial parameters."""
    saved = gd.turn_n
    gd.turn_n = np.zeros(gd.mo_from.shape, np.int64)
    model = _Model(gd, accel, accel.theta, 1.0, 1.0)
    try:
        w = model.omega(theta0)
        sums = pose_sums(w, gd.dt, model.f, gd.pose_start, gd.pose_mid, gd.pose_stop)
        u = _unit(sums.sum(axis=1))
    finally:
        gd.turn_n = saved
    cs = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (w[:-1] + w[1:]) * gd.dt[:-1, None], axis=0)])
    a, b = gd.pose_mid[gd.mo_from], gd.pose_mid[gd.mo_to]
    yaw = np.einsum("ij,ij->i", cs[b] - cs[a], u[gd.mo_from])
    same = np.einsum("ij,ij->i", u[gd.mo_from], u[gd.mo_to]) > math.cos(turn_max_tilt_rad)
    turn = same & (np.abs(yaw) >= turn_min_rad)
    return np.where(turn, np.rint(yaw / (2 * math.pi)), 0).astype(np.int64)


def axis_coverage(gd: GyroData, theta0: np.ndarray, accel) -> np.ndarray:
    """(3,) rad: per body axis, Σ over non-turn motions of |∫ω_a dt| × sin(angle of axis a to the vertical,
    the larger of before and after): how much rotation about that axis gravity could see."""
    if gd.mo_from.size == 0:
        return np.zeros(3)
    model = _Model(gd, accel, accel.theta, 1.0, 1.0)
    w = model.omega(theta0)
    u = _unit(np.array([model.f[m] for m in gd.pose_mid]))
    cs = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (w[:-1] + w[1:]) * gd.dt[:-1, None], axis=0)])
    ang = np.abs(cs[gd.pose_mid[gd.mo_to]] - cs[gd.pose_mid[gd.mo_from]])
    sin_tilt = np.maximum(np.sqrt(np.maximum(1.0 - u[gd.mo_from] ** 2, 0.0)),
                          np.sqrt(np.maximum(1.0 - u[gd.mo_to] ** 2, 0.0)))
    return (ang * sin_tilt * (gd.turn_n == 0)[:, None]).sum(axis=0)
