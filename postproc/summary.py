"""The layout of ``summary.json``: what one ``process`` run did and found, in plain JSON types.

Sections: ``software``, ``conventions`` (the frames and sign conventions of every output), ``input``,
``alignment`` (gravity, initial roll/pitch, gyro bias, still period), ``stance``, ``filter``, ``path``
(``strides.path_summary``), ``metrics`` (reference metrics or null), ``saturation_intervals``, ``warnings``,
``timings_s``, ``settings`` (everything needed to reproduce the run), and the headline numbers repeated at the
top level so that ``jq .distance_m summary.json`` just works. ``outputs.write_outputs`` adds ``files``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bootnav import CONVENTIONS, __version__
from bootnav.core.jsonio import to_jsonable

#: path figures repeated at the top level of the summary
HEADLINE_KEYS = ("distance_m", "closure_3d_m", "closure_pct", "floors_climbed", "floors_descended", "strides",
                 "confidence")


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
        "software": {"name": "bootnav", "version": __version__},
        "conventions": {**CONVENTIONS,
                        "time": "t_s = recording time (a crop keeps the recording's clock)",
                        "origin": ("nav-frame origin = sensor position at the first processed sample; initial yaw = 0, "
                                   "so x is the sensor's initial heading, not true east (no magnetometer)"),
                        "distance": "sum of horizontal footprint-to-footprint distances (stance phases)"},
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
        "alignment": {
            "gravity_mps2": float(result.gravity_mps2),
            "roll_deg": float(np.degrees(getattr(init, "roll_rad", 0.0))),
            "pitch_deg": float(np.degrees(getattr(init, "pitch_rad", 0.0))),
            "gyro_bias_radps": np.asarray(init.gyro_bias_b).tolist(),
            "still_period_s": ([float(t_s[init.still.start]), float(t_s[init.still.stop - 1])]
                               if init.still is not None else None),
        },
        "stance": {
            "method": stance_res.method,
            "threshold": to_jsonable(stance_res.threshold),
            "phases": int(path_stats["stance_phases"]),
            "fraction": float(result.stance.mean()),
            "info": to_jsonable(stance_res.info),
        },
        "navigation": _navigation(result.navigation),
        "filter": to_jsonable(getattr(result.nav, "info", {})),
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
    if summary["navigation"] is not None:
        summary["confidence"] = summary["navigation"]["confidence"]
    return summary



def _navigation(navi: Any) -> dict | None:
    """The stance choice, its confidence, the stride flags and the timing offset (``navigate.Navigation``)."""
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
        "timing_offset": to_jsonable({k: v for k, v in navi.timing.items()}),
        "candidates": to_jsonable(navi.candidates),
    }
