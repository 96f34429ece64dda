"""Truth-free choice of the stance detection per recording, per-stride quality flags, and a level-stride
timing self-calibration of the vertical channel; the passes of ``bootnav.postproc.pipeline`` apply them (stage
"navigation"), each whole-record figure from its accumulator (``GaitPeriodAccumulator``,
``StrideQualityAccumulator``, the timing probes' footprints) or, for the fallback's candidates, from forward runs
over the blocks.

Why: the best stance detector setting varies between people, gaits and sensors (fast walks and runs have a
foot-flat of a few tens of milliseconds, or none), and a fixed default either misses the short stances (the
path between two ZUPTs is unaided drift) or declares stance on a moving foot. The filter runs at over a
million samples per second, so a few candidate masks can be tried per recording and judged by what the
data say about them.

Candidates (``passes.BlockPasses.select_fallback``): the configured detector (default: adaptive, α = 0.3), the adaptive rule
with α = 0.2 and 0.4, fixed-threshold SHOE [Skog2010], and "cycle minimum": the configured mask plus, in
every gait cycle it missed, the lowest-energy window of the SHOE statistic (``cycle_minimum_stance``), so
that every stride gets at least one zero-velocity update even when the foot never rests (running, fast
walks). The other candidates are scored only when the configured one fails (below): a recording the
default handles costs one extra forward filter run.

Criterion, computed from the data alone. For candidate c, run the filter (no smoother) and take at each
zero-velocity-update onset k (the first sample the filter aids, after the onset delay) the velocity the
unaided strapdown integration predicts there, v_k: it is the ZUPT innovation, z_k = 0 − v̂_k [Foxlin2005].
A good mask makes it small: a missed stance lets the velocity error grow over two strides, a stance
declared on a moving foot makes v̂_k the foot's true velocity::

    e_c  = sqrt( mean_k ‖v_k‖² )                                 (m/s; RMS ZUPT innovation at onsets)
    b_c  = fraction of strides flagged implausible (below)
    J_c  = e_c + v_pen · b_c,     v_pen = 1 m/s                   (a flagged stride costs like 1 m/s)

The configured detector is kept unless it FAILS: more than ``max_bad_fraction`` (10 %, the pipeline's own
``max_long_stride_fraction``) of its strides are implausible, or its stance samples turn at a median
‖ω − b̂‖ above ``fail_stance_rate_radps`` (1.5 rad/s, above the ≈ 1 rad/s of a running foot; the pipeline's
0.5 rad/s refusal is what turned away the fast walks of issue 11). Then the candidate with the smallest J_c
is taken. So a recording the default handles is processed exactly as before; J is only trusted for the
large differences of a real failure (a factor 2-10), not to rank candidates that all work.

A normalised innovation squared ε_k = z_kᵀ S_k⁻¹ z_k against its χ²(3) expectation [Groves2013, §17.3] would
make e_c comparable between recordings; it needs the innovation covariance S_k = P_vv + R_k, which
``run_filter`` does not expose yet, so the criterion compares raw innovations between the candidates of ONE
recording only.

Per-stride plausibility flags (``stride_quality``; bitmask, any set bit = implausible):

* ``FAST`` (1): stride length > ``max_stride_m`` or mean speed > ``max_speed_mps`` (a foot cannot);
* ``MISSED`` (2): the swing (end of one stance phase to the start of the next) lasts > ``missed_factor``
  gait cycles while the foot moves > 0.1 m: a stance was missed in between and the path there is unaided
  drift (a swing takes 0.6-0.9 of a cycle, from walking to running without foot-flat; a missed stance ≈ 2);
* ``VERTICAL`` (4): |Δz| > ``max_dz_m`` (a stair stride climbs at most two risers, ≈ 0.4 m);
* ``ROLLING`` (8): the foot turns at a median ‖ω − b̂‖ > ``max_stance_rate_radps`` over the stance phase
  that ends the stride (a zero-velocity update on a rolling foot: informative, not implausible: a running
  foot rolls at ≈ 1 rad/s through its short stance, pyshoe_vicon's running trials, and the filter's
  rolling-foot ZUPT noise accounts for it);
* ``TINY`` (16): horizontal length < ``min_stride_m`` (shuffling or standing, not a stride; informative).

Confidence of the chosen mask, in [0, 1]: (1 − b) · exp(−e / v_scale), v_scale = 0.5 m/s.

Gait cycle (``gait_period``): the lag of the highest autocorrelation peak of ‖ω‖ between 0.4 and 3 s (one
foot's stride period); no peak above 0.2 means no periodic gait (the confidence is then 0).

Vertical channel (``level_timing_offset``): the height error of a ZUPT-aided path behaves like a small
timing offset τ between the specific force and the attitude it is rotated with (sensor-specific filter delays;
about 0.1 m of vertical closure per ms over a 60-80 m loop on the developer data). The half-sample offset
of the strapdown step itself, Δt/2, which grows as the rate falls, is not left to τ: the default step
rotates f_b with the attitude at the middle of its interval (``FilterSettings.strapdown``), so τ is the
sensor's own offset, the same at every rate (docs/tuning-log.md, "Height at low rates"). The rotation of f_b by −ω τ, f_b' = exp(−[ω_b×] τ) f_b (first order
f_b − τ ω_b × f_b, the rotation-compensation term of [Savage1998]), shifts it; τ is chosen so that the
median height change of the level strides (|Δz| < 0.1 m, length > 0.3 m) is zero, assuming most walking is on
level floors: m(τ) is nearly linear, so two filter runs at ±δ give its zero crossing, clipped to ±τ_max.
A walk with fewer than ``timing_min_level_strides`` (200) level strides is not calibrated (τ = 0): there τ*
scatters more between recordings of one sensor than any sensor offset (``SelfTuneSettings``).
"""

from __future__ import annotations

from .settings import SelfTuneSettings
from .gait import gait_period, GaitPeriodAccumulator
from .quality import FAST, MISSED, VERTICAL, ROLLING, TINY, IMPLAUSIBLE, FLAG_NAMES, StrideQuality, stride_quality, stride_flags, StrideQualityAccumulator, split_strides, implausible_strides
from .scoring import onset_innovations, confidence
from .fallback import cycle_minimum_stance, cycle_minimum_candidate
from .timing import rotate_specific_force, level_stride_dz, footprint_level_dz, level_timing_offset, timing_from_probes

__all__ = ["FAST", "FLAG_NAMES", "GaitPeriodAccumulator", "IMPLAUSIBLE", "MISSED", "ROLLING", "SelfTuneSettings", "StrideQuality", "StrideQualityAccumulator", "TINY", "VERTICAL", "confidence", "cycle_minimum_candidate", "cycle_minimum_stance", "footprint_level_dz", "gait_period", "implausible_strides", "level_stride_dz", "level_timing_offset", "onset_innovations", "rotate_specific_force", "split_strides", "stride_flags", "stride_quality", "timing_from_probes"]
