"""``KernelParams``: the numbers the filter kernels and measurement models read, as a ``typing.NamedTuple``.

A NamedTuple of floats / ints / bools is passed to numba as one typed struct (fields are compile-time names,
no array filled by index), the pattern of gaitmap's ``SimpleZuptParameter`` [Kuderle2024]. Variances are
precomputed from ``FilterSettings`` here, once, so both engines and every model use the very same numbers.
"""

from __future__ import annotations

from typing import NamedTuple

from bootnav.postproc.ins.settings import FilterSettings


class KernelParams(NamedTuple):
    """Kernel-side view of ``FilterSettings`` (units: SI; Δt₀ = nominal sample period).

    Every float field is a Python float (``kernel_params`` converts), so numba compiles one signature.
    """

    gravity: float  # local gravity magnitude g, m/s²
    var_acc: float  # σ_a² Δt₀: accelerometer white-noise density, (m/s²)² s  (Q_v = var_acc Δt)
    var_gyro: float  # σ_g² Δt₀: gyro white-noise density, (rad/s)² s
    var_acc_scale: float  # κ_a² Δt₀: signal-proportional acc noise, s  (adds var_acc_scale |f_b|²)
    var_gyro_scale: float  # κ_g² Δt₀, s
    var_acc_bias_rw: float  # σ_ba²: accelerometer-bias random-walk density, (m/s²)²/s
    var_gyro_bias_rw: float  # σ_bg², (rad/s)²/s
    var_zupt: float  # σ_zupt², (m/s)²
    lever_arm2: float  # r² of the rolling-foot ZUPT noise, m²
    var_zaru: float  # σ_zaru², (rad/s)²
    zaru_rate_factor2: float  # c² of the quiet-core ZARU noise (dimensionless)
    var_hde: float  # σ_hde², rad²
    hde_threshold_rad: float  # heading-aid gate |e| < threshold, rad
    hde_min_stride_m: float  # shortest stride that gives a heading-aid measurement, m
    var_level: float  # σ_level², m²: height change of a level stride (floor flatness)
    level_max_dz_m: float  # a stride whose height changes less than this is level, m
    level_min_stride_m: float  # a move shorter than this (horizontal) is a heel/toe roll, not a stride, m
    midpoint: bool  # rotate f_b with the attitude at the middle of its step (FilterSettings.strapdown)
    riccati: bool  # paper mode: constant Riccati ZUPT gain instead of the Kalman gain
    smooth: bool  # run the segment RTS smoother
    max_segment: int  # longest smoother segment, samples


def kernel_params(settings: FilterSettings, gravity: float, nominal_dt_s: float, riccati: bool, smooth: bool,
                  max_segment: int) -> KernelParams:
    """Build the kernel parameters of one run.

    Parameters
    ----------
    settings : the run's (validated) filter settings.
    gravity : local gravity magnitude, m/s².
    nominal_dt_s : nominal sample period Δt₀, s (per-sample sigmas are defined at it; ``settings.py``).
    riccati, smooth : paper mode on; RTS smoother on.
    max_segment : smoother segment length cap, samples.

    Returns
    -------
    KernelParams
    """
    return KernelParams(
        gravity=float(gravity),
        var_acc=float(settings.sigma_acc_mps2**2 * nominal_dt_s),
        var_gyro=float(settings.sigma_gyro_radps**2 * nominal_dt_s),
        var_acc_scale=float(settings.acc_scale_noise**2 * nominal_dt_s),
        var_gyro_scale=float(settings.gyro_scale_noise**2 * nominal_dt_s),
        var_acc_bias_rw=float(settings.sigma_acc_bias_rw**2),
        var_gyro_bias_rw=float(settings.sigma_gyro_bias_rw**2),
        var_zupt=float(settings.sigma_zupt_mps**2),
        lever_arm2=float(settings.zupt_lever_arm_m**2),
        var_zaru=float(settings.sigma_zaru_radps**2),
        zaru_rate_factor2=float(settings.zaru_rate_factor**2),
        var_hde=float(settings.sigma_hde_rad**2),
        hde_threshold_rad=float(settings.hde_threshold_rad),
        hde_min_stride_m=float(settings.hde_min_stride_m),
        var_level=float(settings.sigma_level_m**2),
        level_max_dz_m=float(settings.level_max_dz_m),
        level_min_stride_m=float(settings.level_min_stride_m),
        midpoint=settings.strapdown != "endpoint",
        riccati=bool(riccati),
        smooth=bool(smooth),
        max_segment=int(max_segment),
    )
