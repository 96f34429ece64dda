"""The layout of ``summary.json``: what one ``process`` run did and found, in plain JSON types.

The layout is documented as a JSON Schema in ``docs/summary.schema.json`` (every kind of run: the one
``passes.BlockPasses`` builds for ``process`` and ``bootnav process``, ``build_summary``'s of a
``ProcessResult`` (a fused foot of ``twoboots``), ``twoboots``, ``pdr``). Sections: ``software``, ``conventions`` (the frames and sign conventions of every output), ``input``,
``calibration`` (which sensor calibration ran: file, device id, date, residuals; or "none" and why),
``alignment`` (gravity, initial roll/pitch, gyro bias, still period), ``stance``, ``filter``, ``path``
(``strides.path_summary``), ``metrics`` (reference metrics or null), ``saturation_intervals``, ``warnings``,
``timings_s``, ``settings`` (everything needed to reproduce the run), and the headline numbers repeated at the
top level so that ``jq .distance_m summary.json`` just works. ``outputs.write_outputs`` adds ``files``.

``closure_*`` keys are the last footprint minus the first; ``closed_loop`` (``is_closed_loop``) says whether
that is a closure (the walk was declared or referenced as a loop) or just "end − start", and every
human-readable output labels it accordingly. ``mount`` (``mount_check``) says whether the signals look like
a foot at all; when not, a warning says so.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bootnav.core.conventions import CONVENTIONS, SOFTWARE
from bootnav.core.jsonio import to_jsonable

#: path figures repeated at the top level of the summary
HEADLINE_KEYS = ("distance_m", "closure_3d_m", "closure_pct", "floors_climbed", "floors_descended", "final_floor",
                 "strides", "confidence")


#: ``CONVENTIONS`` and what a processed path adds: its clock, origin and distance (every ``process`` summary)
PATH_CONVENTIONS = {**CONVENTIONS,
                    "time": "t_s = recording time (a crop keeps the recording's clock)",
                    "origin": ("nav-frame origin = sensor position at the first processed sample; initial yaw = 0, "
                               "so x is the sensor's initial heading, not true east (no magnetometer)"),
                    "distance": "sum of horizontal footprint-to-footprint distances (stance phases)"}


def build_summary(result: Any, path_stats: dict, timings: dict[str, float]) -> dict:
    """The summary of one run.

    Parameters
    ----------
    result
        The run's ``pipeline.ProcessResult`` (its ``summary`` is not read).
    path_stats
        ``strides.path_summary`` of the run.
    timings
        Seconds per stage; kept by reference, so stages timed later (writing, plots) appear in it.

    Returns
    -------
    dict
        The summary (``result.warnings`` is kept by reference too). NumPy values in the detector's and the
        filter's info are converted to JSON types, arrays longer than 64 values summarised by shape.
    """
    t_s, init, stance_res = result.t_s, result.init, result.stance_result
    dt = np.diff(t_s)
    summary = {
        "software": dict(SOFTWARE),
        "conventions": dict(PATH_CONVENTIONS),
        "input": {
            "source": str(result.source) if result.source else "recording",
            "format": "hdf5" if result.source_is_hdf5 else "imported",
            "samples_total": int(result.recording.n),
            "samples_processed": int(len(t_s)),
            "t_start_s": float(t_s[0]),
            "t_end_s": float(t_s[-1]),
            "duration_s": float(t_s[-1] - t_s[0]),
            "rate_hz": float(1.0 / np.median(dt[dt > 0])),
            "crop_s": list(result.settings.crop_s) if result.settings.crop_s else None,
            "device": result.recording.meta.get("device"),
        },
        "calibration": to_jsonable(getattr(result.sensor_calibration, "provenance", None)
                                   or {"status": "none", "reason": "not resolved"}),
        "alignment": alignment_summary(init, result.gravity_mps2, t_s),
        "stance": {
            "method": stance_res.method,
            "threshold": to_jsonable(stance_res.threshold),
            "phases": int(path_stats["stance_phases"]),
            "fraction": float(result.stance.mean()),
            "info": to_jsonable(stance_res.info),
        },
        "navigation": _navigation(result.navigation),
        # the engine's info but its settings (the top-level ``settings`` holds them)
        "filter": to_jsonable({k: v for k, v in (getattr(result.nav, "info", None) or {}).items() if k != "settings"}),
        "path": path_stats,
        "metrics": to_jsonable(result.metrics),
        "saturation_intervals": result.saturation_intervals,
        "warnings": result.warnings,
        "timings_s": timings,
        "settings": result.settings.to_dict(),
    }
    for key in HEADLINE_KEYS:
        if key in path_stats:
            summary[key] = path_stats[key]
    summary["uncertainty"] = final_uncertainty(getattr(result, "steps", None) or {})
    if summary["navigation"] is not None:
        summary["confidence"] = summary["navigation"]["confidence"]
    summary["closed_loop"] = is_closed_loop(result.reference)
    period = float(getattr(result.navigation, "period_s", float("nan")))
    summary["mount"] = mount_check(t_s, result.gyro_b, period, float(path_stats.get("distance_m", 0.0)))
    if not summary["mount"]["looks_like_foot"]:
        result.warnings.append(summary["mount"]["message"])
    return summary


def alignment_summary(init: Any, gravity_mps2: float, t_s: np.ndarray) -> dict:
    """The initial alignment (``calibration.InitialState``): gravity, roll, pitch, gyro bias, the still period
    (times from ``t_s``, the samples the alignment read)."""
    return {
        "gravity_mps2": float(gravity_mps2),
        "roll_deg": float(np.degrees(getattr(init, "roll_rad", 0.0))),
        "pitch_deg": float(np.degrees(getattr(init, "pitch_rad", 0.0))),
        "gyro_bias_radps": np.asarray(init.gyro_bias_b).tolist(),
        "still_period_s": ([float(t_s[init.still.start]), float(t_s[init.still.stop - 1])]
                           if init.still is not None else None),
    }


def final_uncertainty(steps: dict) -> dict | None:
    """The last stride's horizontal 1-σ ellipse (``strides.ellipse``) and floor, or None without strides."""
    if "ellipse_major_m" not in steps or not len(steps["ellipse_major_m"]):
        return None
    return {"final_ellipse_major_m": float(steps["ellipse_major_m"][-1]),
            "final_ellipse_minor_m": float(steps["ellipse_minor_m"][-1]),
            "final_ellipse_orientation_rad": float(steps["ellipse_orientation_rad"][-1]),
            "max_ellipse_major_m": float(np.max(steps["ellipse_major_m"])),
            "convention": ("horizontal 1-sigma ellipse of the footprint (filter covariance at the end of its stance "
                           "phase): semi-axes in m, major-axis orientation in rad counter-clockwise from east (ENU), "
                           "in (-pi/2, pi/2]; 2-sigma is twice as large")}


