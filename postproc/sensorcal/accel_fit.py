"""Accelerometer multi-position calibration: bias, scale, misalignment (and bias temperature coefficient).

Derivation
----------
At rest the accelerometer measures the specific force of gravity, whose magnitude g is known and whose
direction is not. With the model of ``bootnav.core.sensorcal`` (y = S x + b + k ΔT, corrected
x̂ = C (y − b − k ΔT)), every static pose p gives one scalar equation [Skog2006; Tedaldi2014, eq. 9]::

    r_p(θ) = ‖C (ȳ_p − b − k ΔT_p)‖ − g = 0,         θ = (C_xx, C_xy, C_xz, C_yy, C_yz, C_zz, b, [k])

solved by nonlinear least squares (``scipy.optimize.least_squares``, trust-region reflective) from
C = I, b = 0. C is upper triangular: a rotation of the body frame leaves every ‖·‖ unchanged, so three of the
nine entries of a full C are unobservable and are fixed by a convention. Upper-triangular C (S = C⁻¹ upper
triangular too) means: the body z axis is the accelerometer's z sensing axis, the body y axis lies in the
plane of the accelerometer's y and z sensing axes, x completes a right-handed frame. This is imu_tk's
choice [imu_tk, ``CalibratedTriad``] for the accelerometer. 9 parameters (12 with k) need at least 9
(12) poses; the issue's 12+ poses over-determine them. Every axis must point both up and down in some pose to
separate scale and bias along it.

Uncertainty: Σ_θ = s² (JᵀJ)⁻¹ at the solution, s² = Σ r² / (P − n) (Gauss–Newton covariance; the residual
scatter stands for pose noise and tremor). ``fit_accelerometer`` returns both.

References: [Skog2006] (multi-position calibration of low-cost IMUs), [Tedaldi2014] (robust calibration
without external equipment), [imu_tk] (their reference implementation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UPPER = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
AXES = "xyz"


@dataclass
class AccelFit:
    """Result of ``fit_accelerometer`` (SI units)."""

    matrix: np.ndarray  # (3, 3) C, upper triangular
    bias: np.ndarray  # (3,) m/s²
    temp_coeff: np.ndarray  # (3,) m/s² per °C (zeros when not fitted)
    names: list  # parameter names, in the order of theta / cov
    theta: np.ndarray
    cov: np.ndarray  # (n, n)
    residuals: np.ndarray  # (P,) m/s², ‖corrected‖ − g per pose
    sigma0: float  # a-posteriori residual std (m/s²)
    fit_temp: bool = False
    n_sessions: int = 1
    session_offset: np.ndarray | None = None  # (S, 3) power-on offsets δ_s (m/s²), zeros for one session
    cov_data: np.ndarray | None = None  # cov without the repeatability added to b (what the poses' up vectors see)

    def session_bias(self, theta: np.ndarray | None = None) -> np.ndarray:
        """(S, 3) bias b + δ_s of each session at T_ref (for ``theta``, default the solution)."""
        _, b, _, d = unpack(self.theta if theta is None else theta, self.fit_temp, self.n_sessions)
        return b + d

    def sigma(self) -> dict:
        sd = np.sqrt(np.maximum(np.diag(self.cov), 0.0))
        return {k: float(v) for k, v in zip(self.names, sd)}


def unpack(theta: np.ndarray, fit_temp: bool, n_sessions: int = 1):
    """(C, b, k, δ (S, 3)) from the parameter vector (δ only with several sessions, else zeros)."""
    c = np.zeros((3, 3))
    for v, (i, j) in zip(theta[:6], UPPER):
        c[i, j] = v
    bias = theta[6:9]
    k = theta[9:12] if fit_temp else np.zeros(3)
    i0 = 12 if fit_temp else 9
    d = theta[i0:i0 + 3 * n_sessions].reshape(n_sessions, 3) if n_sessions > 1 else np.zeros((1, 3))
    return c, bias, k, d


def param_names(fit_temp: bool, n_sessions: int = 1) -> list[str]:
    names = [f"C_{AXES[i]}{AXES[j]}" for i, j in UPPER] + [f"bias_{a}" for a in AXES]
    names += [f"temp_coeff_{a}" for a in AXES] if fit_temp else []
    if n_sessions > 1:
        names += [f"session{s}_offset_{a}" for s in range(n_sessions) for a in AXES]
    return names


def fit_accelerometer(acc_mean, gravity: float, temp_dev=None, weights=None, session=None,
                      repeatability_mps2: float = 0.04) -> AccelFit:
    """Fit C (upper triangular), b and optionally k to static-pose mean specific forces.

    Parameters
    ----------
    acc_mean : (P, 3) array
        Raw mean specific force per static pose (m/s²).
    gravity : float
        Local gravity (m/s²).
    temp_dev : (P,) array or None
        T_p − T_ref (°C) per pose; None fits no temperature coefficient.
    weights : (P,) array or None
        Relative weights per pose (e.g. √n samples); None = equal.
    session : (P,) int array or None
        Session (power-on) of each pose. With several, each session's bias is b + δ_s and every δ_s gets
        the prior 0 ± ``repeatability_mps2`` (the turn-on repeatability: a random effect), so b is the
        unit's mean bias and k comes from the temperature changes within a power-on plus what the prior
        allows between them. With one session δ is not a parameter; b's 1σ includes the repeatability.
    """
    from scipy.optimize import least_squares

    y = np.asarray(acc_mean, dtype=np.float64)
    n_pose = y.shape[0]
    fit_temp = temp_dev is not None
    dT = np.zeros(n_pose) if temp_dev is None else np.asarray(temp_dev, dtype=np.float64)
    w = np.ones(n_pose) if weights is None else np.asarray(weights, dtype=np.float64)
    ses = np.zeros(n_pose, np.int64) if session is None else np.asarray(session, np.int64)
    n_ses = int(ses.max()) + 1 if ses.size else 1
    n_par = (12 if fit_temp else 9) + (3 * n_ses if n_ses > 1 else 0)
    prior_w = [1e-3 / repeatability_mps2]  # pose-residual σ over the prior's σ; refined from the residuals

    def resid(theta):
        c, b, k, d = unpack(theta, fit_temp, n_ses)
        x = (y - b - d[ses if n_ses > 1 else 0] - dT[:, None] * k) @ c.T
        r = w * (np.sqrt(np.einsum("ij,ij->i", x, x)) - gravity)
        return np.concatenate([r, prior_w[0] * d.ravel()]) if n_ses > 1 else r

    theta = np.zeros(n_par)
    theta[[0, 3, 5]] = 1.0
    for _ in range(2 if n_ses > 1 else 1):
        sol = least_squares(resid, theta, method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14,
                            max_nfev=200)
        theta = sol.x
        rp = sol.fun[:n_pose]
        s_pose = math.sqrt(float(rp @ rp) / max(n_pose - (n_par - 3 * n_ses if n_ses > 1 else n_par), 1))
        prior_w[0] = s_pose / repeatability_mps2
    sol = least_squares(resid, theta, method="trf", x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14,
                        max_nfev=200) if n_ses > 1 else sol
    r = sol.fun
    dof = max(r.shape[0] - n_par, 1)
    s2 = float(r @ r) / dof
    cov = s2 * pinv_normal(sol.jac)
    names = param_names(fit_temp, n_ses)
    cov_data = cov.copy()
    if n_ses == 1:  # the next power-on's bias differs by the repeatability
        for i in range(6, 9):
            cov[i, i] += repeatability_mps2**2
    c, b, k, d = unpack(sol.x, fit_temp, n_ses)
    return AccelFit(matrix=c, bias=b.copy(), temp_coeff=k.copy(), names=names, theta=sol.x, cov=cov,
                    residuals=r[:n_pose] / w, sigma0=float(np.sqrt(s2)), fit_temp=fit_temp, n_sessions=n_ses,
                    session_offset=d.copy(), cov_data=cov_data)


def pinv_normal(jac: np.ndarray) -> np.ndarray:
    """(JᵀJ)⁻¹ through the SVD; a direction with no information gets an infinite variance (not a tiny one)."""
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    tol = sv.max(initial=0.0) * max(jac.shape) * np.finfo(float).eps * 1e3
    inv = np.where(sv > tol, 1.0 / np.where(sv > tol, sv, 1.0) ** 2, np.inf)
    with np.errstate(invalid="ignore"):
        cov = (vt.T * inv) @ vt
    # an unobservable direction: inf on the diagonal of every parameter it touches
    bad = sv <= tol
    if bad.any():
        touched = (np.abs(vt[bad]) > 0.05).any(axis=0)  # parameters that take part in it
        cov[touched, :] = np.where(np.isfinite(cov[touched, :]), cov[touched, :], np.inf)
        cov[np.ix_(touched, touched)] = np.inf
    return np.where(np.isnan(cov), np.inf, cov)
