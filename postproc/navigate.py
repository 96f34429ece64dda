"""Stages 4-5 of ``process``: stance detection with a fallback, the vertical timing calibration, the filter.

Policy: a plausible foot recording always gets a path. The configured detector runs first; if its mask is
implausible (a fatal ``checks.stance_findings`` finding) or more than ``SelfTuneSettings.max_bad_fraction``
of the strides it gives are implausible (``selftune.stride_quality``), the truth-free choice among other
candidates (``selftune.select_stance``) takes over and the summary says so, with a confidence figure. Only
a recording that cannot be a walking foot is refused: the configured detector fails AND there is no
periodic gait (no motion, or motion without a stride rhythm), or no candidate finds a zero-velocity phase.

Every run of the filter gets the specific force rotated by the per-recording timing offset τ
(``selftune.level_timing_offset``), which removes most of the vertical drift of level walks
(``docs/tuning-log.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from bootnav.errors import InputError

from . import selftune
from .checks import stance_findings
from .settings import ProcessSettings


@dataclass
class Navigation:
    """What the navigation stages produced (SI units; masks and arrays have one row per sample)."""

    configured: Any  # detectors.StanceResult of the configured detector
    stance: np.ndarray  # (N,) bool, the mask the filter used
    nav: Any  # ins.NavSolution
    acc_used_b: np.ndarray  # (N, 3) m/s², the specific force given to the filter (rotated by τ)
    choice: str  # "configured (<method>)" or the fallback candidate's name
    failed: str | None  # why the configured detector was not kept (None: it was)
    timing: dict  # level_timing_offset's dict (tau_s, n_level, applied, ...); {} when off
    confidence: float  # in [0, 1], selftune.confidence
    period_s: float  # gait (stride) period, s; NaN without a periodic gait
    quality: Any  # selftune.StrideQuality of the raw strides (stance phase to stance phase)
    candidates: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def navigate(name: str, t_s: np.ndarray, acc_b: np.ndarray, gyro_b: np.ndarray, init, gravity: float,
             settings: ProcessSettings, saturated: np.ndarray,
             filter_progress: Callable[[float], None] | None = None) -> Navigation:
    """Choose the stance mask, calibrate the timing offset and run the filter (module docstring).

    Parameters
    ----------
    name
        How messages name the input.
    t_s, acc_b, gyro_b
        Calibrated samples: s, m/s² (specific force, body frame), rad/s.
    init
        ``calibration.InitialState`` (attitude, biases).
    gravity
        m/s².
    settings
        The run's settings (``detector``, ``filter``, ``checks``, ``selftune``).
    saturated
        (N,) saturation bitmask (``recording.SATURATION_BITS``) or bool mask.
    filter_progress
        Called with the fraction done of the final filter run.

    Returns
    -------
    Navigation

    Raises
    ------
    InputError
        No candidate finds a zero-velocity phase (no motion, no gait: not a walking foot), or the configured
        detector fails while ``selftune.fallback`` is off.
    """
    from .calibration import stance_reference
    from .detectors import detect_stance

    st = settings.selftune
    bias_det, gravity_det = stance_reference(init, gravity)  # the rest as this sensor reads it
    configured = detect_stance(t_s, acc_b, gyro_b - bias_det, settings.detector, gravity_det, saturated=saturated)
    stance = np.asarray(configured.stance, dtype=bool)
    warnings = [str(w) for w in (configured.info or {}).get("warnings", [])]
    findings = stance_findings(t_s, stance, settings.checks, configured.method, gyro_b)
    warnings += [f.message for f in findings if not f.fatal]
    fatal = [f.message for f in findings if f.fatal]
    failed = fatal[0] if fatal else None
    if failed and not st.fallback:
        raise InputError(f"{name}: {failed}")
    period = selftune.gait_period(t_s, gyro_b)
    choice, candidates = f"configured ({configured.method})", []

    run = None
    if failed is None:
        run = _run(t_s, acc_b, gyro_b, stance, init, gravity, settings, saturated, period, filter_progress)
        if run[3].bad_fraction > st.max_bad_fraction:
            failed = (f"{run[3].bad_fraction:.0%} of its {len(run[3].flags)} strides are implausible (longer or "
                      "faster than a foot moves, a missed stance, or a climb steeper than stairs)")
            if not st.fallback:
                warnings.append(f"stance detector '{configured.method}': {failed}")
    if failed is not None and st.fallback and not np.isfinite(period):
        raise InputError(f"{name}: not a walking foot: {failed}; and no periodic gait (no stride rhythm of 0.4-3 s "
                         "in the angular rate). Zero-velocity navigation needs a sensor on a walking foot; for a "
                         "waist, pocket or hand sensor use `bootnav pdr`")
    if failed is not None and st.fallback:
        sel = selftune.select_stance(t_s, acc_b, gyro_b, init, gravity, settings.detector, settings.filter,
                                     saturated=saturated, settings=st, configured=configured, failed=failed,
                                     period_s=period)
        candidates = sel.candidates
        if not any(np.isfinite(c["J"]) for c in candidates):
            gait = ("no periodic gait" if not np.isfinite(period)
                    else f"a gait period of {period:.2f} s but no moment the foot rests")
            raise InputError(f"{name}: not a walking foot: {failed}; no other stance detection finds a "
                             f"zero-velocity phase either ({gait}). Zero-velocity navigation needs a sensor on "
                             "the foot; for a waist, pocket or hand sensor use `bootnav pdr`")
        stance, choice = np.asarray(sel.stance, dtype=bool), sel.choice
        warnings += sel.warnings
        run = _run(t_s, acc_b, gyro_b, stance, init, gravity, settings, saturated, period, filter_progress)
    timing, acc_used, nav, quality = run
    e = timing.get("innovation_rms_mps")
    if e is None:  # the timing calibration is off: one forward run scores the path
        e = selftune.innovation_rms(t_s, acc_used, gyro_b, stance, init, gravity, settings.filter, saturated)
    conf = selftune.confidence(e, quality.bad_fraction, period, st)
    split = selftune.split_strides(quality, period, st)
    if split:
        warnings.append(split)
    if not np.isfinite(period):
        warnings.append("no periodic gait found: the confidence of this path is 0")
    return Navigation(configured=configured, stance=stance, nav=nav, acc_used_b=acc_used, choice=choice,
                      failed=failed, timing=timing, confidence=conf, period_s=period, quality=quality,
                      candidates=candidates, warnings=warnings)


def _run(t_s, acc_b, gyro_b, stance, init, gravity, settings: ProcessSettings, saturated, period,
         filter_progress):
    """(timing, specific force used, NavSolution, StrideQuality) of one stance mask."""
    from .ins import run_filter

    st = settings.selftune
    timing: dict = {}
    acc_used = acc_b
    if st.timing_calibration:
        timing = selftune.level_timing_offset(t_s, acc_b, gyro_b, stance, init, gravity, settings.filter,
                                              saturated=saturated, delta_s=st.timing_probe_s,
                                              max_abs_s=st.timing_max_abs_s,
                                              min_level_strides=st.timing_min_level_strides,
                                              max_level_strides=st.timing_max_level_strides)
        if timing["tau_s"] != 0.0:
            acc_used = selftune.rotate_specific_force(acc_b, gyro_b, timing["tau_s"])
    nav = run_filter(t_s, acc_used, gyro_b, stance, init, gravity, settings.filter, progress=filter_progress,
                     saturated=saturated)
    if settings.filter.heading_aid == "auto":  # decided on the unaided path (building.directions)
        from .building.directions import auto_heading

        nav = auto_heading(nav, t_s, stance, settings.filter, lambda fs, gate: run_filter(
            t_s, acc_used, gyro_b, stance, init, gravity, fs, saturated=saturated, heading_gate=gate))
    if settings.filter.revisits != "none":  # pose graph over strides (building.revisits)
        from .building.revisits import apply_revisits

        nav = apply_revisits(nav, t_s, stance, settings.filter)
    bias = nav.gyro_bias_b if getattr(nav, "gyro_bias_b", None) is not None else np.asarray(init.gyro_bias_b)
    quality = selftune.stride_quality(t_s, np.asarray(nav.pos_n), stance, gyro_b, bias, period, st)
    return timing, acc_used, nav, quality
