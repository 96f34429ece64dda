"""``run_filter``: ZUPT-aided strapdown navigation [Heidari2019, eqs. 1–5; Foxlin2005; Skog2010; Nilsson2012].

Error state δx = x_true − x̂ = (δp_n, δv_n, δθ_n[, δb_a,b, δb_g,b]) with the attitude error a nav-frame
rotation, C_true ≈ (I + [δθ×]) Ĉ. Linearised dynamics (continuous time, A):

    δṗ = δv,   δv̇ = −[f_n×] δθ − Ĉ δb_a − Ĉ w_a,   δθ̇ = −Ĉ δb_g − Ĉ w_g,   δḃ = w_b

discretised per step as F = I + A Δt and Q_d = diag(σ_a² Δt₀ Δt, σ_g² Δt₀ Δt, σ_ba² Δt, σ_bg² Δt)
(σ conventions in settings.py; the rotation Ĉ drops out of isotropic noise).

Time update: mechanization (mechanization.py) + P ← F P Fᵀ + Q_d.
Measurement updates (``measurements.py``, one definition shared by both engines), sequential in this order:
ZUPT in stance (eq. 3 with the sign made explicit): z = 0 − v̂ = H δx + ν, H = [0 I 0], with the rolling-foot
noise R_k = (σ_zupt² + r² |ω_k − b̂_g|²) I; K = P Hᵀ (H P Hᵀ + R)⁻¹, δx = K z, Joseph form
P ← (I−KH) P (I−KH)ᵀ + K R Kᵀ. The paper prints "+ k_n v_n": that is this update with z's minus sign absorbed
in k_n. ZARU (15 states, on by default): z = ω_m − b̂_g = δb_g + ν in stance with the quiet-core noise
R_k = (σ_zaru² + c² |ω_k − b̂_g|²) I. Optional heuristic heading aid (off by default): a scalar yaw
pseudo-measurement at stance onsets. A later update's innovation is z − H δx (δx: this sample's corrections so
far).
Reset after any update: p̂ += δp, v̂ += δv, b̂ += δb, q̂ ← exp(δθ/2) ⊗ q̂ (the quaternion form of ψ ← a(dθ) ψ;
exact rotation, renormalised, not the first-order R ← (I − [δθ×]) R [Sola2017]), then δx ← 0.
ZUPT onset delay: the first min(0.15 s, 1/3 of the phase) of each stance phase gets no ZUPT/ZARU
(``delay_zupt_onsets``: the foot still settles after heel strike).
Saturated samples (``saturated=`` mask): per-sample process noise along the clipped body axis,
Q_v += C diag(σ_sat,a²) Cᵀ Δt₀Δt, Q_θ += C diag(σ_sat,g²) Cᵀ Δt₀Δt (``saturation_variance``).
"riccati" mode: the paper's constant gain from eq. 5 on the observable subsystem (+ the vertical accelerometer
bias with 15 states), a position row from the cross-covariance and the open-loop time, and a bias prior from
the still period (riccati.py); P is still propagated and Joseph-updated with that (suboptimal) gain so
``pos_sigma_n`` stays meaningful.

Engines (``FilterSettings.engine``): ``fast.py`` (numba, production; driven incrementally by
``stream.StreamNavigator``) and ``filterpy_engine.py`` (filterpy, readable); they agree to 1e-9 m. Variants tried and
not kept are in ``docs/tuning-log.md`` (section Filter).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bootnav.core.timebase import GAP_FACTOR, time_base
from bootnav.postproc.ins.measurements import (HEADING_AID, LEVEL_HEIGHT, ZUPT, LevelHeightMeasurement,
                                               ZaruMeasurement)
from bootnav.postproc.ins.mechanization import validate_imu
from bootnav.postproc.ins.prepare import (MAX_LISTED_GAPS, FilterSetup, delay_zupt_onsets, initial_covariance,
                                          prepare_filter, saturation_variance)
from bootnav.postproc.ins.settings import FilterSettings

__all__ = ["FilterSetup", "NavSolution", "delay_zupt_onsets", "initial_covariance", "prepare_filter", "run_filter",
           "saturation_variance", "warm_up"]


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
    pos_cov_en: np.ndarray | None = None  # (N,) the filter's east-north position covariance P_EN, m² (ellipses)


def navigator(init, gravity: float, nominal_dt_s: float, settings: FilterSettings | None = None):
    """The navigator of ``settings.engine`` from an initial state, as the block passes build theirs
    (``passes.BlockPasses``): "fast" → ``StreamNavigator.from_initial_state`` (rows as they become final,
    memory bounded); "reference" → ``filterpy_engine.RecordReference`` (the same ``push`` / ``finish`` /
    ``info`` / ``covariance``; every row at ``finish``, the whole record kept: a slow, readable check).

    Parameters
    ----------
    init : object
        Initial state (``StreamNavigator.from_initial_state``'s).
    gravity : float
        Local gravity magnitude, m/s².
    nominal_dt_s : float
        Nominal sample period, s.
    settings : FilterSettings, optional
        Default ``FilterSettings()``.
    """
    settings = settings or FilterSettings()
    settings.validate()
    if settings.engine == "reference":
        from bootnav.postproc.ins.filterpy_engine import RecordReference

        return RecordReference(init, gravity, nominal_dt_s, settings)
    from bootnav.postproc.ins.stream import StreamNavigator

    return StreamNavigator.from_initial_state(init, gravity, nominal_dt_s, settings)


def propagated_gaps_warning(n_gaps: int, largest_s: float) -> str:
    """The warning of a run with timestamp gaps (steps > ``GAP_FACTOR`` nominal periods): the filter propagates
    each as one step."""
    return (f"{n_gaps} timestamp gap(s) > {GAP_FACTOR:g} x nominal period (largest {largest_s:.4g} s) were "
            "propagated as single steps")


def run_filter(t_s, acc_b, gyro_b, stance, init, gravity: float, settings: FilterSettings | None = None,
               progress=None, saturated=None, heading_gate=None) -> NavSolution:
    """ZUPT-aided INS over a whole record: filter (and by default RTS smoother) on the raw timestamps.

    Position starts at the origin, velocity at 0 (the record starts still).

    Parameters
    ----------
    t_s : (N,) array
        Sample times, s, non-decreasing (duplicates allowed: no propagation, the sample may still be updated).
    acc_b : (N, 3) array
        Specific force, body frame, m/s² (+g up at rest).
    gyro_b : (N, 3) array
        Angular rate, body frame, rad/s.
    stance : (N,) bool array
        True where the foot is still (a stance detector's output): ZUPT/ZARU apply there, after the onset
        delay (``delay_zupt_onsets``).
    init : object
        Initial state with ``q_nb`` (4,) wxyz and ``gyro_bias_b`` (3,) rad/s; optional ``acc_bias_b`` (3,)
        m/s² and ``acc_mean_b`` (the still period's mean specific force, used by the riccati mode), e.g.
        ``bootnav.postproc.calibration.InitialState``. A missing ``q_nb`` / bias means level / zero.
    gravity : float
        Local gravity magnitude, m/s² (5-15).
    settings : FilterSettings, optional
        Every tunable; default ``FilterSettings()``.
    progress : callable, optional
        ``progress(fraction)``, called a few times.
    saturated : array, optional
        Per-sample saturation mask (``saturation_variance`` lists the accepted forms).
    heading_gate : (N,) bool array, optional
        Where the heading aid (when on) may correct a stride (``building.directions.segment_gate``: the
        straight legs along the building's grid); None: everywhere.

    Returns
    -------
    NavSolution
        Per-sample position, velocity, attitude, biases (15 states) and position sigma; ``info`` has the
        mode, engine, update counts, timings, warnings and the settings used (JSON-serialisable).

    Raises
    ------
    InputError
        Bad data (shapes, non-finite values, timestamps going back, bad initial state or gravity).
    ValueError
        Bad settings.
    """
    settings = settings or FilterSettings()
    settings.validate()
    t_s, acc_b, gyro_b = validate_imu(t_s, acc_b, gyro_b, stance)
    stance = np.ascontiguousarray(stance, dtype=bool)
    zupt_mask = delay_zupt_onsets(t_s, stance, settings.zupt_onset_delay_s, settings.zupt_onset_max_fraction)
    tb = time_base(t_s)
    extra_var = saturation_variance(saturated, t_s.shape[0], settings)
    prep = prepare_filter(init, gravity, settings, tb.nominal_dt_s, t_s, zupt_mask)
    warnings = run_warnings(prep, stance, tb, extra_var)
    t0 = time.perf_counter()
    out, einfo = _engine(settings.engine)(t_s, acc_b, gyro_b, zupt_mask, prep, settings, tb, progress, extra_var,
                                          heading_gate=heading_gate)
    einfo = dict(einfo, filter_s=time.perf_counter() - t0)
    info = _run_info(settings, prep, tb, einfo, stance, zupt_mask, extra_var, warnings)
    biases = settings.n_states == 15
    return NavSolution(
        t_s=t_s,
        pos_n=out["pos_n"],
        vel_n=out["vel_n"],
        q_nb=out["q_nb"],
        acc_bias_b=out["acc_bias_b"] if biases else None,
        gyro_bias_b=out["gyro_bias_b"] if biases else None,
        pos_sigma_n=out["pos_sigma_n"],
        info=info,
        pos_cov_en=out.get("pos_cov_en"),
    )


def _engine(name: str):
    """The whole-record runner of the engine ``FilterSettings.engine`` names (module docstring)."""
    if name == "fast":
        from bootnav.postproc.ins.stream import run_fast

        return run_fast
    from bootnav.postproc.ins.filterpy_engine import run_reference

    return run_reference


def run_warnings(prep: FilterSetup, stance, tb, extra_var) -> list[str]:
    """The warnings of a whole-record run (besides the engine's): the paper mode's saturated samples, the
    preparation's, no stance at all, timestamp gaps."""
    warnings: list[str] = []
    if prep.zupt_gain is not None and extra_var is not None:
        warnings.append(f"riccati (paper) mode: {int((extra_var > 0).any(axis=1).sum())} saturated samples; "
                        "the constant gain cannot widen its uncertainty after a clipped swing (the time-varying "
                        "filter does), so the tilt and height after it are less trustworthy")
    warnings += prep.warnings
    if not stance.any():
        warnings.append("no stance sample: the filter ran open loop (pure strapdown) — the path is not usable")
    if tb.gap_mask.any():
        warnings.append(propagated_gaps_warning(int(tb.gap_mask.sum()), float(tb.dt_s.max())))
    return warnings


def _run_info(settings: FilterSettings, prep: FilterSetup, tb, einfo: dict, stance, zupt_mask, extra_var,
              warnings: list[str]) -> dict:
    """``NavSolution.info`` of a whole-record run (JSON-serialisable): mode, engine, update counts, smoother,
    timings, what the onset delay and the saturation did, the gaps (at most ``MAX_LISTED_GAPS``), the final
    σ of every error state, warnings and the settings."""
    return {
        "mode": settings.mode,
        "engine": settings.engine,
        "n_states": settings.n_states,
        "smoother": "rts" if prep.prm.smooth else "none",
        "riccati": None if prep.zupt_gain is None else prep.zupt_gain.report.to_dict(),
        "nominal_dt_s": tb.nominal_dt_s,
        "n_duplicates": tb.n_duplicates,
        "gaps": tb.gaps[:MAX_LISTED_GAPS],
        "n_updates": int(einfo["applied"][ZUPT]),
        "timings": {"filter_s": einfo["filter_s"], "kernel_s": einfo["run_s"], "compile_s": einfo.get("compile_s", 0.0)},
        "smoother_segments": einfo.get("smoother_segments", 0),
        "smoother_skipped_steps": einfo.get("smoother_skipped_steps", 0),
        "zupt_onset_samples_skipped": int(stance.sum() - zupt_mask.sum()),
        "zaru": ZaruMeasurement.active(settings),
        "heading_aid": settings.heading_aid,
        "heading_aid_updates": int(einfo["applied"][HEADING_AID]),
        "level_height": LevelHeightMeasurement.active(settings),
        "level_height_updates": int(einfo["applied"][LEVEL_HEIGHT]),
        "saturated_samples_inflated": 0 if extra_var is None else int((extra_var > 0).any(axis=1).sum()),
        # 1-σ of every error state at the last sample (δp, δv, δθ[, δb_a, δb_g]), filter (not smoothed)
        "final_state_sigma": np.sqrt(np.maximum(np.diag(einfo["final_P"]), 0.0)).tolist(),
        "warnings": warnings,
        "settings": settings.to_dict(),
    }


_WARM = False


def warm_up() -> float:
    """Compile (or load from the numba cache) every fast-engine kernel variant; returns the seconds spent."""
    global _WARM
    t0 = time.perf_counter()
    if not _WARM:
        class _Init:
            q_nb = np.array([1.0, 0.0, 0.0, 0.0])
            gyro_bias_b = np.zeros(3)

        t = np.arange(40) * 0.01
        acc = np.tile([0.0, 0.0, 9.81], (40, 1))
        gyr = np.zeros((40, 3))
        st = np.ones(40, bool)
        for n in (9, 15):
            for sm in ("rts", "none"):
                run_filter(t, acc, gyr, st, _Init(), 9.81, FilterSettings(n_states=n, smoother=sm))
        run_filter(t, acc, gyr, st, _Init(), 9.81, FilterSettings(mode="riccati"))
        _WARM = True
    return time.perf_counter() - t0
