"""``process``: from a recording (or any file ``bootnav import`` reads) to the walked 3-D path.

The stages are the paper's pipeline [Heidari2019] with the standard reconstructions it cites; each is
timed in ``summary["timings_s"]`` and each lives in its own module, read top to bottom:

1. **load** (``source``): the recording or imported file; a reference file (``reference``) is read first, so a
   bad one fails before any work.
2. **checks** (``source.crop``, ``checks``): crop to ``crop_s``, refuse samples that would give a garbage path
   (NaN, time going backwards, gaps the integration cannot bridge, too short) with the sample index and time;
   flag saturated bursts and short gaps as warnings.
3. **calibration** (``calibration``): optional accelerometer calibration file, gravity (WGS-84 normal gravity
   from latitude/height unless given), roll/pitch and gyro bias from the initial still period.
4. **navigation** (``navigate``): the stance (zero-velocity) mask of the configured detector
   (``detectors``, [Heidari2019, eq. 2]); when it is implausible (``checks.stance_findings``, per-stride
   flags of ``selftune``) a truth-free fallback chooses another, with a warning and a confidence figure; the
   per-recording timing calibration of the vertical channel; the ZUPT error-state Kalman filter + RTS
   smoother (``ins.run_filter``, [Heidari2019, eqs. 1, 3-7]). Only input that cannot be a walking foot is
   refused.
5. **strides** (``strides``, ``checks.stride_findings``): strides (moves shorter than
   ``selftune.min_stride_m`` are not strides), distance, closure, floors.
6. **reference** (``reference``), when a reference is given: its metrics [Heidari2019, Table 1].

The summary layout is ``summary.build_summary``. ``process`` writes nothing; ``outputs.write_outputs`` and
``plots`` do.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bootnav.errors import InputError
from bootnav.logger.recording import Recording

from .checks import (check_path_finite, check_samples, clipping_bits, refuse_fatal, saturation_intervals,
                     saturation_warnings, stride_findings)
from .navigate import navigate
from .selftune import TINY
from .settings import ProcessSettings
from .source import crop, load_source
from .strides import path_summary, segment_strides
from .summary import build_summary

Progress = Callable[[str, float], None]


@dataclass
class ProcessResult:
    """Everything one run produced (SI, nav frame ENU z up, origin at the first processed sample)."""

    t_s: np.ndarray  # (N,) s, recording time (crop keeps the recording's clock)
    pos_n: np.ndarray  # (N, 3) m
    vel_n: np.ndarray  # (N, 3) m/s
    q_nb: np.ndarray  # (N, 4) wxyz body -> nav
    stance: np.ndarray  # (N,) bool
    steps: dict[str, np.ndarray]  # one row per stride, keys strides.STEP_COLUMNS
    summary: dict
    settings: ProcessSettings
    warnings: list[str]
    saturated: np.ndarray  # (N,) bool, any axis at full scale
    acc_b: np.ndarray  # (N, 3) specific force used (calibrated), m/s^2
    gyro_b: np.ndarray  # (N, 3) rad/s (raw; the filter's bias estimate is in ``nav``)
    gravity_mps2: float = 9.80665
    stance_result: Any = None  # detectors.StanceResult
    nav: Any = None  # ins.NavSolution
    init: Any = None  # calibration.InitialState
    recording: Recording | None = None  # the full (uncropped) input
    source: Path | None = None
    source_is_hdf5: bool = False
    index: slice = field(default_factory=lambda: slice(None))  # processed samples within the recording
    saturation_intervals: list[dict] = field(default_factory=list)
    metrics: dict | None = None  # reference metrics [Heidari2019, Table 1] when a reference was given
    reference: Any = None  # reference.Reference
    navigation: Any = None  # navigate.Navigation: stance choice, timing offset, confidence, stride flags


def _call_progress(progress: Progress | None, stage: str, fraction: float) -> None:
    if progress is not None:
        progress(stage, fraction)


def process(source: str | Path | Recording, settings: ProcessSettings | None = None,
            progress: Progress | None = None) -> ProcessResult:
    """Run every stage (module docstring) on one input and return the result; writes nothing.

    Parameters
    ----------
    source
        A bootnav HDF5 recording, any file ``bootnav import`` reads (e.g. a canonical ``imu.csv.gz``), or an
        in-memory ``Recording``.
    settings
        Every tunable (defaults when None); validated before any work.
    progress
        ``progress(stage, fraction)`` is called at stage boundaries and, for the filter, while it runs.

    Returns
    -------
    ProcessResult
        The path, stance mask, strides, summary (``summary.build_summary``) and every intermediate a writer
        or a plot needs.

    Raises
    ------
    InputError
        Bad settings, an unreadable input or reference, input that cannot be integrated
        (``checks.check_samples``), a recording that cannot be a walking foot (``navigate``), or a diverged
        filter.
    """
    from .calibration import apply_accel_calibration, initial_alignment
    from .reference import compute_metrics, load_reference, truth_reference

    settings = settings or ProcessSettings()
    settings.validate()
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(stage: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[stage] = now - clock
        clock = now
        _call_progress(progress, stage, 1.0)

    ref = None
    if settings.reference and settings.reference != "truth":  # a bad reference fails before any work
        ref = load_reference(settings.reference)
    _call_progress(progress, "load", 0.0)
    src = load_source(source)
    name = src.name
    if settings.reference == "truth":
        ref = truth_reference(src.recording, src.path if src.is_hdf5 else None)
    lap("load")

    samples = crop(src.recording, settings.crop_s, name)
    t_s, gyro_b, offset = samples.t_s, samples.gyro_b, samples.index.start
    warnings = check_samples(name, t_s, samples.acc_b, gyro_b, offset, settings.checks)
    sat_bits = samples.saturated
    if settings.detector.detect_clipping:
        sat_bits = sat_bits | clipping_bits(samples.acc_b, gyro_b)
    sat_iv = saturation_intervals(t_s, sat_bits, offset)
    warnings += saturation_warnings(sat_iv)
    lap("checks")

    cal = settings.calibration
    acc_b = samples.acc_b
    if cal.accel_calibration_file:
        acc_b = apply_accel_calibration(acc_b, cal.accel_calibration_file)
    gravity = cal.gravity()
    init = initial_alignment(t_s, acc_b, gyro_b, cal, gravity)
    warnings += list(init.warnings)
    lap("calibration")

    filter_progress = (lambda f: _call_progress(progress, "navigation", min(float(f), 0.99))) if progress else None
    navi = navigate(name, t_s, acc_b, gyro_b, init, gravity, settings, sat_bits, filter_progress)
    nav, stance = navi.nav, navi.stance
    pos_n = np.asarray(nav.pos_n)
    check_path_finite(name, t_s, pos_n, offset)
    warnings += navi.warnings
    warnings += [str(w) for w in (getattr(nav, "info", None) or {}).get("warnings", [])]
    lap("navigation")

    min_stride = settings.selftune.min_stride_m
    steps = segment_strides(t_s, pos_n, stance, min_stride, navi.quality.flags & np.uint8(0xFF ^ TINY))  # a kept stride is not tiny
    if len(steps["t_s"]) == 0 and not np.isfinite(navi.period_s):
        raise InputError(f"{name}: no motion: not one stride of >= {min_stride:g} m and no periodic gait in "
                         f"{t_s[-1] - t_s[0]:.1f} s; nothing to navigate (is the sensor on a walking foot?)")
    findings = stride_findings(steps, settings.checks, navi.choice)
    warnings += ([f.message for f in findings] if settings.selftune.fallback else refuse_fatal(name, findings))
    path_stats = path_summary(t_s, pos_n, stance, settings.floor_settings(), min_stride)
    lap("strides")
    metrics = None
    if ref is not None:
        metrics = compute_metrics(ref, t_s, pos_n, stance, src.recording.meta.get("mount"), min_stride)
        lap("reference")

    timings["total_process"] = float(sum(timings.values()))
    result = ProcessResult(
        t_s=t_s, pos_n=pos_n, vel_n=np.asarray(nav.vel_n), q_nb=np.asarray(nav.q_nb), stance=stance,
        steps=steps, summary={}, settings=settings, warnings=warnings, saturated=sat_bits.astype(bool),
        acc_b=acc_b, gyro_b=gyro_b, gravity_mps2=float(gravity), stance_result=navi.configured, nav=nav, init=init,
        recording=src.recording, source=src.path, source_is_hdf5=src.is_hdf5, index=samples.index,
        saturation_intervals=sat_iv, metrics=metrics, reference=ref, navigation=navi,
    )
    result.summary = build_summary(result, path_stats, timings)
    return result
