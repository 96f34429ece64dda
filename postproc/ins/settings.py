"""``FilterSettings``: every tunable of the ZUPT navigation filter, saved with the results (as OpenShoe does).

Noise convention (documented because the literature mixes two):
``sigma_acc_mps2`` / ``sigma_gyro_radps`` are the standard deviations of the accelerometer / gyro error
of ONE sample at the nominal sample period Δt₀ (OpenShoe's σ_a, σ_g [Nilsson2012]). The process noise of a step
of length Δt is ``Q_d = σ² Δt₀ Δt`` (white-noise density σ²Δt₀ integrated over Δt), which equals OpenShoe's
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
    """Tunables of ``bootnav.postproc.ins.run_filter``, saved with every result.

    Starting values as pyshoe's [Wagstaff2017] (after OpenShoe [Nilsson2012]); the tuned ones were chosen on
    all developer recordings at once (pre-LODO). The figures behind every default are in
    ``docs/tuning-log.md`` (section Filter).

    Attributes
    ----------
    n_states : int
        Error-state size: 9 = (δp, δv, δθ) [Skog2010]; 15 = + accelerometer bias δb_a and gyro bias δb_g
        (body frame) [Groves2013]. Default 15: MEMS biases drift within a walk, and ZARU needs δb_g.
    mode : str
        "time_varying": discrete Kalman filter, P propagated and updated [Skog2010]. "riccati": the source
        paper's constant gain from the continuous algebraic Riccati equation [Heidari2019, eqs. 3–5]
        (``riccati.py`` says which states it corrects), to reproduce the paper.
    engine : str
        "fast" (numba kernel, production) or "reference" (filterpy ``KalmanFilter`` [Labbe-filterpy],
        per-sample Python loop): the same filter to 1e-9 m; the reference is the readable check. Every pass
        of ``process`` honours it (``filter.navigator``); the reference keeps the whole record in memory and
        costs ~0.12 ms per sample and filter run, ~40× the fast engine: ``process`` of 4 min at 200 Hz takes
        ~19 s instead of 0.5 s (it runs the filter 3-4 times), an hour would take ~5 min.
    sigma_acc_mps2, sigma_gyro_radps : float
        Accelerometer (m/s²) and gyro (rad/s) error std of one sample at the nominal period (module
        docstring): white noise plus the unmodelled errors of a foot-mounted MEMS unit (vibration, impacts,
        scale factor, coning). 0.5 m/s² [Wagstaff2017]; 0.6 °/s, pyshoe's 0.5 °/s tuned together with the
        ZUPT onset delay.
    acc_scale_noise, gyro_scale_noise : float
        κ (dimensionless) of a signal-proportional per-sample noise, σ_k² = σ² + κ² |signal_k|² (a scale-factor
        error grows with the signal [Groves2013]). Default 0: no gain measured.
    sigma_acc_bias_rw, sigma_gyro_bias_rw : float
        Bias random-walk densities, m/s²/√s and rad/s/√s (15 states): how fast a bias may wander
        [Groves2013]. 1e-3 m/s²/√s (0.06 m/s² in an hour); 3e-5 rad/s/√s (1.8 mrad/s in an hour): slow enough
        that ZARU does not turn the foot's real slow rotation in stance into bias.
    sigma_zupt_mps : float
        Std of the zero-velocity pseudo-measurement, m/s: how still a foot in stance really is. 0.01 m/s
        [Wagstaff2017; Nilsson2012].
    zupt_lever_arm_m : float
        r of the rolling-foot ZUPT noise R_k = σ_zupt² + (r |ω_k − b̂_g|)² per axis, m: a foot rolling over
        heel or toe at rate ω moves the sensor at ≈ ω r (r = distance from the contact point, 0.05-0.15 m).
        0.05 m; 0 = the classic constant R.
    zupt_onset_delay_s, zupt_onset_max_fraction : float
        No ZUPT/ZARU in the first min(delay, fraction × duration) of each stance phase (s, dimensionless;
        ``prepare.delay_zupt_onsets``): the foot still settles after heel strike (loading response, 0.1-0.15 s
        of a 1.0-1.4 s gait cycle [Perry2010]). 0.15 s, at most 1/3 of the phase (keeps most of a short
        running stance); 0 = off.
    sat_acc_sigma_mps2, sat_gyro_sigma_radps : float
        Extra per-sample std of a saturated (clipped) sample along the clipped body axis, m/s² and rad/s
        (``run_filter(saturated=...)``, ``filter.saturation_variance``): the true value beyond full scale is
        unknown; a foot swing that clips a ±250 °/s gyro peaks ~1-2 rad/s above it, hence 1 rad/s; 5 m/s² for
        a clipped impact. Only the uncertainty of the clipped excess is modelled: it cannot be recovered.
    sloping_rails : bool
        Also find the gyro rails that a calibrated output makes slope (``bootnav.core.arrays.sloping_rails``;
        a sensor that clips and then applies its factory calibration, e.g. MicroStrain's ``scaledGyro``,
        does not repeat one value at full scale) and treat them as clipped (``sat_gyro_sigma_radps``).
        In blocks (``checks.ClipRails``) each block finds its own sloping rails (a rail shows on many swings of
        one block), so one block flags exactly what the whole record does. True: a sample on a rail is a
        lower bound, not a measurement, whether or not the output repeats one value there (physics; the
        leave-one-dataset-out check is flat, 1.002, as nothing but the railed MicroStrain files moves;
        docs/tuning-log.md 2026-12-02).
    zaru : bool
        Zero-angular-rate update in stance (z = ω_m − b̂_g on δb_g; 15 states, time-varying mode): it observes
        the vertical gyro bias that the ZUPT cannot (heading drift) [Groves2013]. Quiet-core noise (below).
        ``NavSolution.info["zaru"]`` says whether it ran.
    sigma_zaru_radps : float
        ZARU measurement std in a still foot, rad/s. 0.1 °/s.
    zaru_rate_factor : float
        c of the quiet-core ZARU noise R_k = σ_zaru² + (c |ω_k − b̂_g|)² (dimensionless): a rolling foot's own
        rate counts as noise, so the update only bites where the foot is really still (detected stance
        includes heel and toe roll). 1.
    init_pos_sigma_m, init_vel_sigma_mps, init_att_sigma_rad, init_yaw_sigma_rad : float
        Initial error std: position (m; the origin is the start, 1 mm), velocity (m/s; still at the start),
        roll/pitch (rad; levelled from the still period), yaw (rad; the start defines the heading, and ZUPTs
        cannot observe it). 1 mm, 0.01 m/s, 0.1°, 0.1°.
    init_acc_bias_sigma_mps2, init_gyro_bias_sigma_radps : float
        Initial bias std, m/s² and rad/s (15 states): after the still-period calibration (gyro) and without
        one (accelerometer: turn-on bias of a MEMS unit). 0.1 m/s², 0.1 °/s.
    smoother : str
        "rts": Rauch-Tung-Striebel smoothing of each segment between stance phases [RTS1965; Colomar2012]
        (spreads the velocity error found at heel strike back over the swing); "none".
    smoother_max_segment_s : float
        Longest buffered smoother segment, s: bounds memory (longer swings or stances are smoothed in pieces).
        5 s.
    heading_aid : str
        "auto" (default), "none" or "dominant_directions": the heuristic heading aid of
        ``measurements.heading_aid`` [Borenstein2009] assumes a building with rectilinear floor plans; "auto"
        switches it on when the strides of the unaided path show such a grid, and then only on the straight
        legs along it (``postproc.building.directions``; ``bootnav live``: from the strides seen so far).
        Default "auto" by leave-one-dataset-out validation: identical on the sets where it stays off, better on
        the rectilinear ones, and on simulated building missions (``docs/building.md``).
    heading_aid_reference_rad : float or None
        Grid direction of the aid in the path frame, rad; None: the first stride of at least
        ``hde_min_stride_m`` sets it ("auto" sets it from the strides it decided on).
    hde_auto_window : int
        "auto": straight strides per window (each window has its own grid direction, so the unaided path's
        heading drift within one window must stay below the tolerance: ~1 min of walking). 40.
    hde_auto_min_strides : int
        "auto": fewest straight strides to decide on (a shorter walk keeps the aid off). 10.
    hde_auto_tolerance_rad : float
        "auto": a straight stride is on the grid within this angle, rad: σ_hde, how straight a corridor walk
        is. 5° (strides in random directions: 11 % on the grid).
    hde_auto_min_share : float
        "auto": share of the straight strides on the grid for the aid to switch on. 0.5.
    hde_auto_min_cross : float
        "auto": share of the aligned strides on the axis at right angles to the main one (a corridor at right
        angles walked; an out-and-back walk has none, as its turns are not straight strides). 0.02: one
        straight stride in 50 (in a building most straight strides run along the long corridors).
    heading_aid_segments : bool
        "auto", once on: the aid corrects only the strides of straight legs along the building's grid where
        the strides around them show the grid (``building.directions.segment_flags``; per segment, in the
        spirit of iHDE [Jimenez2011]); False: every stride within ``hde_threshold_rad`` of the grid. True.
    hde_leg_min_strides : int
        "auto" per segment: fewest consecutive strides within ``hde_auto_tolerance_rad`` of their mean heading
        that make a straight leg (a stride and its two neighbours, the aid's own notion of straight). 3.
    revisits : str
        "none", "entry", "stairs" or "entry+stairs": correct the smoothed path by a pose graph over strides
        where the walker comes back to a place already visited (``postproc.building.revisits``). Off: see
        docs/building.md for what it does.
    revisit_entry_gate : float
        "entry": the last footprint is tied to the first when they are closer than this share of the distance
        walked: 0.01, the drift of a foot INS (~1 % of the distance). A larger gap comes from scale or heading
        errors, which a position graph cannot undo (it bends the path: docs/tuning-log.md).
    revisit_stair_gate_m : float
        "stairs": two parallel flights are the same (or stacked) when both ends are this close, m. 3 m (the
        drift between two visits; flights of one stairwell in the same direction are stacked exactly).
    revisit_sigma_m : float
        Std of a revisit edge, m (where a foot lands at a door or on a step). 0.3 m.
    revisit_step_sigma_m : float
        Least std of one stride's odometry edge, m (the filter's covariance misses unmodelled errors). 0.05 m.
    hde_threshold_rad : float
        The aid acts only on strides within this angle of a dominant direction, rad. 10°.
    sigma_hde_rad : float
        Its measurement std, rad: how straight a corridor walk is. 5°.
    hde_min_stride_m : float
        Shortest stride that counts, m (shuffling and turning on the spot give no heading). 0.3 m.
    strapdown : str
        The strapdown step (``mechanization.py``, ``increments.py``). "increments" (default): the samples are
        the sensor's increments over their interval (Δθ/Δt, Δv/Δt: what a DLPF or accumulate-and-dump stage,
        or a block mean, delivers): f_b rotated with the attitude at the middle of the step, q_{k−1} ⊗
        exp(θ_k/2) (the rotation-compensation term [Savage1998]), plus the two-sample sculling and coning
        terms. "midpoint": the middle-of-step rotation alone. "endpoint": the attitude at the end of the step
        (OpenShoe's ordering [Nilsson2012]): f_n and the attitude half a sample apart, a timing error of Δt/2
        (2.5 ms at 200 Hz) that makes the height depend on the rate (docs/tuning-log.md, "Height at low
        rates"). A point sample with the first-order attitude step is half a sample ahead too, so the middle
        of the step is right for it as well on a foot, which starts from rest.
    level_height : bool
        Height hold on level strides (``measurements.level_height``): at each stance onset, a stride whose
        estimated height change is below ``level_max_dz_m`` gets the pseudo-measurement "no height change since
        the previous footfall" [MunozDiaz2018]. On by default (``docs/floors.md``); False = height integrated
        freely.
    level_max_dz_m : float
        A stride is level when |Δh| < this, m. 0.075 m: half the lowest riser (0.15 m): a stride on stairs
        changes the height by at least one riser, while the vertical drift of a level stride is millimetres to a
        centimetre or two (0.2–0.9 % of the distance walked). Physics, not tuned; a ramp steeper than 0.075 m
        per stride (5 % at 1.4 m strides) is not flattened, a gentler one is.
    level_min_stride_m : float
        After a stair stride, a move shorter than this (horizontal, m) is not a stride but the foot rolling
        onto its heel (stairs down land toe-first): the sensor's height changes by centimetres with the foot's
        pitch, so it is not held, and the reference moves on to where the foot settles. 0.10 m: a roll moves a sensor within 0.15 m of the pivot by at most r·θ ≈ 0.08 m
        horizontally (θ ≤ 35°, a steep toe-off).
    sigma_level_m : float
        Std of the height change of a level stride, m: floor flatness, 4 mm over 1 m and 10 mm over 4 m for
        finished floors [DIN18202], plus the foot not landing on exactly the same sole point. 5 mm.
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
    sloping_rails: bool = True
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
    heading_aid: str = "auto"
    heading_aid_reference_rad: float | None = None
    hde_auto_window: int = 40
    hde_auto_min_strides: int = 10
    hde_auto_tolerance_rad: float = 5.0 * DEG
    hde_auto_min_share: float = 0.5
    hde_auto_min_cross: float = 0.02
    heading_aid_segments: bool = True
    hde_leg_min_strides: int = 3
    revisits: str = "none"
    revisit_entry_gate: float = 0.01
    revisit_stair_gate_m: float = 3.0
    revisit_sigma_m: float = 0.3
    revisit_step_sigma_m: float = 0.05
    hde_threshold_rad: float = 10.0 * DEG
    sigma_hde_rad: float = 5.0 * DEG
    hde_min_stride_m: float = 0.3
    strapdown: str = "increments"
    level_height: bool = True
    level_max_dz_m: float = 0.075
    level_min_stride_m: float = 0.10
    sigma_level_m: float = 0.005

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
        if not isinstance(self.sloping_rails, bool):
            raise ValueError(f"FilterSettings.sloping_rails must be true or false, got {self.sloping_rails!r}")
        if self.heading_aid not in ("none", "dominant_directions", "auto"):
            raise ValueError(f"FilterSettings.heading_aid must be 'none', 'dominant_directions' or 'auto', got "
                             f"{self.heading_aid!r}")
        ref = self.heading_aid_reference_rad
        if ref is not None and not (isinstance(ref, (int, float)) and math.isfinite(ref)):
            raise ValueError(f"FilterSettings.heading_aid_reference_rad must be None or a finite angle, got {ref!r}")
        if not isinstance(self.heading_aid_segments, bool):
            raise ValueError(f"FilterSettings.heading_aid_segments must be true or false, got "
                             f"{self.heading_aid_segments!r}")
        for name in ("hde_auto_window", "hde_auto_min_strides", "hde_leg_min_strides"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 3):
                raise ValueError(f"FilterSettings.{name} must be an integer >= 3, got {v!r}")
        if self.revisits not in ("none", "entry", "stairs", "entry+stairs"):
            raise ValueError(f"FilterSettings.revisits must be 'none', 'entry', 'stairs' or 'entry+stairs', got "
                             f"{self.revisits!r}")
        for name in ("revisit_entry_gate", "revisit_stair_gate_m", "revisit_sigma_m",
                     "revisit_step_sigma_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"FilterSettings.{name} must be a finite number > 0, got {v!r}")
        for name in ("hde_auto_min_share", "hde_auto_min_cross"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"FilterSettings.{name} must be in [0, 1], got {getattr(self, name)!r}")
        if self.heading_aid == "dominant_directions" and self.mode == "riccati":  # "auto" decides off there
            raise ValueError("FilterSettings.heading_aid needs mode='time_varying' (the paper mode has no yaw gain)")
        if self.strapdown not in ("increments", "midpoint", "endpoint"):
            raise ValueError(f"FilterSettings.strapdown must be 'increments', 'midpoint' or 'endpoint', got "
                             f"{self.strapdown!r}")
        if not isinstance(self.level_height, bool):
            raise ValueError(f"FilterSettings.level_height must be true or false, got {self.level_height!r}")
        for f in fields(self):
            if f.name in ("zupt_lever_arm_m", "zaru_rate_factor", "acc_scale_noise", "gyro_scale_noise", "zupt_onset_delay_s",
                          "zupt_onset_max_fraction", "hde_auto_min_cross") or f.name.startswith("sat_"):
                v = getattr(self, f.name)
                if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                    raise ValueError(f"FilterSettings.{f.name} must be a finite number >= 0, got {v!r}")
                continue
            if f.name.startswith(("sigma_", "init_", "hde_")) or f.name in ("smoother_max_segment_s", "level_max_dz_m",
                                                                                          "level_min_stride_m"):
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
