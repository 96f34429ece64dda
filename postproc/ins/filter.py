"""``run_filter``: ZUPT-aided strapdown navigation (seed-004 eqs. 1–5; Skog et al. 2010; Foxlin 2005; OpenShoe).

Error state δx = x_true − x̂ = (δp_n, δv_n, δθ_n[, δb_a,b, δb_g,b]) with the attitude error a nav-frame
rotation, C_true ≈ (I + [δθ×]) Ĉ. Linearised dynamics (continuous time, A):

    δṗ = δv,   δv̇ = −[f_n×] δθ − Ĉ δb_a − Ĉ w_a,   δθ̇ = −Ĉ δb_g − Ĉ w_g,   δḃ = w_b

discretised per step as F = I + A Δt and Q_d = diag(σ_a² Δt₀ Δt, σ_g² Δt₀ Δt, σ_ba² Δt, σ_bg² Δt)
(σ conventions in settings.py; the rotation Ĉ drops out of isotropic noise).

Time update: mechanization (mechanization.py) + P ← F P Fᵀ + Q_d.
ZUPT in stance (eq. 3 with the sign made explicit): z = 0 − v̂ = H δx + ν, H = [0 I 0], R = σ_zupt² I,
K = P Hᵀ (H P Hᵀ + R)⁻¹, δx = K z, Joseph form P ← (I−KH) P (I−KH)ᵀ + K R Kᵀ. The paper prints
"+ k_n v_n": that is this update with z's minus sign absorbed in k_n.
Reset: p̂ += δp, v̂ += δv, b̂ += δb, q̂ ← exp(δθ/2) ⊗ q̂ (the quaternion form of ψ ← a(dθ) ψ; exact rotation,
renormalised, not the first-order R ← (I − [δθ×]) R), then δx ← 0.
Rolling-foot ZUPT noise: R_k = (σ_zupt² + r² |ω_k − b̂_g|²) I (a foot rolling over heel/toe at ω moves the
sensor at ≈ ω r). ZUPT onset delay: the first min(0.15 s, 1/3 of the phase) of each stance phase gets no
update (``delay_zupt_onsets``: the foot still settles after heel strike).
ZARU (15 states, on by default): z = ω_m − b̂_g = δb_g + ν in stance, sequential after the ZUPT, with the
"quiet-core" noise R_k = (σ_zaru² + c² |ω_k − b̂_g|²) I so that it only bites where the foot is really still.
Saturated samples (``saturated=`` mask): per-sample process noise along the clipped body axis,
Q_v += C diag(σ_sat,a²) Cᵀ Δt₀Δt, Q_θ += C diag(σ_sat,g²) Cᵀ Δt₀Δt (``saturation_variance``).
Optional heuristic heading aid (``heading_aid="dominant_directions"``, off by default; settings.py):
a scalar yaw pseudo-measurement at stance onsets, sequential after the ZUPT (innovation −e − δθ_U).
"riccati" mode: constant continuous gain from eq. 5 (riccati.py); P is still propagated and Joseph-updated
with that (suboptimal) gain so ``pos_sigma_n`` stays meaningful.

Tried on the foot-set eval and NOT kept (no gain or worse; mean over the 10 goal metrics relative to the
default, < 1 = better): an along-gravity accelerometer-bias prior from the still period ((|f̄| − g) f̄/|f̄|;
1.000: the ZUPTs of the still period learn it within a second anyway); a two-sample coning term
(Δt²/12) ω_{k−1} × ω_k in the attitude step (1.007; with trapezoidal rates 1.11: pyshoe_vicon's running
heading drift, −0.9 °/s, is not coning); no yaw (or gyro-bias) row in the ZUPT gain (1.04 / 1.01);
an impact term (τ (|f| − g))² in the ZUPT R, τ = 5-40 ms (1.001-1.044; it does not replace the onset delay);
cutting the last 20-100 ms of each stance too (1.03-1.06); de-jittering timestamps with a linear sample
clock (1.001).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from bootnav.errors import InputError
from bootnav.postproc.ins.mechanization import time_base, validate_imu
from bootnav.postproc.ins.settings import FilterSettings


@dataclass
class NavSolution:
    """Per-sample navigation solution (SI, nav frame ENU, q_nb wxyz body -> nav)."""

    t_s: np.ndarray
    pos_n: np.ndarray
    vel_n: np.ndarray
    q_nb: np.ndarray
    acc_bias_b: np.ndarray | None
    gyro_bias_b: np.ndarray | None
    pos_sigma_n: np.ndarray
    info: dict = field(default_factory=dict)  # JSON-serialisable: mode, engine, riccati report, timings, ...


def initial_covariance(settings: FilterSettings) -> np.ndarray:
    """P₀ = diag of the initial error sigmas (yaw separately: alignment cannot see it)."""
    s = [settings.init_pos_sigma_m] * 3 + [settings.init_vel_sigma_mps] * 3
    s += [settings.init_att_sigma_rad] * 2 + [settings.init_yaw_sigma_rad]
    if settings.n_states == 15:
        s += [settings.init_acc_bias_sigma_mps2] * 3 + [settings.init_gyro_bias_sigma_radps] * 3
    return np.diag(np.square(s))


def _init_vector(init, name, default):
    v = getattr(init, name, None)
    if v is None:
        return np.array(default, dtype=float)
    v = np.asarray(v, dtype=float).reshape(-1)
    if not np.all(np.isfinite(v)):
        raise InputError(f"initial state {name} is not finite: {v}")
    return v


def delay_zupt_onsets(t_s: np.ndarray, stance: np.ndarray, delay_s: float, max_fraction: float) -> np.ndarray:
    """Stance mask with the first min(delay_s, max_fraction × phase duration) of every stance phase removed.

    Why: a detector reports stance as soon as the foot's energy falls, but after heel strike the foot is still
    settling (loading response: heel rocker to foot flat, the first ~10 % of the gait cycle, ≈ 0.1 s;
    Perry & Burnfield, *Gait Analysis*, 2010). There the sensor still moves at a few cm/s, and a ZUPT
    would read that real motion as accumulated velocity ERROR and move the position by P_pv P_vv⁻¹ δv —
    on the developer loops +1.5 cm upwards per stride (x-io long walk: v_z = −0.037 m/s at detected onset,
    decaying to 0 within ~0.05 s). Letting the mechanization integrate that settling removes the jump.
    The cap keeps most of a short (running) stance phase. A phase starting at sample 0 (the initial
    still period) is kept whole.
    """
    out = np.array(stance, dtype=bool, copy=True)
    if delay_s <= 0 or max_fraction <= 0 or not out.any():
        return out
    edges = np.diff(np.concatenate(([0], out.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    keep = starts > 0
    starts, stops = starts[keep], stops[keep]
    cut_t = t_s[starts] + np.minimum(delay_s, max_fraction * (t_s[stops - 1] - t_s[starts]))
    cut = np.searchsorted(t_s, cut_t, side="left")
    for a, c in zip(starts, cut):
        out[a:c] = False
    return out


def saturation_variance(saturated, n: int, settings: FilterSettings) -> np.ndarray | None:
    """Extra per-sample variance of each body axis (ax, ay, az, gx, gy, gz) of saturated samples, (N, 6), or
    None when nothing is saturated.

    A clipped sample says only "at least full scale": the true value is unknown, so instead of trusting the
    clipped number with the normal noise the filter adds ``sat_acc_sigma_mps2``² / ``sat_gyro_sigma_radps``²
    to that sample's per-sample variance (process noise) ALONG THE CLIPPED BODY AXIS (the other axes are
    fine), i.e. the velocity / attitude uncertainty grows in that direction through the clipped burst and
    the next ZUPTs correct the error it caused. ``saturated``: (N,) bitmask (bits ax, ay, az, gx, gy, gz as
    ``bootnav.logger.recording.SATURATION_BITS``), or (N, 6) bool, or (N,) bool (every axis).
    """
    if saturated is None:
        return None
    sat = np.asarray(saturated)
    if sat.shape[0] != n:
        raise InputError(f"saturated must have {n} rows like t_s, got shape {sat.shape}")
    if sat.ndim == 2:
        axes = sat[:, :6].astype(bool)
    elif sat.dtype == bool:
        axes = np.repeat(sat[:, None], 6, axis=1)
    else:
        bits = sat.astype(np.uint8)
        axes = np.column_stack([(bits >> b) & 1 for b in range(6)]).astype(bool)
    if not axes.any():
        return None
    sig2 = np.array([settings.sat_acc_sigma_mps2**2] * 3 + [settings.sat_gyro_sigma_radps**2] * 3)
    out = axes * sig2
    return out if out.any() else None


def run_filter(t_s, acc_b, gyro_b, stance, init, gravity: float, settings: FilterSettings | None = None,
               progress=None, saturated=None) -> NavSolution:
    """ZUPT-aided INS over a whole record.

    t_s (N,) s, increasing (duplicates allowed); acc_b (N,3) m/s² specific force; gyro_b (N,3) rad/s;
    stance (N,) bool (True = foot still: ZUPT applied); init: any object with ``q_nb`` (4,) wxyz and
    ``gyro_bias_b`` (3,) (optional ``acc_bias_b``), e.g. ``bootnav.postproc.calibration.InitialState``;
    gravity: m/s² (positive); progress: optional ``progress(fraction)`` called a few times;
    saturated: optional per-sample saturation mask (see ``saturation_variance``).
    Position starts at 0, velocity at 0. Raises ``InputError`` for bad data, ``ValueError`` for bad settings.
    """
    settings = settings or FilterSettings()
    settings.validate()
    requested = settings
    warnings: list[str] = []
    if settings.mode == "riccati" and settings.n_states != 9:
        settings = replace(settings, n_states=9)
        warnings.append("riccati (paper) mode runs the paper's 9-state model: sensor biases are not estimated")
    t_s, acc_b, gyro_b = validate_imu(t_s, acc_b, gyro_b, stance)
    stance = np.ascontiguousarray(stance, dtype=bool)
    zupt_mask = delay_zupt_onsets(t_s, stance, settings.zupt_onset_delay_s, settings.zupt_onset_max_fraction)
    if not (np.isfinite(gravity) and 5.0 < gravity < 15.0):
        raise InputError(f"gravity must be the local magnitude in m/s² (about 9.8), got {gravity!r}")
    tb = time_base(t_s, settings.gap_factor)
    extra_var = saturation_variance(saturated, t_s.shape[0], settings)
    q0 = _init_vector(init, "q_nb", [1.0, 0.0, 0.0, 0.0])
    if q0.shape != (4,) or not 0.5 < np.linalg.norm(q0) < 1.5:
        raise InputError(f"init.q_nb must be a unit quaternion (w, x, y, z), got {q0}")
    q0 = q0 / np.linalg.norm(q0) * (1.0 if q0[0] >= 0 else -1.0)
    bg0 = _init_vector(init, "gyro_bias_b", np.zeros(3))
    ba0 = _init_vector(init, "acc_bias_b", np.zeros(3))
    P0 = initial_covariance(settings)
    zupt_gain = None
    ric_report = None
    smooth = settings.smoother == "rts"
    if settings.mode == "riccati":
        from bootnav.postproc.ins.riccati import paper_zupt_gain

        zupt_gain = paper_zupt_gain(settings, gravity, tb.nominal_dt_s)
        ric_report = zupt_gain.report.to_dict()
        if smooth:
            smooth = False
            warnings.append("smoother disabled in riccati (paper) mode: RTS needs the optimal time-varying P")
    if not stance.any():
        warnings.append("no stance sample: the filter ran open loop (pure strapdown) — the path is not usable")
    if tb.gap_mask.any():
        warnings.append(f"{int(tb.gap_mask.sum())} timestamp gap(s) > {settings.gap_factor} x nominal period "
                        f"(largest {tb.dt_s.max():.4g} s) were propagated as single steps")

    t0 = time.perf_counter()
    if settings.engine == "fast":
        from bootnav.postproc.ins.fast import run_fast

        out, einfo = run_fast(t_s, acc_b, gyro_b, zupt_mask, q0, bg0, ba0, gravity, settings, tb, P0, zupt_gain,
                              smooth, progress, extra_var)
    else:
        from bootnav.postproc.ins.reference import run_reference

        out, einfo = run_reference(t_s, acc_b, gyro_b, zupt_mask, q0, bg0, ba0, gravity, settings, tb, P0,
                                   zupt_gain, smooth, progress, extra_var)
    elapsed = time.perf_counter() - t0
    biases = settings.n_states == 15
    info = {
        "mode": settings.mode,
        "engine": settings.engine,
        "n_states": settings.n_states,
        "smoother": "rts" if smooth else "none",
        "riccati": ric_report,
        "nominal_dt_s": tb.nominal_dt_s,
        "n_duplicates": tb.n_duplicates,
        "gaps": tb.gaps,
        "n_updates": einfo["n_updates"],
        "timings": {"filter_s": elapsed, "kernel_s": einfo["run_s"], "compile_s": einfo.get("compile_s", 0.0)},
        "smoother_segments": einfo.get("smoother_segments", 0),
        "smoother_skipped_steps": einfo.get("smoother_skipped_steps", 0),
        "zupt_onset_samples_skipped": int(stance.sum() - zupt_mask.sum()),
        "zaru": bool(settings.zaru and settings.n_states == 15 and settings.mode == "time_varying"),
        "heading_aid": settings.heading_aid,
        "heading_aid_updates": einfo.get("heading_aid_updates", 0),
        "saturated_samples_inflated": 0 if extra_var is None else int((extra_var > 0).any(axis=1).sum()),
        # 1-σ of every error state at the last sample (δp, δv, δθ[, δb_a, δb_g]), filter (not smoothed)
        "final_state_sigma": np.sqrt(np.maximum(np.diag(einfo["final_P"]), 0.0)).tolist(),
        "warnings": warnings,
        "settings": requested.to_dict(),
    }
    return NavSolution(
        t_s=t_s,
        pos_n=out["pos_n"],
        vel_n=out["vel_n"],
        q_nb=out["q_nb"],
        acc_bias_b=out["acc_bias_b"] if biases else None,
        gyro_bias_b=out["gyro_bias_b"] if biases else None,
        pos_sigma_n=out["pos_sigma_n"],
        info=info,
    )
