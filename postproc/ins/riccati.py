"""Steady-state "Riccati gain" mode: the source paper's constant Kalman gain [Heidari2019, eqs. 3-5].

**The paper's method.** Eq. 5 is the continuous algebraic Riccati equation (CARE) of the Kalman–Bucy
filter [Kalman1961] and eq. 4 its gain; eq. 3 corrects position, velocity and attitude with k·v::

    A P + P Aᵀ − P Cᵀ V⁻¹ C P + W = 0,      K = P Cᵀ V⁻¹,      (δp, δv, δθ) = K z,  z = 0 − v̂

W and V are the process and measurement noise densities (settings.py: W = σ² Δt₀, V = σ_zupt² Δt₀). The
gain is computed once; nothing is propagated at run time to compute it. (The engines still carry P through
the same constant-gain updates, for the reported position sigma only.)

**Error model in stance** (``filter.py``; f_n = (0, 0, g), attitude constant; δb_n = Ĉ δb_a is the
accelerometer bias in the nav frame, w white noise)::

    δṗ = δv,   δv̇_E = g δθ_N − δb_E,   δv̇_N = −g δθ_E − δb_N,   δv̇_U = −δb_U,   δθ̇ = w_g,   δḃ = w_b
    y = δv + ν                                                              (the ZUPT)

**What the ZUPT observes.** y gives δv; ẏ_E = g δθ_N − δb_E and ẏ_N = −g δθ_E − δb_N give tilt and
horizontal bias only as these sums (a tilt δθ and a horizontal bias g δθ read the same at rest, so the tilt
states carry both); ẏ_U = −δb_U gives the vertical bias. Yaw δθ_U appears nowhere, position never reaches
y or its derivatives: both are unobservable, so eq. 5 has no stabilising solution for the full state
(``full_pv_model`` reproduces this; ``steady_state_gain`` reports it). The gyro biases show only in higher
derivatives; they come from the still period (calibration.py). Eq. 5 is therefore solved on the observable
subsystem o = (δv_E, δv_N, δv_U, δθ_E, δθ_N, δb_U)::

    A_o: δv̇_E = g δθ_N,  δv̇_N = −g δθ_E,  δv̇_U = −δb_U;   C_o = [I₃ 0];   W_o = diag(q_a I₃, q_g I₂, q_b);  V = r I₃

(A_o, C_o) is observable, so the CARE has one stabilising solution P_oo and K_o = P_oo C_oᵀ V⁻¹ (with
``n_states=9``, the paper's states only, δb_U is left out and the bias stays at its prior).

**Position row (eq. 3's k for p).** P_pp has no steady state, but the cross-covariance P_po has: the p-o
block of eq. 5 with δṗ = E o (E selects δv) reads 0 = E P_oo + P_po (A_o − K_o C_o)ᵀ, so

    P_po = −E P_oo (A_o − K_o C_o)⁻ᵀ,     K_p = P_po C_oᵀ V⁻¹   (= I for this model, to rounding)

i.e. in steady stance the observer holds the position still while it pulls the velocity to zero. That is
the stance regime. The swing regime adds what eq. 5 cannot know: during an open-loop interval of length τ
(no ZUPT since the previous stance) any error that makes the velocity error grow linearly — a constant
accelerometer bias (the MPU6050's turn-on bias, ≈ 0.5 m/s²), a tilt error times g, white acceleration
noise in expectation — leaves δp(τ) = (τ/2) δv(τ); in covariance terms the interval builds
P_pv = P_vv τ/2 from P ≈ 0 at the last ZUPT (P_vv = qτ, P_pv = qτ²/2) [Groves2013], and with P_vv ≫ R
after a swing the Kalman position row of the interval's first ZUPT is P_pv (P_vv + R)⁻¹ ≈ (τ/2) I. So the
first ZUPT of each stance phase also moves the position by (τ/2) z, once, with τ in closed form from the
stance mask (``open_loop_durations``); the later samples of the phase are the stance regime. Without it
the bias leaves b τ²/2 of height per stride (≈ 10 % of the distance on the paper's walks).

**Discretisation** (the paper gives none). During stance the error observer ẋ = K (z − C x) runs for Δt
with z = −v̂ held; integrated exactly from x = 0 (the error state is reset every sample)::

    K_d,v(Δt) = I − exp(−K_v Δt),     K_d,j(Δt) = T_j K_d,v(Δt),   T_j = K_j K_v⁻¹   for the other rows j

(velocity only: 1 − e^{−KΔt}). K_v = P_vv/r is symmetric positive definite, so exp(−K_v Δt) = U diag(e^{−λΔt}) Uᵀ
from one eigen-decomposition, cheap per sample in numba. The per-sample rows: δp = T_p δv (+ (τ/2) z at a
phase's first ZUPT), δv = K_d,v z, (δθ_E, δθ_N) = T_θ δv, δb_U = T_b δv, applied as the body-frame bias
b̂_a += Ĉᵀ e_U δb_U (the body axis that points up now); yaw and the gyro biases get no correction. A
duplicate timestamp (Δt = 0) gets no correction: no time passes for the observer.

**Prior from the still period.** The bias state's pole is slow (≈ −√(q_b/r)/K_v, −0.03 1/s with the default
noise: half a minute), so the initial bias comes from the still period: the part of the mean specific force
f̄ along gravity that exceeds g, b_a0 = (‖f̄‖ − g) f̄/‖f̄‖ (``still_period_acc_bias``; the observable part,
the same one the ZUPTs of a still period teach the time-varying filter).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numba import njit

from bootnav.core.runs import runs


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
    position_gain: np.ndarray | None = None  # K_p (3×m) from the steady-state cross-covariance

    def to_dict(self) -> dict:
        return {
            "gain": None if self.gain is None else self.gain.tolist(),
            "position_gain": None if self.position_gain is None else self.position_gain.tolist(),
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

    Parameters
    ----------
    A, C, W, V : array_like
        System, measurement, process-noise density and measurement-noise density matrices.
    state_names : list of str, optional
        Names of the states, kept in the report.
    cond_limit : float
        Largest acceptable condition number of P.

    Returns
    -------
    RiccatiReport
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


def cross_covariance_gain(A, C, V, P, K, E) -> np.ndarray:
    """Gain of unobservable states driven by the observable ones, from their steady-state cross-covariance.

    For states p with ṗ = E o (no noise of their own) beside the observable subsystem o (A, C, its CARE
    solution P and gain K): 0 = E P + P_po (A − K C)ᵀ, so P_po = −E P (A − K C)⁻ᵀ and K_p = P_po Cᵀ V⁻¹.

    Parameters
    ----------
    A, C, V : ndarray
        The observable subsystem and its measurement-noise density.
    P, K : ndarray
        Its stabilising CARE solution and gain (``steady_state_gain``).
    E : ndarray
        Maps o to the rates of p.

    Returns
    -------
    ndarray
        K_p, shape (rows of E, rows of C).
    """
    p_po = -np.linalg.solve((A - K @ C), (E @ P).T).T
    return p_po @ C.T @ np.linalg.inv(V)


def zupt_observable_model(sigma_acc_mps2, sigma_gyro_radps, sigma_zupt_mps, gravity, nominal_dt_s,
                          sigma_acc_bias_rw=None):
    """(A, C, W, V, names) of the stance-linearised observable subsystem (module docstring).

    Parameters
    ----------
    sigma_acc_mps2, sigma_gyro_radps, sigma_zupt_mps : float
        Per-sample sigmas at the nominal period (settings.py): W = σ² Δt₀, V = σ_zupt² Δt₀.
    gravity : float
        m/s².
    nominal_dt_s : float
        Δt₀, s.
    sigma_acc_bias_rw : float, optional
        Accelerometer-bias random walk, m/s²/√s; given -> the vertical bias δb_U is the 6th state.

    Returns
    -------
    tuple
        A, C, W, V and the state names (δv(3), δθ_E, δθ_N[, δb_U]).
    """
    n = 5 if sigma_acc_bias_rw is None else 6
    A = np.zeros((n, n))
    # δv̇ = −[f_n×] δθ − δb_n with f_n = (0, 0, g): δv̇_E = g δθ_N, δv̇_N = −g δθ_E, δv̇_U = −δb_U
    A[0, 4] = gravity
    A[1, 3] = -gravity
    q = [sigma_acc_mps2**2 * nominal_dt_s] * 3 + [sigma_gyro_radps**2 * nominal_dt_s] * 2
    names = ["dv_E", "dv_N", "dv_U", "dtheta_E", "dtheta_N"]
    if n == 6:
        A[2, 5] = -1.0
        q.append(sigma_acc_bias_rw**2)
        names.append("dba_U")
    C = np.hstack([np.eye(3), np.zeros((3, n - 3))])
    V = np.eye(3) * sigma_zupt_mps**2 * nominal_dt_s
    return A, C, np.diag(q), V, names


def full_pv_model(q: float = 0.25, r: float = 1e-4):
    """The full [δp; δv] ZUPT model (position unobservable): eq. 5 has no stabilising solution."""
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 3)), np.zeros((3, 3))]])
    C = np.hstack([np.zeros((3, 3)), np.eye(3)])
    W = np.diag([0.0] * 3 + [q] * 3)
    V = np.eye(3) * r
    return A, C, W, V, ["dp_E", "dp_N", "dp_U", "dv_E", "dv_N", "dv_U"]


def open_loop_durations(t_s: np.ndarray, zupt: np.ndarray) -> np.ndarray:
    """τ per sample: at the first sample of each ZUPT run, the time since the last ZUPT sample before it (the
    open-loop interval the run closes; from the first sample for the first run); 0 elsewhere.

    Parameters
    ----------
    t_s : ndarray, shape (N,)
        Sample times, s.
    zupt : ndarray of bool, shape (N,)
        Samples that get a ZUPT.

    Returns
    -------
    ndarray, shape (N,)
        Seconds.
    """
    tau = np.zeros(t_s.shape[0])
    starts, stops = runs(np.asarray(zupt, dtype=bool))
    if starts.size:
        last = np.concatenate([[0], stops[:-1] - 1])
        tau[starts] = t_s[starts] - t_s[last]
    return tau


def still_period_acc_bias(acc_mean_b, gravity: float) -> np.ndarray:
    """Accelerometer bias along gravity from the still period's mean specific force: (‖f̄‖ − g) f̄/‖f̄‖.

    Parameters
    ----------
    acc_mean_b : array_like, shape (3,)
        Mean specific force at rest, body frame, m/s².
    gravity : float
        Local gravity, m/s².

    Returns
    -------
    ndarray, shape (3,)
        m/s², body frame.
    """
    f = np.asarray(acc_mean_b, dtype=float)
    norm = float(np.linalg.norm(f))
    return (norm - gravity) * f / norm


@dataclass
class ZuptGain:
    """The per-sample paper-mode gain in factors: K_d,v = U diag(1−e^{−λΔt}) Uᵀ and every other row
    T_j K_d,v (module docstring).

    T rows: δp_E, δp_N, δp_U (T_p = K_p K_v⁻¹, the stance part), δθ_E, δθ_N, δb_U (zeros without the bias
    state). tau: per sample, the open-loop interval closed at that sample (``open_loop_durations``), s.
    """

    U: np.ndarray  # (3,3)
    lam: np.ndarray  # (3,)
    T: np.ndarray  # (6,3)
    tau: np.ndarray  # (N,)
    report: RiccatiReport

    def discrete(self, dt: float, tau: float, c_nb: np.ndarray, n_states: int = 9) -> np.ndarray:
        """n×3 gain mapping z = −v̂ to (δp, δv, δθ[, δb_a, δb_g]) for one step (readable form of
        ``gain_into``).

        Parameters
        ----------
        dt : float
            Step length, s.
        tau : float
            Open-loop interval this sample closes (nonzero at a phase's first ZUPT only), s.
        c_nb : ndarray, shape (3, 3)
            Current attitude (body -> nav), to map δb_U to the body-frame bias.
        n_states : int
            9 or 15.

        Returns
        -------
        ndarray, shape (n_states, 3)
        """
        kv = self.U @ np.diag(1.0 - np.exp(-self.lam * dt)) @ self.U.T
        k = np.zeros((n_states, 3))
        k[0:3] = self.T[0:3] @ kv + 0.5 * tau * np.eye(3)
        k[3:6] = kv
        k[6:8] = self.T[3:5] @ kv
        if n_states == 15:
            k[9:12] = np.outer(c_nb[2], self.T[5] @ kv)
        return k


@njit(cache=True)
def gain_into(K, n, dt, tau, c, U, lam, T):
    """Fill K (n×3) with ``ZuptGain.discrete(dt, tau, c, n)`` (the fast engine's form, no allocation)."""
    for i in range(n):
        K[i, 0] = 0.0
        K[i, 1] = 0.0
        K[i, 2] = 0.0
    for i in range(3):
        for m in range(3):
            s = 0.0
            for l in range(3):
                s += U[i, l] * (1.0 - np.exp(-lam[l] * dt)) * U[m, l]
            K[3 + i, m] = s
    for m in range(3):
        for i in range(3):
            K[i, m] = T[i, 0] * K[3, m] + T[i, 1] * K[4, m] + T[i, 2] * K[5, m]
        K[m, m] += 0.5 * tau
        for i in range(2):
            K[6 + i, m] = T[3 + i, 0] * K[3, m] + T[3 + i, 1] * K[4, m] + T[3 + i, 2] * K[5, m]
        if n == 15:
            b = T[5, 0] * K[3, m] + T[5, 1] * K[4, m] + T[5, 2] * K[5, m]
            for i in range(3):
                K[9 + i, m] = c[2, i] * b


def paper_zupt_gain(settings, gravity: float, nominal_dt_s: float, t_s=None, zupt=None) -> ZuptGain:
    """Solve eq. 5 on the observable subsystem for these settings (the vertical bias state with
    ``n_states=15``) and the position gain from the cross-covariance; raise ValueError if not stabilising.

    Parameters
    ----------
    settings : FilterSettings
        Noise sigmas and ``n_states``.
    gravity, nominal_dt_s : float
        m/s²; Δt₀, s.
    t_s, zupt : ndarray, optional
        Sample times and ZUPT mask, for the open-loop durations τ (none given: τ = 0).

    Returns
    -------
    ZuptGain
    """
    bias_rw = settings.sigma_acc_bias_rw if settings.n_states == 15 else None
    A, C, W, V, names = zupt_observable_model(settings.sigma_acc_mps2, settings.sigma_gyro_radps,
                                              settings.sigma_zupt_mps, gravity, nominal_dt_s, bias_rw)
    rep = steady_state_gain(A, C, W, V, state_names=names)
    if not rep.stabilising:
        raise ValueError(f"Riccati mode: {rep.message}")
    rep.position_gain = cross_covariance_gain(A, C, V, rep.P, rep.gain, C)
    kv = rep.gain[0:3]
    kv = 0.5 * (kv + kv.T)  # symmetric in exact arithmetic (V ∝ I)
    lam, U = np.linalg.eigh(kv)
    kv_inv = np.linalg.inv(kv)
    T = np.zeros((6, 3))
    T[0:3] = rep.position_gain @ kv_inv
    T[3:3 + A.shape[0] - 3] = rep.gain[3:] @ kv_inv
    tau = np.zeros(0) if t_s is None else open_loop_durations(np.asarray(t_s, dtype=float), zupt)
    return ZuptGain(U, lam, T, tau, rep)
