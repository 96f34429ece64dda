"""``FilterSettings``: every tunable of the ZUPT navigation filter, saved with the results (OpenShoe style).

Noise convention (documented because the literature mixes two):
``sigma_acc_mps2`` / ``sigma_gyro_radps`` are the standard deviations of the accelerometer / gyro error
of ONE sample at the nominal sample period Δt₀ (OpenShoe's σ_a, σ_g). The process noise of a step of length
Δt is ``Q_d = σ² Δt₀ Δt`` (white-noise density σ²Δt₀ integrated over Δt), which equals OpenShoe's
``Ts² σ²`` for uniform sampling and grows linearly, as it physically should, over jitter and gaps.
Bias random walks are densities (unit/√s): ``Q_d = σ_rw² Δt``.
The continuous-time Riccati ("paper") mode uses the same densities: W = σ² Δt₀, V = σ_zupt² Δt₀.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

DEG = math.pi / 180.0


@dataclass
class FilterSettings:
    """Tunables of ``bootnav.postproc.ins.run_filter`` (defaults: OpenShoe-like, then tuned on the developer data).

    n_states: 9 = (δp, δv, δθ) [Skog 2010, OpenShoe]; 15 = + accelerometer bias δb_a, gyro bias δb_g (body).
        Default 15: on the developer data it beat 9 states (pyshoe_vicon mean armse_2d 0.070 vs 0.071 m;
        mean closure of the three closed loops 1.0 % vs 1.2 %; benchmarks/bench_filter.py).
    mode: "time_varying" (default; discrete KF, P propagated and updated) or "riccati" (seed-004 eqs. 4–5:
        constant gain from the continuous algebraic Riccati equation on the observable subsystem
        (velocity, roll, pitch); position and yaw propagated open loop). It always runs the paper's 9-state
        model: with n_states=15 the biases stay at their initial values (a warning says so).
    engine: "fast" (numba, production) or "reference" (filterpy ``KalmanFilter``, per-sample Python loop).
    sigma_acc_mps2, sigma_gyro_radps: per-sample IMU noise at the nominal rate (see module docstring).
        σ_g 0.6 °/s (was 0.5) together with the 0.15 s onset delay (below): one joint change measured on the
        foot-set eval (benchmarks/accuracy_foot.py), before -> after: pyshoe_vicon 0.0662 -> 0.0658 m,
        xio closure 0.695 -> 0.666 % (closure_v 0.199 -> 0.183 m), openshoe 0.633 -> 0.631 %, koroglu_footprints
        1.740 -> 1.741 %, koroglu_rectangles 1.216 -> 1.220 %, iez 2.22 -> 2.11 % (closure_v 0.288 -> 0.265 m),
        voisard 3.609 -> 3.607 %, gaitmap stride MAE 0.0311 -> 0.0306 m; stairs unchanged (gaitmap stair_up
        dz L/R 4.51/5.22 m, three-floors sim climb 8.92 of 9 m). Grid 0.125-0.175 s × 0.6-0.8 °/s ×
        max_fraction 1/3-0.5 is smooth: longer delay / larger fraction -> better loops and gaitmap, worse
        pyshoe_vicon (running); larger σ_g -> better pyshoe_vicon, openshoe, rectangles, worse footprints
        (0.8 °/s, 0.4: xio 0.66 %, gaitmap 0.029 m but footprints 1.79 %, pyshoe 0.066 m).
    sigma_acc_bias_rw, sigma_gyro_bias_rw: bias random walks, m/s²/√s and rad/s/√s (15 states only).
        Gyro 3e-5 rad/s/√s (0.1 mrad/s drift in 10 s, 1.8 mrad/s in an hour; OpenShoe uses far less): with
        ZARU on, 1e-4 let the bias follow the foot's real slow rotation in stance (koroglu_rectangles closure
        4.6 % at 1e-4, 2.6 % at 3e-5, 2.4 % at 1e-5; 3e-4: 10.7 %); openshoe_820 prefers a faster walk
        (0.56 -> 0.63 %).
    sigma_zupt_mps: std of the zero-velocity pseudo-measurement (how still a foot in stance really is).
    zaru: zero-angular-rate update in stance (z = ω_m − b̂_g on the gyro-bias states; needs 15 states),
        "quiet-core" form: R_k = σ_zaru² + |ω_k − b̂_g|², so a rolling foot's own rate counts as
        measurement noise and the update only bites where the foot is really still (the plain form,
        R = σ_zaru², made pyshoe_vicon armse_2d 8x worse because detected stance includes heel/toe roll).
        On by default: it observes the z gyro bias that ZUPT cannot (heading drift). Foot-set eval
        (benchmarks/accuracy_foot.py): koroglu_rectangles closure 8.2 -> 4.9 %, koroglu_footprints
        final error 4.9 -> 2.9 %, pyshoe_vicon 0.073 -> 0.066 m; costs iez closure_v 0.52 -> 0.61 m.
        It needs the gyro-bias states: with n_states=9 or mode="riccati" it is not applied
        (``NavSolution.info["zaru"]`` says whether it ran). sigma_zaru_radps: its measurement std in a still foot.
        zaru_rate_factor c: R_k = σ_zaru² + (c |ω_k − b̂_g|)²; c = 1 (default); 3 or 10 weaken the update and
        undo most of its gain (koroglu_rectangles 2.6 -> 5.1 / 5.7 %) while improving iez a little (3.1 -> 2.9 %).
    zupt_lever_arm_m: r of the rolling-foot ZUPT noise R_k = σ_zupt² + (r |ω_k − b̂_g|)² per axis: a foot
        rolling over heel or toe at rate ω moves the sensor at ≈ ω × r (r = distance from the contact
        point, ~0.05-0.15 m), so zero velocity is only that certain at the edges of a stance phase.
        0 = the classic constant R. Default 0.05 m (pyshoe_vicon 0.073 -> 0.069 m, worst trial 0.20 -> 0.17 m).
    zupt_onset_delay_s, zupt_onset_max_fraction: no ZUPT/ZARU in the first min(delay, fraction × duration)
        of each stance phase (``filter.delay_zupt_onsets``: the foot is still settling after heel strike;
        a ZUPT there turns real motion into a position correction, +1.5 cm UP per stride on the loops).
        Foot-set eval, 0 -> 0.1 s / 1/3: xio closure_v 0.34 -> 0.18 m, iez closure_v median 0.50 -> 0.26 m,
        pyshoe_vicon 0.066 -> 0.067 m (median 0.054 -> 0.051), gaitmap stride MAE 0.039 -> 0.031 m;
        openshoe 0.50 -> 0.56 %. Larger delays keep improving the loops' height a little (0.2 s: xio 0.14 m)
        at the cost of pyshoe_vicon's running trials. 0 = off (every detected stance sample is a ZUPT).
        Default now 0.15 s (loading response 0.1-0.15 s of a 1.0-1.4 s gait cycle; see sigma_gyro_radps).
    acc_scale_noise, gyro_scale_noise: κ of a signal-proportional (scale-factor) per-sample noise,
        σ_k² = σ² + κ² |signal_k|². Default 0: measured no gain (0.02-0.05 traded one set against another).
    sat_acc_sigma_mps2, sat_gyro_sigma_radps: extra per-sample std of a SATURATED (clipped) sample along the
        clipped body axis (``run_filter(saturated=...)``, ``filter.saturation_variance``): the true value
        beyond full scale is unknown (a foot swing that clips a ±250 °/s gyro peaks ~1-2 rad/s above it).
        Defaults 5 m/s², 1 rad/s (the acc part is neutral on the data: iez closure 2.20 % at 0, 2.22 % at 5,
        2.37 % at 20 m/s²; kept small because a clipped impact does hide velocity change). iez_mpu6050 (the ±2 g / ±250 °/s files clip; with the both-rails clipping
        mask of detectors._common): closure 3.1 -> 2.2 %, closure_v 0.47 -> 0.29 m (gyro 0.3: 2.6 %, 2: 2.3 %;
        conf-3030 8.1 -> 4.7 %); no other set clips. An isotropic (all-axes) inflation was worse (the yaw
        part is unobservable), and so was bridging the clipped plateau with a parabola through its
        neighbours (conf-3030 12.8 -> 32 %): the clipped excess is not recoverable, only its uncertainty.
    """

    n_states: int = 15
    mode: str = "time_varying"
    engine: str = "fast"
    sigma_acc_mps2: float = 0.5
    sigma_gyro_radps: float = 0.6 * DEG
    acc_scale_noise: float = 0.0
    gyro_scale_noise: float = 0.0
    sigma_acc_bias_rw: float = 1e-3
    sigma_gyro_bias_rw: float = 3e-5
    sigma_zupt_mps: float = 0.01
    zupt_lever_arm_m: float = 0.05
    zupt_onset_delay_s: float = 0.15
    zupt_onset_max_fraction: float = 1.0 / 3.0
    sat_acc_sigma_mps2: float = 5.0
    sat_gyro_sigma_radps: float = 1.0
    zaru: bool = True
    sigma_zaru_radps: float = 0.1 * DEG
    zaru_rate_factor: float = 1.0
    init_pos_sigma_m: float = 1e-3
    init_vel_sigma_mps: float = 1e-2
    init_att_sigma_rad: float = 0.1 * DEG
    init_yaw_sigma_rad: float = 0.1 * DEG
    init_acc_bias_sigma_mps2: float = 0.1
    init_gyro_bias_sigma_radps: float = 0.1 * DEG
    smoother: str = "rts"
    smoother_max_segment_s: float = 5.0
    gap_factor: float = 5.0
    heading_aid: str = "none"
    hde_threshold_rad: float = 10.0 * DEG
    sigma_hde_rad: float = 5.0 * DEG
    hde_min_stride_m: float = 0.3

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first bad field."""
        if self.n_states not in (9, 15):
            raise ValueError(f"FilterSettings.n_states must be 9 or 15, got {self.n_states}")
        if self.mode not in ("time_varying", "riccati"):
            raise ValueError(f"FilterSettings.mode must be 'time_varying' or 'riccati', got {self.mode!r}")
        if self.engine not in ("fast", "reference"):
            raise ValueError(f"FilterSettings.engine must be 'fast' or 'reference', got {self.engine!r}")
        if self.smoother not in ("rts", "none"):
            raise ValueError(f"FilterSettings.smoother must be 'rts' or 'none', got {self.smoother!r}")
        if self.heading_aid not in ("none", "dominant_directions"):
            raise ValueError(
                f"FilterSettings.heading_aid must be 'none' or 'dominant_directions', got {self.heading_aid!r}"
            )
        if self.heading_aid != "none" and self.mode == "riccati":
            raise ValueError("FilterSettings.heading_aid needs mode='time_varying' (the paper mode has no yaw gain)")
        for f in fields(self):
            if f.name in ("zupt_lever_arm_m", "zaru_rate_factor", "acc_scale_noise", "gyro_scale_noise", "zupt_onset_delay_s",
                          "zupt_onset_max_fraction") or f.name.startswith("sat_"):
                v = getattr(self, f.name)
                if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                    raise ValueError(f"FilterSettings.{f.name} must be a finite number >= 0, got {v!r}")
                continue
            if f.name.startswith(("sigma_", "init_", "hde_")) or f.name in ("smoother_max_segment_s", "gap_factor"):
                v = getattr(self, f.name)
                if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                    raise ValueError(f"FilterSettings.{f.name} must be a finite number > 0, got {v!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "FilterSettings":
        known = {f.name for f in fields(cls)}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"unknown FilterSettings field(s): {sorted(unknown)}")
        return cls(**d)
