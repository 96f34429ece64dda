"""Steady-state "Riccati gain" mode reproducing the paper (seed-004 eqs. 4–7).

Eq. 5 (continuous algebraic Riccati equation of the Kalman–Bucy filter) and eq. 4 (its gain):

    A P + P Aᵀ − P Cᵀ V⁻¹ C P + W = 0,        K = P Cᵀ V⁻¹

with W the process-noise and V the measurement-noise covariance (densities). The full ZUPT model is not
detectable — position and yaw never appear in a zero-velocity measurement — so eq. 5 has no stabilising
solution for it (``full_pv_model`` reproduces the failure; ``steady_state_gain`` reports it). The paper mode
therefore solves eq. 5 on the OBSERVABLE subsystem x = (δv_E, δv_N, δv_U, δθ_E, δθ_N) linearised in stance
(f_n = [0, 0, g]): δv̇ = −[f_n×] δθ + w_a, δθ̇ = w_g, y = δv + v. Position and yaw are propagated open loop.

Continuous gain -> per-sample correction (the paper gives no discretisation). During stance the continuous
observer ẋ = K (y − C x) runs for Δt with the innovation y = −v̂ held; integrating it exactly from x = 0
(the error state is reset every sample) gives the per-sample gain applied as δx = K_d(Δt) z:

    K_d,v(Δt) = I − exp(−K_v Δt),     K_d,θ(Δt) = K_θ K_v⁻¹ (I − exp(−K_v Δt))

(velocity-only case: 1 − e^{−KΔt}, the brief's "I − exp(−K_c Δt)"). K_v = P_vv/V is symmetric positive
definite, so exp(−K_v Δt) = U diag(e^{−λΔt}) Uᵀ from one eigen-decomposition, cheap per sample in numba.
A duplicate timestamp (Δt = 0) gets no correction in this mode: no time passes for the observer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg


@dataclass
class RiccatiReport:
    """Outcome of eq. 5. ``gain`` = K (n×m) and ``P`` are None when no solution could be computed."""

    gain: np.ndarray | None
    P: np.ndarray | None
    stabilising: bool
    message: str
    closed_loop_eigenvalues: np.ndarray | None = None
    residual: float = float("nan")
    condition: float = float("nan")
    state_names: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "gain": None if self.gain is None else self.gain.tolist(),
            "stabilising": self.stabilising,
            "message": self.message,
            "residual": self.residual,
            "condition": self.condition,
            "state_names": self.state_names,
        }


def steady_state_gain(A, C, W, V, *, state_names=None, cond_limit: float = 1e12) -> RiccatiReport:
    """Solve eq. 5 with ``scipy.linalg.solve_continuous_are`` (filter dual: a=Aᵀ, b=Cᵀ) and check the result.

    Stabilising means every eigenvalue of A − K C has real part < 0 (relative tolerance), the residual of
    eq. 5 is small relative to ‖W‖ and cond(P) < ``cond_limit``. Otherwise ``stabilising=False`` with a
    message saying which check failed and the usual cause (an unobservable state such as position or yaw).
    """
    A, C, W, V = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (A, C, W, V))
    names = list(state_names) if state_names is not None else [f"x{i}" for i in range(A.shape[0])]
    hint = (
        " The model is probably not detectable: a state that never reaches the measurement (position or yaw "
        "under ZUPT) has no steady-state covariance. Solve on the observable subsystem instead "
        "(bootnav.postproc.ins.riccati.zupt_observable_model)."
    )
    try:
        P = scipy.linalg.solve_continuous_are(A.T, C.T, W, V)
    except (np.linalg.LinAlgError, ValueError) as exc:
        return RiccatiReport(None, None, False, f"Riccati equation (eq. 5) has no solution: {exc}." + hint,
                             state_names=names)
    if not np.all(np.isfinite(P)):
        return RiccatiReport(None, None, False, "Riccati solution is not finite." + hint, state_names=names)
    Vinv = np.linalg.inv(V)
    K = P @ C.T @ Vinv
    res = A @ P + P @ A.T - P @ C.T @ Vinv @ C @ P + W
    residual = float(np.linalg.norm(res) / max(np.linalg.norm(W), 1e-300))
    cond = float(np.linalg.cond(P))
    eig = np.linalg.eigvals(A - K @ C)
    scale = max(1.0, float(np.max(np.abs(eig))))
    worst = float(np.max(eig.real))
    problems = []
    if worst >= -1e-9 * scale:
        problems.append(f"closed loop A − K C has an eigenvalue with real part {worst:.3g} ≥ 0 (not stabilising)")
    if cond > cond_limit:
        problems.append(f"P is ill-conditioned (cond {cond:.3g} > {cond_limit:.0e})")
    if residual > 1e-6:
        problems.append(f"eq. 5 residual is {residual:.3g} relative to ‖W‖")
    if problems:
        return RiccatiReport(K, P, False, "; ".join(problems) + "." + hint, eig, residual, cond, names)
    return RiccatiReport(K, P, True, f"stabilising; slowest closed-loop pole {worst:.4g} 1/s", eig, residual,
                         cond, names)


def zupt_observable_model(sigma_acc_mps2, sigma_gyro_radps, sigma_zupt_mps, gravity, nominal_dt_s):
    """(A, C, W, V, names) of the stance-linearised observable subsystem (δv(3), δθ_E, δθ_N).

    Densities from the per-sample sigmas (see settings.py): W = σ² Δt₀, V = σ_zupt² Δt₀.
    """
    A = np.zeros((5, 5))
    # δv̇ = −[f_n×] δθ with f_n = (0, 0, g): δv̇_E = g δθ_N, δv̇_N = −g δθ_E
    A[0, 4] = gravity
    A[1, 3] = -gravity
    C = np.hstack([np.eye(3), np.zeros((3, 2))])
    W = np.diag([sigma_acc_mps2**2] * 3 + [sigma_gyro_radps**2] * 2) * nominal_dt_s
    V = np.eye(3) * sigma_zupt_mps**2 * nominal_dt_s
    return A, C, W, V, ["dv_E", "dv_N", "dv_U", "dtheta_E", "dtheta_N"]


def full_pv_model(q: float = 0.25, r: float = 1e-4):
    """The full [δp; δv] ZUPT model (position unobservable): eq. 5 has no stabilising solution (seed-004 §2.5)."""
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 3)), np.zeros((3, 3))]])
    C = np.hstack([np.zeros((3, 3)), np.eye(3)])
    W = np.diag([0.0] * 3 + [q] * 3)
    V = np.eye(3) * r
    return A, C, W, V, ["dp_E", "dp_N", "dp_U", "dv_E", "dv_N", "dv_U"]


@dataclass
class ZuptGain:
    """Factors of the per-sample paper-mode gain: K_d,v = U diag(1−e^{−λΔt}) Uᵀ, K_d,θ = T K_d,v."""

    U: np.ndarray  # (3,3)
    lam: np.ndarray  # (3,)
    T: np.ndarray  # (2,3) = K_θ K_v⁻¹
    report: RiccatiReport

    def discrete(self, dt: float) -> np.ndarray:
        """9×3 gain mapping z = −v̂ to (δp, δv, δθ) for one step of length dt (readable form)."""
        kv = self.U @ np.diag(1.0 - np.exp(-self.lam * dt)) @ self.U.T
        k = np.zeros((9, 3))
        k[3:6] = kv
        k[6:8] = self.T @ kv
        return k


def paper_zupt_gain(settings, gravity: float, nominal_dt_s: float) -> ZuptGain:
    """Solve eq. 5 on the observable subsystem for these settings; raise ValueError if not stabilising."""
    A, C, W, V, names = zupt_observable_model(
        settings.sigma_acc_mps2, settings.sigma_gyro_radps, settings.sigma_zupt_mps, gravity, nominal_dt_s
    )
    rep = steady_state_gain(A, C, W, V, state_names=names)
    if not rep.stabilising:
        raise ValueError(f"Riccati mode: {rep.message}")
    kv = rep.gain[0:3]
    kv = 0.5 * (kv + kv.T)  # symmetric in exact arithmetic (V ∝ I)
    lam, U = np.linalg.eigh(kv)
    T = rep.gain[3:5] @ np.linalg.inv(kv)
    return ZuptGain(U, lam, T, rep)