def endpoint_label(summary: dict) -> str:
    """How the outputs name ``closure_3d_m``: "closure" for a closed loop, "end − start" otherwise."""
    return "closure" if summary.get("closed_loop") else "end − start"


#: a closed-loop reference polyline ends within this fraction of its length (or CLOSED_LOOP_MIN_M) of its start
CLOSED_LOOP_FRACTION = 0.02
CLOSED_LOOP_MIN_M = 0.5


def is_closed_loop(reference: Any) -> bool:
    """Whether the walk is known to end where it started: a ``closed_loop`` reference (``--closed-loop``), or a
    reference path whose end is within 2 % of its length (at least 0.5 m) of its start.

    Parameters
    ----------
    reference : reference_path.Reference or None

    Returns
    -------
    bool
        False without a reference: nothing says the walk was a loop, so end − start is not a closure.
    """
    if reference is None:
        return False
    if reference.kind == "closed_loop":
        return True
    pts = np.asarray(reference.points_n, float)
    if len(pts) < 3 or not reference.length_m:
        return False
    gap = float(np.linalg.norm(pts[-1] - pts[0]))
    return gap <= max(CLOSED_LOOP_FRACTION * reference.length_m, CLOSED_LOOP_MIN_M)


#: thresholds of ``mount_check`` (physics of walking, see its docstring)
STEP_RHYTHM_MAX_S = 0.75
FOOT_SWING_MIN_RADPS = 4.0
MIN_ADVANCE_PER_PERIOD_M = 0.3
NO_SWING_MAX_RADPS = 2.5


