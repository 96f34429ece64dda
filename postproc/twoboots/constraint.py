"""The maximum-separation constraint between two foot-mounted navigators [Skog2012].

Two feet of one walker are never further apart than γ (``TwoBootSettings.max_separation_m``). When the two
position estimates p̂_L, p̂_R (covariances P_L, P_R, the two filters taken as independent) violate
‖p_L − p_R‖ ≤ γ, the constrained estimate is the covariance-weighted projection onto the bound:

    minimise (p_L − p̂_L)ᵀ P_L⁻¹ (p_L − p̂_L) + (p_R − p̂_R)ᵀ P_R⁻¹ (p_R − p̂_R)   s.t. ‖p_L − p_R‖ = γ.

With the Lagrange multiplier μ ≥ 0 the stationarity conditions are p_L = p̂_L − μ P_L d, p_R = p̂_R + μ P_R d
(d = p_L − p_R), so d = (I + μ S)⁻¹ d̂ with S = P_L + P_R and d̂ = p̂_L − p̂_R. With S = U diag(s) Uᵀ and
e = Uᵀ d̂, ‖d(μ)‖² = Σ eᵢ² / (1 + μ sᵢ)² falls monotonically from ‖d̂‖² > γ² to 0, so the one root of
‖d(μ)‖ = γ is found by a safeguarded Newton iteration in the scalar μ (the 1-D Lagrange solve).

Each foot then receives the projection as a scalar position pseudo-measurement along u = d / ‖d‖ (the
constrained separation direction): z = uᵀ(p* − p̂), H = uᵀ [I₃ 0 …], R = σ_c². For R → 0 its Kalman update
moves the position by P u (uᵀ c)/(uᵀ P u) with c = p* − p̂ = ∓ μ P d, which is exactly c: the filter
reproduces the projection, the other states (velocity, attitude — the heading — and biases) follow through
their covariance with the position, and only the variance along u shrinks (the bound says nothing about
the perpendicular directions). This is the covariance-weighted form; Prateek et al. [Prateek2013] instead
move only the swinging foot onto the sphere around the resting one with a 3-D position update.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Projection:
    """Result of ``project_max_separation`` (SI, nav frame)."""

    active: bool  # the bound was violated and the positions moved
    p_left: np.ndarray  # (3,) constrained positions
    p_right: np.ndarray
    direction: np.ndarray  # (3,) unit vector of the constrained separation p_L − p_R (the measurement axis)
    multiplier: float  # μ, 1/m² (0 when inactive)
    separation_m: float  # ‖p̂_L − p̂_R‖ before the projection


def project_max_separation(p_left, cov_left, p_right, cov_right, gamma_m: float,
                           tol_m: float = 1e-9, max_iter: int = 100) -> Projection:
    """Covariance-weighted projection of two positions onto ‖p_L − p_R‖ ≤ γ (module docstring).

    Parameters
    ----------
    p_left, p_right : (3,) array
        Position estimates, m.
    cov_left, cov_right : (3, 3) array
        Their covariances, m² (symmetric positive semi-definite; their sum must be positive definite
        along the separation).
    gamma_m : float
        The bound γ, m (> 0).
    tol_m : float
        Accuracy of ‖p_L − p_R‖ = γ at the solution, m.
    max_iter : int
        Newton iterations at most (it converges in a few).

    Returns
    -------
    Projection
        Unchanged positions and ``active=False`` when the bound holds.
    """
    pl, pr = np.asarray(p_left, float), np.asarray(p_right, float)
    d_hat = pl - pr
    dist = float(np.linalg.norm(d_hat))
    if dist <= gamma_m:
        u = d_hat / dist if dist > 0 else np.zeros(3)
        return Projection(False, pl.copy(), pr.copy(), u, 0.0, dist)
    S = np.asarray(cov_left, float) + np.asarray(cov_right, float)
    s, U = np.linalg.eigh(0.5 * (S + S.T))
    s = np.maximum(s, 0.0)
    e2 = (U.T @ d_hat) ** 2
    g2 = gamma_m * gamma_m
    # f(μ) = Σ e²/(1+μs)² − γ², decreasing and convex in μ: Newton from μ = 0 approaches the root from below
    mu = 0.0
    for _ in range(max_iter):
        w = 1.0 / (1.0 + mu * s)
        f = float(np.sum(e2 * w * w)) - g2
        if f <= 2.0 * gamma_m * tol_m:
            break
        df = float(np.sum(-2.0 * e2 * s * w ** 3))
        if df >= 0.0:  # no variance along the separation: nothing can move (caller's covariance is degenerate)
            break
        mu -= f / df
    d = U @ ((U.T @ d_hat) / (1.0 + mu * s))
    c_left = -mu * (np.asarray(cov_left, float) @ d)
    c_right = mu * (np.asarray(cov_right, float) @ d)
    norm = float(np.linalg.norm(d))
    return Projection(True, pl + c_left, pr + c_right, d / norm if norm > 0 else d, float(mu), dist)


def separation_variance_m2(excess_m: float, var_sep_m2: float, sigma_m: float, gate_sigma: float) -> float:
    """Noise variance R of the bound as a measurement of the separation, m².

    σ² (``constraint_sigma_m``) while the violation is consistent with the filters' covariances; when the
    excess e = ‖p̂_L − p̂_R‖ − γ lies more than ``gate_sigma`` standard deviations outside them
    (e² > g² (s + σ²), s = uᵀ(P_L + P_R)u the variance of the separation along u), the covariances are too small
    for the error at hand (a ZUPT filter's on a stair flight) and a hard projection through them turns much
    of the excess into attitude corrections, the common heading included (docs/twoboots.md). R is then raised
    until the excess is at the gate, R = e²/g² − s: the update moves the feet by the consistent part, and the
    next checks continue. ``gate_sigma`` 0: no gate, always σ².
    """
    if gate_sigma <= 0:
        return sigma_m * sigma_m
    return max(sigma_m * sigma_m, (excess_m / gate_sigma) ** 2 - var_sep_m2)


def position_measurement(p_hat, p_star, direction, n_states: int, sigma_m: float):
    """The scalar pseudo-measurement (z, H, R) that moves ``p_hat`` to ``p_star`` along ``direction``.

    z = uᵀ(p* − p̂) in the error-state convention δx = x_true − x̂ (position error first), H = uᵀ[I₃ 0 …]
    (1 × n), R = σ² (module docstring).
    """
    u = np.asarray(direction, float)
    H = np.zeros((1, n_states))
    H[0, :3] = u
    z = np.array([float(u @ (np.asarray(p_star, float) - np.asarray(p_hat, float)))])
    return z, H, np.array([[sigma_m * sigma_m]])
