"""``process``: from a recording (or any file ``bootnav import`` reads) to the walked 3-D path.

Stages (seed-004 §3, the paper's pipeline with the standard reconstructions it cites), each timed in
``summary["timings_s"]``:

1. **load**: HDF5 recording (``bootnav.logger.recording.load``) or an importable file (``bootnav.logger.importers``),
   e.g. the canonical ``imu.csv.gz``, which needs no options.
2. **checks**: crop to ``crop_s`` (paper: 103-176 s), then refuse input that would give a garbage path
   (NaN, time going backwards, gaps the integration cannot bridge, too short) with the sample index and
   time; flag saturated bursts and short gaps as warnings (kept in the summary).
3. **calibration**: optional accelerometer calibration file, gravity (WGS-84 normal gravity from
   latitude/height unless given), roll/pitch and gyro bias from the initial still period
   (``bootnav.postproc.calibration``).
4. **detection**: stance (zero-velocity) detector (``bootnav.postproc.detectors``, eq. 2); too few stance phases
   or an implausible stance fraction is an error, never a silent path.
5. **filter**: ZUPT error-state Kalman filter + RTS smoother (``bootnav.postproc.ins.run_filter``, eqs. 1, 3-7).
6. **strides**: strides, distance, closure, floors (``bootnav.postproc.strides``); reference metrics when a
   reference file is given (``bootnav.postproc.reference``).

``process`` writes nothing; ``bootnav.postproc.outputs.write_outputs`` and ``bootnav.postproc.plots`` do.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bootnav import CONVENTIONS, __version__
from bootnav.errors import InputError
from bootnav.logger.recording import EVENT_DTYPE, SATURATION_BITS, Recording, load

from .settings import InputChecks, OutputSettings, ProcessSettings  # noqa: F401  (re-exported API)
from .strides import path_summary, segment_strides, stance_phases

Progress = Callable[[str, float], None]
AXIS_NAMES = {v: k for k, v in SATURATION_BITS.items()}  # bit -> "ax", ...


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
    metrics: dict | None = None  # reference metrics (Table 1) when a reference was given
    reference: Any = None  # reference.Reference


# ----------------------------------------------------------------------------------------- loading
def is_hdf5(path: Path) -> bool:
    import h5py

    try:
        return bool(h5py.is_hdf5(path))
    except OSError:
        return False


def load_source(source: str | Path | Recording) -> tuple[Recording, Path | None, bool]:
    """(recording, path, is_hdf5) for a Recording, an HDF5 recording or any importable file."""
    if isinstance(source, Recording):
        return source, Path(source.path) if source.path else None, bool(source.path) and is_hdf5(Path(source.path))
    path = Path(source)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory; give a recording (.h5) or an IMU file (e.g. imu.csv.gz)")
    if is_hdf5(path):
        return load(path, with_truth=False), path, True  # /truth (simulator) is not for the processor
    return _import(path), path, False


def _import(path: Path) -> Recording:
    """Read a non-HDF5 input through the importers (``bootnav import``'s public API, ``read_any``).

    The ``ImportResult`` is kept on ``Recording.raw["import_result"]`` so the outputs can write the
    imported recording (raw values + channels, exactly as ``bootnav import`` would) next to the results.
    """
    try:
        try:
            from bootnav.logger.importers import read_any
        except ImportError:
            from bootnav.logger.importers.core import read_any
    except ImportError:  # importers not installed in this build: the canonical CSV still works
        return _read_canonical_csv(path)
    try:
        imp = read_any(path)
    except ImportError:  # a half-installed importer package: the canonical CSV still works
        return _read_canonical_csv(path)
    from bootnav.logger.recording import make_events

    events = sorted(imp.events, key=lambda e: (e.get("sample_index", -1), e.get("line", -1)))
    return Recording(path=path, t_s=np.asarray(imp.t_s, np.float64), acc_mps2=imp.acc_mps2,
                     gyro_radps=imp.gyro_radps, saturated=np.asarray(imp.saturated, np.uint8),
                     events=make_events(events), meta=dict(imp.meta), attrs=dict(CONVENTIONS),
                     raw={"import_result": imp})


def _read_canonical_csv(path: Path) -> Recording:
    """Fallback reader for the canonical ``t_s,ax_mps2,...,gz_radps`` CSV (plain or gzip)."""
    import gzip

    opener = gzip.open if path.read_bytes()[:2] == b"\x1f\x8b" else open
    with opener(path, "rt") as f:
        header = f.readline().strip().split(",")
        need = ["t_s", "ax_mps2", "ay_mps2", "az_mps2", "gx_radps", "gy_radps", "gz_radps"]
        if header[:7] != need:
            raise InputError(f"{path}: line 1: not a bootnav recording nor a canonical IMU CSV (header {header[:7]}); "
                             "convert it with `bootnav import` first")
        try:
            data = np.loadtxt(f, delimiter=",", ndmin=2, usecols=range(7))
        except ValueError as exc:
            raise InputError(f"{path}: unreadable number ({exc})") from None
    events = np.zeros(0, dtype=EVENT_DTYPE)
    return Recording(path=path, t_s=data[:, 0].copy(), acc_mps2=np.ascontiguousarray(data[:, 1:4]),
                     gyro_radps=np.ascontiguousarray(data[:, 4:7]), saturated=np.zeros(len(data), np.uint8),
                     events=events, meta={"source_file": str(path), "importer_profile": "canonical"},
                     attrs=dict(CONVENTIONS))


# ------------------------------------------------------------------------------------------ checks
def crop_index(t_s: np.ndarray, crop_s, name: str = "recording") -> slice:
    if crop_s is None:
        return slice(0, len(t_s))
    t0, t1 = float(crop_s[0]), float(crop_s[1])
    if not t1 > t0:
        raise InputError(f"{name}: --crop: end {t1} s must be after start {t0} s")
    i0 = int(np.searchsorted(t_s, t0, side="left"))
    i1 = int(np.searchsorted(t_s, t1, side="right"))
    if i1 - i0 < 2:
        raise InputError(f"{name}: --crop {t0:g} {t1:g}: no samples in that window (recording spans "
                         f"{t_s[0]:.3f}-{t_s[-1]:.3f} s)")
    return slice(i0, i1)


def check_samples(name: str, t_s, acc_b, gyro_b, offset: int, checks: InputChecks) -> list[str]:
    """Errors for input that cannot give a valid path; warnings (returned) for what is only suspicious."""
    n = len(t_s)
    if n < 3:
        raise InputError(f"{name}: only {n} samples; nothing to process")
    if np.all(np.isnan(gyro_b)):
        raise InputError(f"{name}: no gyroscope data (accelerometer-only file): foot-mounted ZUPT navigation "
                         "needs a gyro; use `bootnav pdr` for step-and-heading dead reckoning")
    finite = np.isfinite(t_s) & np.all(np.isfinite(acc_b), axis=1) & np.all(np.isfinite(gyro_b), axis=1)
    if not finite.all():
        i = int(np.flatnonzero(~finite)[0])
        cols = [c for c, v in zip(("t_s", "ax", "ay", "az", "gx", "gy", "gz"),
                                   np.concatenate(([t_s[i]], acc_b[i], gyro_b[i]))) if not np.isfinite(v)]
        t_txt = f"t = {t_s[i]:.4f} s" if np.isfinite(t_s[i]) else "time unknown"
        raise InputError(f"{name}: sample {i + offset} ({t_txt}): NaN/inf in {', '.join(cols)} "
                         f"({int((~finite).sum())} bad samples in all); crop around them with --crop T0 T1")
    dt = np.diff(t_s)
    back = np.flatnonzero(dt < 0)
    if len(back):
        i = int(back[0]) + 1
        raise InputError(f"{name}: sample {i + offset}: time goes backwards ({t_s[i - 1]:.6f} s -> {t_s[i]:.6f} s); "
                         "re-import the file (`bootnav import` repairs device-clock wraps)")
    duration = float(t_s[-1] - t_s[0])
    if duration < checks.min_duration_s:
        raise InputError(f"{name}: too short: {duration:.2f} s of data (need >= {checks.min_duration_s:g} s: "
                         "a still period plus a few strides)")
    warnings = []
    pos = dt[dt > 0]
    med = float(np.median(pos)) if len(pos) else float("nan")
    big = np.flatnonzero(dt > checks.max_gap_s)
    if len(big):
        i = int(big[0])
        raise InputError(f"{name}: sample {i + 1 + offset}: gap of {dt[i]:.3f} s at t = {t_s[i]:.3f} s "
                         f"(> {checks.max_gap_s:g} s cannot be bridged by integration); process each side "
                         f"with --crop {t_s[0]:.3f} {t_s[i]:.3f} / --crop {t_s[i + 1]:.3f} {t_s[-1]:.3f}")
    gaps = np.flatnonzero(dt > checks.gap_factor * med)
    if len(gaps):
        warnings.append(f"{len(gaps)} gaps longer than {checks.gap_factor:g} x the median interval "
                        f"({med * 1e3:.2f} ms), longest {dt[gaps].max() * 1e3:.1f} ms at t = {t_s[gaps[np.argmax(dt[gaps])]]:.3f} s "
                        "(integrated over with the real time step)")
    dup = int((dt == 0).sum())
    if dup:
        warnings.append(f"{dup} duplicate timestamps (zero time step; integrated as no time elapsed)")
    return warnings


def saturation_intervals(t_s: np.ndarray, saturated: np.ndarray, offset: int = 0) -> list[dict]:
    """Contiguous runs of saturated samples with the axes involved (bitmask names: ax..gz)."""
    sat = np.asarray(saturated)
    mask = sat.astype(bool) if sat.ndim == 1 else sat.any(axis=1)
    out = []
    for a, b in stance_phases(mask):  # runs of True, reused
        bits = int(np.bitwise_or.reduce(sat[a:b].astype(np.uint8))) if sat.ndim == 1 else 0
        axes = [AXIS_NAMES[k] for k in range(6) if bits >> k & 1]
        out.append({"t0_s": float(t_s[a]), "t1_s": float(t_s[b - 1]), "i0": int(a + offset),
                    "i1": int(b - 1 + offset), "samples": int(b - a), "axes": axes})
    return out


def clipping_bits(acc_b: np.ndarray, gyro_b: np.ndarray) -> np.ndarray:
    """Saturation bitmask (bits as the recording's) from full-scale plateaus, for inputs without a mask."""
    from .detectors._common import clipped_samples

    bits = np.zeros(len(acc_b), dtype=np.uint8)
    for k, x in enumerate((*acc_b.T, *gyro_b.T)):
        bits |= clipped_samples(x[:, None]).astype(np.uint8) << k
    return bits


def check_stance(name: str, t_s, stance: np.ndarray, checks: InputChecks, method: str, gyro_b=None) -> None:
    """Refuse a stance mask that cannot give a valid ZUPT path (see InputChecks)."""
    phases = stance_phases(stance)
    frac = float(np.mean(stance))
    hint = ("check that the sensor is on the foot (not waist or hand: use `bootnav pdr`), or choose another "
            "detector / threshold (--detector, --settings)")
    if gyro_b is not None and stance.any():
        w = float(np.median(np.linalg.norm(gyro_b[stance], axis=1)))
        if w > checks.max_stance_gyro_radps:
            raise InputError(f"{name}: stance detector '{method}' marks {100 * frac:.0f} % of samples as stance, but "
                             f"the sensor turns at a median {w:.2f} rad/s there (a resting foot: < "
                             f"{checks.max_stance_gyro_radps:g} rad/s): no zero-velocity phase found; {hint}")
    if len(phases) <= 1 and frac > 0.9:
        raise InputError(f"{name}: the foot is at rest for {100 * frac:.0f} % of the {t_s[-1] - t_s[0]:.1f} s "
                         f"(detector '{method}': {len(phases)} stance phase, no stride): nothing to navigate")
    if len(phases) < checks.min_stance_phases:
        raise InputError(f"{name}: stance detector '{method}' found {len(phases)} stance phase(s) in "
                         f"{t_s[-1] - t_s[0]:.1f} s (need >= {checks.min_stance_phases} for zero-velocity updates); {hint}")
    if not checks.min_stance_fraction <= frac <= checks.max_stance_fraction:
        raise InputError(f"{name}: stance detector '{method}' marks {100 * frac:.1f} % of samples as stance "
                         f"(plausible {100 * checks.min_stance_fraction:.0f}-{100 * checks.max_stance_fraction:.0f} %); {hint}")


def check_strides(name: str, steps: dict, checks: InputChecks, method: str) -> list[str]:
    """Strides longer than a foot can move mean missed stance phases (drift in between): warn, or refuse
    when they are more than ``max_long_stride_fraction`` of all strides."""
    length = steps["stride_length_m"]
    dist3 = np.hypot(length, steps["dz_m"])
    long = np.flatnonzero(dist3 > checks.max_stride_length_m)
    if len(long) == 0:
        return []
    worst = int(long[np.argmax(dist3[long])])
    where = f"worst {dist3[worst]:.1f} m ending at t = {steps['t_s'][worst]:.2f} s"
    if len(long) > checks.max_long_stride_fraction * len(length):
        raise InputError(f"{name}: {len(long)} of {len(length)} strides are longer than {checks.max_stride_length_m:g} m "
                         f"({where}): the stance detector '{method}' misses stance phases (running? sensor not on the "
                         "foot?), so the path in between is unaided drift; try another detector (--detector shoe "
                         "--threshold ...) or check the mounting")
    return [f"{len(long)} strides longer than {checks.max_stride_length_m:g} m ({where}): stance phases were "
            "probably missed there; the path is unaided drift in those intervals"]


# ---------------------------------------------------------------------------------------- pipeline
def _call_progress(progress: Progress | None, stage: str, fraction: float) -> None:
    if progress is not None:
        progress(stage, fraction)


def process(source: str | Path | Recording, settings: ProcessSettings | None = None,
            progress: Progress | None = None) -> ProcessResult:
    """Run every stage (module docstring) and return the result; writes nothing.

    ``progress(stage, fraction)`` is called at stage boundaries and, for the filter, while it runs.
    """
    from .calibration import apply_accel_calibration, initial_alignment
    from .detectors import detect_stance
    from .ins import run_filter

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

    from .reference import compute_metrics, load_reference, truth_reference

    ref = None
    if settings.reference and settings.reference != "truth":  # a bad reference fails before any work
        ref = load_reference(settings.reference)
    _call_progress(progress, "load", 0.0)
    rec, path, hdf5 = load_source(source)
    name = str(path) if path else "recording"
    if rec.n < 3:
        raise InputError(f"{name}: only {rec.n} samples; nothing to process")
    if settings.reference == "truth":
        ref = truth_reference(rec, path if hdf5 else None)
    lap("load")

    idx = crop_index(rec.t_s, settings.crop_s, name)
    t_s = np.ascontiguousarray(rec.t_s[idx], dtype=np.float64)
    acc_b = np.ascontiguousarray(rec.acc_mps2[idx], dtype=np.float64)
    gyro_b = np.ascontiguousarray(rec.gyro_radps[idx], dtype=np.float64)
    sat_bits = np.asarray(rec.saturated[idx]) if rec.saturated is not None else np.zeros(len(t_s), np.uint8)
    warnings = check_samples(name, t_s, acc_b, gyro_b, idx.start, settings.checks)
    if settings.detector.detect_clipping:
        sat_bits = sat_bits | clipping_bits(acc_b, gyro_b)
    sat_iv = saturation_intervals(t_s, sat_bits, idx.start)
    if sat_iv:
        n_sat = sum(iv["samples"] for iv in sat_iv)
        worst = max(sat_iv, key=lambda iv: iv["samples"])
        warnings.append(f"{len(sat_iv)} saturated bursts ({n_sat} samples at full scale, longest "
                        f"{worst['t0_s']:.3f}-{worst['t1_s']:.3f} s on {'/'.join(worst['axes']) or 'unknown axes'}): "
                        "the path is less trustworthy there (intervals listed in summary.json)")
    lap("checks")

    cal = settings.calibration
    if cal.accel_calibration_file:
        acc_b = apply_accel_calibration(acc_b, cal.accel_calibration_file)
    gravity = cal.gravity()
    init = initial_alignment(t_s, acc_b, gyro_b, cal, gravity)
    warnings += list(init.warnings)
    lap("calibration")

    stance_res = detect_stance(t_s, acc_b, gyro_b, settings.detector, gravity, saturated=sat_bits)
    stance = np.asarray(stance_res.stance, dtype=bool)
    check_stance(name, t_s, stance, settings.checks, stance_res.method, gyro_b)
    warnings += [str(w) for w in (stance_res.info or {}).get("warnings", [])]
    lap("detection")

    filter_progress = (lambda f: _call_progress(progress, "filter", min(float(f), 0.99))) if progress else None
    nav = run_filter(t_s, acc_b, gyro_b, stance, init, gravity, settings.filter, progress=filter_progress,
                     saturated=sat_bits)
    pos_n = np.asarray(nav.pos_n)
    bad = np.flatnonzero(~np.all(np.isfinite(pos_n), axis=1))
    if len(bad):
        raise InputError(f"{name}: the filter diverged at sample {bad[0] + idx.start} (t = {t_s[bad[0]]:.3f} s); "
                         "check the sensor ranges and the input units")
    warnings += [str(w) for w in (getattr(nav, "info", None) or {}).get("warnings", [])]
    lap("filter")

    floors = settings.floor_settings()
    steps = segment_strides(t_s, pos_n, stance)
    warnings += check_strides(name, steps, settings.checks, stance_res.method)
    path_stats = path_summary(t_s, pos_n, stance, floors)
    metrics = compute_metrics(ref, t_s, pos_n, stance, rec.meta.get("mount")) if ref is not None else None
    lap("strides")

    summary = {
        "software": {"name": "bootnav", "version": __version__},
        "conventions": {**CONVENTIONS,
                        "time": "t_s = recording time (a crop keeps the recording's clock)",
                        "origin": ("nav-frame origin = sensor position at the first processed sample; initial yaw = 0, "
                                   "so x is the sensor's initial heading, not true east (no magnetometer)"),
                        "heading_rad": "stride direction atan2(dy, dx), counter-clockwise from x (east)",
                        "distance": "sum of horizontal footprint-to-footprint distances (stance phases)"},
        "input": {
            "source": name,
            "format": "hdf5" if hdf5 else "imported",
            "samples_total": int(rec.n),
            "samples_processed": int(len(t_s)),
            "t_start_s": float(t_s[0]),
            "t_end_s": float(t_s[-1]),
            "duration_s": float(t_s[-1] - t_s[0]),
            "rate_hz": float(1.0 / np.median(np.diff(t_s)[np.diff(t_s) > 0])),
            "crop_s": list(settings.crop_s) if settings.crop_s else None,
            "device": rec.meta.get("device"),
        },
        "alignment": {
            "gravity_mps2": float(gravity),
            "roll_deg": float(np.degrees(getattr(init, "roll_rad", 0.0))),
            "pitch_deg": float(np.degrees(getattr(init, "pitch_rad", 0.0))),
            "gyro_bias_radps": np.asarray(init.gyro_bias_b).tolist(),
            "still_period_s": ([float(t_s[init.still.start]), float(t_s[init.still.stop - 1])]
                               if init.still is not None else None),
        },
        "stance": {
            "method": stance_res.method,
            "threshold": _jsonable(stance_res.threshold),
            "phases": int(path_stats["stance_phases"]),
            "fraction": float(stance.mean()),
            "info": _jsonable(stance_res.info),
        },
        "filter": _jsonable(getattr(nav, "info", {})),
        "path": path_stats,
        "metrics": _jsonable(metrics),
        "saturation_intervals": sat_iv,
        "warnings": warnings,
        "timings_s": timings,
        "settings": settings.to_dict(),
    }
    # Headline numbers at the top level, so `jq .distance_m summary.json` just works.
    for key in ("distance_m", "closure_3d_m", "closure_pct", "floors_climbed", "floors_descended", "strides"):
        if key in path_stats:
            summary[key] = path_stats[key]
    timings["total_process"] = float(sum(timings.values()))
    return ProcessResult(
        t_s=t_s, pos_n=pos_n, vel_n=np.asarray(nav.vel_n), q_nb=np.asarray(nav.q_nb), stance=stance,
        steps=steps, summary=summary, settings=settings, warnings=warnings, saturated=sat_bits.astype(bool),
        acc_b=acc_b, gyro_b=gyro_b, gravity_mps2=float(gravity), stance_result=stance_res, nav=nav, init=init,
        recording=rec, source=path, source_is_hdf5=hdf5, index=idx, saturation_intervals=sat_iv,
        metrics=metrics, reference=ref,
    )


def _jsonable(obj: Any) -> Any:
    """Plain JSON types from numpy/dataclass-laden info dicts (big arrays summarised, not dumped)."""
    import dataclasses

    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, np.generic):
        return _jsonable(obj.item())
    if isinstance(obj, np.ndarray):
        if obj.size > 64:
            return {"shape": list(obj.shape), "dtype": str(obj.dtype)}
        return _jsonable(obj.tolist())
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return _jsonable(dataclasses.asdict(obj))
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)
