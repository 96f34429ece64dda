"""The tunables of the self-tuning (``SelfTuneSettings``); what each does is in the module docstrings of
``bootnav.postproc.selftune`` and its modules."""

from __future__ import annotations

from dataclasses import dataclass

from bootnav.postproc.detectors.shoe import ShoeDetector


@dataclass
class SelfTuneSettings:
    """Tunables of the self-tuning (physical bounds, not fitted to data, except where said).

    alphas: extra adaptive α candidates; shoe_threshold: fixed SHOE γ candidate (None = no SHOE candidate).
    max_bad_fraction, fail_stance_rate_radps: when the configured detector counts as failed (module docstring).
    v_pen_mps, v_scale_mps: criterion and confidence scales (module docstring).
    max_stride_m, max_speed_mps, missed_factor, max_dz_m, max_stance_rate_radps, min_stride_m: stride flags.
    split_factor, max_split_fraction: a stride shorter in time than ``split_factor`` gait periods (footprint to
        footprint) has a stance detected inside a swing; more than ``max_split_fraction`` of such strides is a
        warning (``split_strides``).
    cycle_window_fraction: half-width of a cycle-minimum stance window, as a fraction of the gait period.
    cycle_depth_decades: a cycle-minimum window covers the samples within this many decades of the minimum.
    fallback: when the configured detector fails (a fatal stance finding of ``checks.stance_findings``, or
        more than ``max_bad_fraction`` implausible strides), choose among the candidates instead of
        refusing the recording (``bootnav process`` refuses only what cannot be a walking foot).
    timing_calibration: estimate the specific-force/attitude timing offset τ from the level strides
        (``level_timing_offset``) and rotate f_b by it before the final run.
    timing_probe_s, timing_max_abs_s: the probe offsets ±δ and the bound of τ, s. The bound was chosen by
        leave-one-dataset-out validation among ±1.5 / 3 / 5 ms (docs/tuning-log.md).
    timing_min_level_strides: fewer level strides than this: τ = 0 (no calibration). 200: τ is a property of the
        sensor, but on a short walk the criterion measures the walk more than the sensor: the τ* of ONE sensor
        scatters between its recordings of 15-30 level strides with a standard deviation of 6 / 10 / 14 ms
        (voisard_ipol 44 files / pyshoe_vicon 16 trials / iez_mpu6050 14 files, median τ* −4.8 / +2.7 /
        −16 ms), 2-5 times the bound ±τ_max; shrinking as 1/√K, that scatter falls within the bound only past
        K ≈ 65-380 level strides. So the short walks (every public recording: at most 73 level strides) keep
        the sensor's samples as they are, and a mission calibrates. Leave-one-dataset-out (10 / 50 / 100 /
        200): a bound of 50 or more is chosen in every fold, held-out / default 0.978; voisard 4.63 → 4.04 %
        beyond its spread, pyshoe_vicon 0.0736 → 0.0686 m (docs/tuning-log.md, "Timing calibration on short
        walks").
    timing_max_level_strides: τ is estimated from the first this many level strides (None: all), so the probe
        filters of a long recording run over its first part only (``level_timing_offset``). τ is a property
        of the sensor, constant over a recording, and 500 level strides make the standard error of τ*,
        1.2533 σ_dz / (√K |dm/dτ|) (of a median), 0.1-0.3 ms with the public foot walks' spread of level-stride
        height changes (σ_dz 6-10 mm) and slopes (dm/dτ 1.9-3.2 mm per ms): 5-15 % of the probe offset δ
        (docs/tuning-log.md, "Long recordings"). No public recording has as many strides: their results do
        not depend on it.
    """

    alphas: tuple[float, ...] = (0.2, 0.4)
    shoe_threshold: float | None = ShoeDetector.DEFAULT_THRESHOLD
    max_bad_fraction: float = 0.10
    fail_stance_rate_radps: float = 1.5
    v_pen_mps: float = 1.0
    v_scale_mps: float = 0.5
    max_stride_m: float = 6.0
    max_speed_mps: float = 8.0
    missed_factor: float = 1.4
    max_dz_m: float = 0.5
    max_stance_rate_radps: float = 1.0
    min_stride_m: float = 0.05
    split_factor: float = 0.5
    max_split_fraction: float = 0.5
    cycle_window_fraction: float = 0.06
    cycle_depth_decades: float = 0.5
    fallback: bool = True
    timing_calibration: bool = True
    timing_probe_s: float = 0.002
    timing_max_abs_s: float = 0.003
    timing_min_level_strides: int = 200
    timing_max_level_strides: int | None = 500