def mount_check(t_s: np.ndarray, gyro_b: np.ndarray, period_s: float, distance_m: float) -> dict:
    """Does the recording look like a walking foot, or like a sensor on the waist/trunk or in the hand?

    A foot alternates rest and a swing at 5-10 rad/s once per stride (0.9-1.4 s when walking); a sensor on
    the trunk turns by less than ~3 rad/s and its rhythm is the step (0.45-0.65 s), half a stride. A
    ZUPT filter fed such signals finds "stance" in the sway and gives strides of centimetres. The
    recording is flagged when the path advances less than 0.3 m per rhythm period (or there is no
    rhythm, ``selftune.gait_period``) and either the rhythm is a step rhythm (< 0.75 s) with a 99th
    percentile of ‖ω‖ below 4 rad/s, or ‖ω‖ stays below 2.5 rad/s (99th percentile) at any rhythm. On the
    developer data this flags 20 of the 22 Voisard and all 9 mobgap lower-back recordings, and none of
    the 87 foot recordings nor the simulator's shuffle and crawl (their ‖ω‖ 99th percentile is ≥ 3.0 rad/s,
    their rhythm ≥ 1.1 s).

    Parameters
    ----------
    t_s : (N,) array
        Sample times, s.
    gyro_b : (N, 3) array
        Angular rate, rad/s.
    period_s : float
        ``selftune.gait_period`` of the recording (NaN: no rhythm; then nothing is flagged).
    distance_m : float
        Walked distance of the path.

    Returns
    -------
    dict
        ``looks_like_foot``, ``gait_period_s``, ``gyro_p99_radps``, ``advance_per_period_m`` and, when
        flagged, ``message``.
    """
    p99 = float(np.percentile(np.linalg.norm(np.asarray(gyro_b, float), axis=1), 99))
    return mount_check_of(p99, float(t_s[-1] - t_s[0]), period_s, distance_m)


def mount_check_of(p99: float, duration: float, period_s: float, distance_m: float) -> dict:
    """``mount_check`` from its figures: the 99th percentile of ‖ω‖ (rad/s) and the record's span (s); the one
    definition of the check (a recording read in blocks gives the percentile from passes over them)."""
    periodic = bool(np.isfinite(period_s)) and duration > 0
    advance = distance_m / (duration / period_s) if periodic else float("nan")
    slow = not periodic or advance < MIN_ADVANCE_PER_PERIOD_M
    step_rhythm = periodic and period_s < STEP_RHYTHM_MAX_S and p99 < FOOT_SWING_MIN_RADPS
    flagged = slow and (step_rhythm or p99 < NO_SWING_MAX_RADPS)
    out = {"looks_like_foot": not flagged, "gait_period_s": to_jsonable(float(period_s)), "gyro_p99_radps": p99,
           "advance_per_period_m": to_jsonable(advance)}
    if flagged:
        rhythm = (f"a rhythm every {period_s:.2f} s and {advance:.2f} m of path per period" if periodic
                  else "no gait rhythm")
        out["message"] = (f"this does not look like a sensor on a foot: rotation rates up to {p99:.1f} rad/s (a "
                          f"walking foot swings at 5-10), {rhythm}; a waist, trunk or hand sensor? Its path is not "
                          "meaningful: use `bootnav pdr` (step-and-heading) for such sensors")
    return out



def _navigation(navi: Any) -> dict | None:
    """The stance choice, its confidence, the stride flags and the timing offset (``pipeline.Navigation``)."""
    if navi is None:
        return None
    from .selftune import FLAG_NAMES

    flags = np.asarray(navi.quality.flags)
    return {
        "stance_choice": navi.choice,
        "fallback_used": navi.failed is not None and not navi.choice.startswith("configured"),
        "configured_failed": navi.failed,
        "confidence": float(navi.confidence),
        "gait_period_s": to_jsonable(float(navi.period_s)),
        "implausible_stride_fraction": to_jsonable(float(navi.quality.bad_fraction)),
        "stride_flags": {name: int(np.count_nonzero(flags & bit)) for bit, name in FLAG_NAMES.items()},
        "stride_flag_bits": {name: bit for bit, name in FLAG_NAMES.items()},
        "timing_offset": to_jsonable(navi.timing),
        "candidates": to_jsonable(navi.candidates),
    }
