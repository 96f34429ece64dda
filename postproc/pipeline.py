"""``process``: from a recording (or any file ``bootnav import`` reads) to the walked 3-D path.

The stages are the paper's pipeline [Heidari2019] with the standard reconstructions it cites; each is
timed in ``summary["timings_s"]`` and each lives in its own module, read top to bottom:

1. **load** (``source``): the recording or imported file; a reference file (``reference_path``) is read first, so a
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
   ``selftune.min_stride_m`` are not strides), distance, closure, floors; before them the storeys
   (``floors.snap_storeys``: flights counted in risers, landings on discrete storeys).
6. **reference** (``reference_path``), when a reference is given: its metrics [Heidari2019, Table 1].

The summary layout is ``summary.build_summary``. ``process`` writes nothing; ``outputs.write_outputs`` and
``plots`` do.

``process_chunked`` (``bootnav process --chunk-s S``) is the same pipeline for recordings of many hours, with
memory bounded by the chunk: it reads the recording block by block, makes the whole-recording decisions in
passes over the blocks, and writes the outputs as it goes (its docstring says what it leaves out).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bootnav.core import atomic
from bootnav.errors import InputError
from bootnav.logger.recording import Recording

from .checks import (ClipRails, check_path_finite, check_samples, clipping_bits, refuse_fatal,
                     saturation_intervals, saturation_warnings, stride_findings)
from .ellipses import stride_scale_covariance
from .floors import snap_storeys
from .navigate import navigate
from .selftune import TINY
from .settings import ProcessSettings
from .source import crop, is_hdf5, load_source
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
    gyro_b: np.ndarray  # (N, 3) rad/s (calibrated; the filter's bias estimate is in ``nav``)
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
    reference: Any = None  # reference_path.Reference
    navigation: Any = None  # navigate.Navigation: stance choice, timing offset, confidence, stride flags
    sensor_calibration: Any = None  # calibration.AppliedCalibration: which calibration ran (or none, and why)


def _call_progress(progress: Progress | None, stage: str, fraction: float) -> None:
    if progress is not None:
        progress(stage, fraction)


class _StageClock:
    """Wall time of each stage since the previous one (``timings``, s), reported to ``progress`` as done."""

    def __init__(self, progress: Progress | None):
        self.progress = progress
        self.timings: dict[str, float] = {}
        self._clock = time.perf_counter()

    def __call__(self, stage: str) -> None:
        now = time.perf_counter()
        self.timings[stage] = now - self._clock
        self._clock = now
        _call_progress(self.progress, stage, 1.0)


def process(source: str | Path | Recording, settings: ProcessSettings | None = None,
            progress: Progress | None = None, calibration=None) -> ProcessResult:
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
    calibration
        A ``bootnav.core.sensorcal.SensorCalibration`` to apply instead of the one the settings choose
        (``calibration.resolve_calibration``), or False for none.

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
    from .calibration import calibrate_recording, initial_alignment
    from .reference_path import compute_metrics, load_reference, truth_reference

    settings = settings or ProcessSettings()
    settings.validate()
    lap = _StageClock(progress)
    timings = lap.timings

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
    acc_b, gyro_b, sensor_cal = calibrate_recording(src.recording, samples.index, samples.acc_b, gyro_b, cal,
                                                    calibration)
    warnings += sensor_cal.warnings
    gravity = cal.gravity()
    init = initial_alignment(t_s, acc_b, gyro_b, cal, gravity)
    warnings += list(init.warnings)
    lap("calibration")

    filter_progress = (lambda f: _call_progress(progress, "navigation", min(float(f), 0.99))) if progress else None
    navi = navigate(name, t_s, acc_b, gyro_b, init, gravity, settings, sat_bits, filter_progress)
    nav, stance = navi.nav, navi.stance
    pos_n = np.asarray(nav.pos_n)
    check_path_finite(name, t_s, pos_n, offset)
    storeys = None
    floors = settings.floor_settings()
    if floors.storeys:
        pos_n, storeys = snap_storeys(t_s, pos_n, stance, settings.filter.level_max_dz_m, floors.riser_min_m,
                                      floors.riser_max_m, settings.filter.level_min_stride_m, floors.hysteresis_m,
                                      floors.floor_height_m)
    # the floor number: the storeys found (``floors.storey_numbers``) as heights of whole nominal storeys, so that
    # the hysteresis counting of ``strides.floor_levels`` returns exactly their numbers
    floor_z = storeys.storey_fp * floors.floor_height_m if storeys is not None else None
    warnings += navi.warnings
    warnings += [str(w) for w in (getattr(nav, "info", None) or {}).get("warnings", [])]
    lap("navigation")

    min_stride = settings.selftune.min_stride_m
    cov_extra = stride_scale_covariance(t_s, pos_n, stance, nav.q_nb, settings,
                                        sensor_cal.provenance.get("status") == "applied")
    steps = segment_strides(t_s, pos_n, stance, min_stride, navi.quality.flags & np.uint8(0xFF ^ TINY),  # a kept stride is not tiny
                            floors, nav.pos_sigma_n, getattr(nav, "pos_cov_en", None), floor_z, cov_extra)
    if len(steps["t_s"]) == 0 and not np.isfinite(navi.period_s):
        raise InputError(f"{name}: no motion: not one stride of >= {min_stride:g} m and no periodic gait in "
                         f"{t_s[-1] - t_s[0]:.1f} s; nothing to navigate (is the sensor on a walking foot?)")
    findings = stride_findings(steps, settings.checks, navi.choice)
    warnings += ([f.message for f in findings] if settings.selftune.fallback else refuse_fatal(name, findings))
    path_stats = path_summary(t_s, pos_n, stance, floors, min_stride, floor_z)
    path_stats["storeys"] = storeys.summary() if storeys is not None else None
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
        saturation_intervals=sat_iv, metrics=metrics, reference=ref, navigation=navi, sensor_calibration=sensor_cal,
    )
    result.summary = build_summary(result, path_stats, timings)
    return result


# ---------------------------------------------------------------------------------------------------------------
# Chunked run: bounded memory for recordings of a whole shift


def process_chunked(source: str | Path, settings: ProcessSettings | None, out_dir: str | Path, chunk_s: float,
                    force: bool = False, progress: Progress | None = None) -> tuple[dict, dict[str, str]]:
    """``process`` + ``outputs.write_outputs`` of an HDF5 recording in chunks of ``chunk_s`` seconds.

    Memory is bounded by the chunk (and the smoother's open segment), not by the recording's length: the
    recording is read block by block from the file, and every per-sample output is appended to
    ``trajectory.csv`` and ``results.h5`` as the navigator makes it final. The path is the same for every
    chunk size (to rounding, 1e-9 m: ``tests/test_long_chunked.py``). The decisions ``process`` makes on the
    whole arrays are made by passes over the blocks before the final one:

    1. the adaptive detector's noise floor F: one pass of ``StreamStance`` (its histogram quantile over the
       whole recording, then fixed, so every chunking gets the same stance mask);
    2. the vertical timing calibration τ (``selftune.level_timing_offset``): one pass of the two probe
       filters (±δ, no smoother) with their footprints accumulated (``strides.FootprintAccumulator``);
    3. the final pass: stance, the filter + smoother on the specific force rotated by τ, the outputs.

    The clipping rails (``checks.ClipRails``) take two cheap passes (extremes, then the samples at them); the
    checks run per block; the initial alignment reads the first seconds (``calibration.still_search_s`` +
    ``max_still_s``); the nominal period is the median step of the first 65 536 samples. Not done in chunks
    (refused, or left out with a warning): the plausibility checks of the stance mask, the truth-free
    fallback and its confidence figure (the configured detector is always used), the per-stride quality
    flags, the detector statistic in ``results.h5``, crop, reference, non-HDF5 inputs. The sensor calibration
    (``calibration.resolve_calibration``) is applied to every block as it is read, with its temperature. Charts 1-7 and path.html are drawn from the decimated stream of the final pass
    (``plots.ChartStream``: bounded memory), as the whole run draws them. F is a histogram quantile (1e-3
    decade bins): the stance mask can differ from the whole-array run's in samples where F + δ decides (none on the test walks).

    Parameters
    ----------
    source
        A bootnav HDF5 recording.
    settings
        Every tunable (defaults when None).
    out_dir
        Output directory (``check_outputs`` rules).
    chunk_s
        Seconds of samples per block (> 0).
    force
        Replace existing output files.
    progress
        ``progress(stage, fraction)``.

    Returns
    -------
    (summary, files)
        The summary written to summary.json and {kind: path} of every file written.

    Raises
    ------
    InputError
        As ``process``, plus an option not available in chunks or a detector that cannot stream.
    """
    import json

    from bootnav.core.jsonio import to_jsonable

    from .outputs import ChartWorker, check_outputs

    settings = settings or ProcessSettings()
    settings.validate()
    path, out = Path(source), Path(out_dir)
    name = str(path)
    if not (chunk_s > 0 and np.isfinite(chunk_s)):
        raise InputError(f"--chunk-s must be a positive number of seconds, got {chunk_s}")
    for what, bad in (("--crop", settings.crop_s), ("--reference/--closed-loop", settings.reference)):
        if bad:
            raise InputError(f"{name}: {what} is not available with --chunk-s; run without --chunk-s")
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if not is_hdf5(path):
        raise InputError(f"{path}: --chunk-s reads HDF5 recordings; `bootnav import` it first")
    warnings: list[str] = []
    check_outputs(settings, out, [path], False, force)
    lap = _StageClock(progress)
    worker = ChartWorker.start() if settings.output.plots else None  # warms matplotlib up during the passes
    try:
        summary, files = _chunked_passes(path, settings, out, chunk_s, warnings, lap, worker, progress)
    finally:
        if worker is not None:
            worker.close()
    files["summary"] = str(out / "summary.json")
    summary["files"] = files
    atomic.write_text(out / "summary.json", json.dumps(to_jsonable(summary), indent=1, allow_nan=False) + "\n")
    return summary, files


def _check_units_chunked(f, imu, n: int, path) -> None:
    """The recording loader's unit check (``recording.check_recording_units``) on the first rows of a recording
    read block by block: acc in g or counts, gyro in deg/s refused as ``import`` and ``load`` refuse them."""
    from bootnav.logger.recording import UNIT_CHECK_ROWS, Recording, check_recording_units, decode_attr, make_events

    k = min(n, UNIT_CHECK_ROWS)

    def si(key):
        ds = imu[key]
        return ds[:k].astype(np.float64) * float(ds.attrs.get("scale_to_si", 1.0)) \
            + float(ds.attrs.get("offset_to_si", 0.0))

    meta = {key: decode_attr(v) for key, v in f["meta"].attrs.items()} if "meta" in f else {}
    head = Recording(path=path, t_s=imu["t_s"][:k].astype(np.float64), acc_mps2=si("acc"), gyro_radps=si("gyro"),
                     saturated=np.zeros(k, np.uint8), events=make_events([]), meta=meta, attrs={})
    check_recording_units(head, path)


def _chunked_passes(path: Path, settings: ProcessSettings, out: Path, chunk_s: float, warnings: list[str], lap,
                    worker, progress: Progress | None) -> tuple[dict, dict[str, str]]:
    """``process_chunked``'s passes over the recording and its outputs but summary.json; (summary, files)."""
    import json

    import h5py

    from bootnav.core.conventions import CONVENTIONS, SOFTWARE, __version__
    from bootnav.core.jsonio import to_jsonable
    from bootnav.logger.recording import attach_dimension_scales, start_results_file, write_group

    from . import selftune
    from .calibration import apply_calibration, initial_alignment, resolve_calibration, stance_reference
    from .detectors.stream import StreamStance
    from .ins.stream import StreamNavigator
    from .outputs import (TRAJECTORY_COLUMNS, TRAJECTORY_FORMATS, ResultsWriter, draw_here,
                          append_csv_rows, heading_columns, trajectory_columns, write_steps_csv)
    from .strides import FootprintAccumulator, footprint_strides, footprint_summary

    name = str(path)
    timings = lap.timings
    with h5py.File(path, "r") as f:
        if "imu" not in f:
            raise InputError(f"{path}: no /imu group; not a bootnav recording")
        imu = f["imu"]
        device = f["meta"].attrs.get("device") if "meta" in f else None
        sensor_cal = resolve_calibration(settings.calibration, f["meta"].attrs.get("device_id") if "meta" in f else None)
        warnings += sensor_cal.warnings
        n = min(imu[k].shape[0] for k in ("t_s", "acc", "gyro"))
        t_all = imu["t_s"]
        if n < 3:
            raise InputError(f"{name}: only {n} samples; nothing to process")
        _check_units_chunked(f, imu, n, path)
        cal = settings.calibration
        gravity = cal.gravity()
        t_head = t_all[: min(n, 1 << 16)].astype(np.float64)
        dt0 = float(np.median(np.diff(t_head)))
        rows = max(int(round(chunk_s / dt0)), 2)
        n_init = int(min(n, max(rows, np.searchsorted(t_head, t_head[0] + cal.still_search_s + cal.max_still_s + 1.0)
                                + 1)))
        blocks = [(i, min(n, i + rows)) for i in range(0, n, rows)]

        def read(i0: int, i1: int):
            def si(k):
                return (imu[k][i0:i1].astype(np.float64) * float(imu[k].attrs.get("scale_to_si", 1.0))
                        + float(imu[k].attrs.get("offset_to_si", 0.0)))

            sat = np.asarray(imu["saturated"][i0:i1] if "saturated" in imu else np.zeros(i1 - i0), np.uint8)
            t, acc, gyro = imu["t_s"][i0:i1].astype(np.float64), si("acc"), si("gyro")
            if sensor_cal.calibration is not None:
                temp = si("temp") if "temp" in imu else None
                acc, gyro = apply_calibration(sensor_cal, acc, gyro, temp)
                warnings.extend(w for w in sensor_cal.warnings if w not in warnings)
            if rails is not None and rails.rail_pos is not None:
                sat = sat | rails.bits(acc, gyro)
            return t, acc, gyro, sat

        rails = None
        if settings.detector.detect_clipping:  # the extremes of the whole record, then the samples at them
            rails = ClipRails()
            for i0, i1 in blocks:
                rails.add_peaks(*read(i0, i1)[1:3])
            for i0, i1 in blocks:
                rails.add_counts(*read(i0, i1)[1:3])
            rails.finish()
        duration = float(t_all[n - 1] - t_all[0])
        if duration < settings.checks.min_duration_s:  # as check_samples refuses it
            raise InputError(f"{name}: too short: {duration:.2f} s of data (need >= {settings.checks.min_duration_s:g}"
                             " s: a still period plus a few strides)")
        block_checks = replace(settings.checks, min_duration_s=0.0)
        for i0, i1 in blocks:  # the checks of ``process`` (each block with the last samples of the one before)
            t, acc, gyro, _ = read(max(i0 - 2, 0), i1)
            warnings.extend(w for w in check_samples(name, t, acc, gyro, max(i0 - 2, 0), block_checks)
                            if w not in warnings)

        t0_, a0_, g0_, _ = read(0, n_init)
        init = initial_alignment(t0_, a0_, g0_, cal, gravity)
        warnings += list(init.warnings)
        del t0_, a0_, g0_
        lap("load")
        rate = 1.0 / dt0
        bias_det, gravity_det = stance_reference(init, gravity)  # as ``navigate`` gives the detector

        floor = None
        if settings.detector.method == "adaptive":  # pass 1: the noise floor F over the whole recording
            probe = StreamStance(settings.detector, rate, gravity_det, gyro_bias_b=bias_det)
            for i0, i1 in blocks:
                probe.push(*read(i0, i1))
            probe.finish()
            floor = _stream_noise_floor(probe)
        lap("stance_floor")

        def stance_stream():
            """Yield StanceChunks of the whole recording (fixed floor: the same for every chunking)."""
            det = StreamStance(settings.detector, rate, gravity_det, noise_floor_log10=floor, gyro_bias_b=bias_det)
            for i0, i1 in blocks:
                yield from det.push(*read(i0, i1))
            yield from det.finish()

        st = settings.selftune
        timing: dict = {}
        tau = 0.0
        if st.timing_calibration:  # pass 2: the two probe filters of the vertical timing calibration
            probe_filter = replace(settings.filter, smoother="none", level_height=False)  # as selftune's probes
            navs = {s: StreamNavigator.from_initial_state(init, gravity, dt0, probe_filter) for s in (-1, 1)}
            fps = {s: FootprintAccumulator() for s in (-1, 1)}
            for ch in stance_stream():
                for s in (-1, 1):
                    f_rot = selftune.rotate_specific_force(ch.acc_b, ch.gyro_b, s * st.timing_probe_s)
                    r = navs[s].push(ch.t_s, f_rot, ch.gyro_b, ch.stance, ch.saturated)
                    fps[s].push(r.t_s, r.pos_n, r.stance)
            for s in (-1, 1):
                r = navs[s].finish()
                fps[s].push(r.t_s, r.pos_n, r.stance)
            cap = {"max_level_strides": st.timing_max_level_strides}  # the whole run's rule (level_timing_offset)
            timing["m_minus"], n_level = selftune.footprint_level_dz(*fps[-1].finish(), **cap)
            timing["m_plus"], timing["n_level"] = selftune.footprint_level_dz(*fps[1].finish(), **cap)
            timing = selftune.timing_from_probes(timing, st.timing_probe_s, st.timing_max_abs_s,
                                                 st.timing_min_level_strides)
            tau = timing["tau_s"]
        lap("timing")

        # pass 3: the final filter + smoother, outputs appended as rows become final
        out.mkdir(parents=True, exist_ok=True)
        opts = settings.output
        group = f"/results/{opts.results_name}"
        target = out / "results.h5"
        tmp = atomic.temporary_beside(target)
        nav = StreamNavigator.from_initial_state(init, gravity, dt0, settings.filter)
        fp_acc = FootprintAccumulator()
        charts = None
        if opts.plots:
            from .plots import ChartStream

            charts = ChartStream(float(t_all[0]), float(t_all[n - 1]), n, gravity, opts.plot_max_points)
        units = {"t_s": "s", "pos_n_m": "m", "vel_n_mps": "m/s", "q_nb": "1 (wxyz)", "stance": "1 (bool)",
                 "acc_bias_b_mps2": "m/s^2", "gyro_bias_b_radps": "rad/s", "pos_sigma_n_m": "m"}
        n_rows = n_stance = 0
        writer = None
        try:
            if opts.write_hdf5:
                start_results_file(tmp, path, out)  # links to the recording, not a copy
            writer = ResultsWriter(tmp, group, n, units) if opts.write_hdf5 else None
            with atomic.replacing(out / "trajectory.csv") as csv:  # appears complete or not at all
                csv.write((",".join(TRAJECTORY_COLUMNS) + "\n").encode("ascii"))

                def emit(r) -> None:
                    nonlocal n_rows, n_stance
                    if not len(r):
                        return
                    if not np.all(np.isfinite(r.pos_n)):
                        check_path_finite(name, r.t_s, r.pos_n, r.start)
                    append_csv_rows(csv, trajectory_columns(r.t_s, r.pos_n, r.vel_n, r.stance, r.q_nb),
                                    TRAJECTORY_FORMATS)
                    if writer is not None:
                        writer.append({"t_s": r.t_s, "pos_n_m": r.pos_n, "vel_n_mps": r.vel_n, "q_nb": r.q_nb,
                                       "stance": r.stance.astype(np.uint8), "acc_bias_b_mps2": r.acc_bias_b,
                                       "gyro_bias_b_radps": r.gyro_bias_b, "pos_sigma_n_m": r.pos_sigma_n})
                    fp_acc.push(r.t_s, r.pos_n, r.stance)
                    if charts is not None:
                        charts.push_nav(r.t_s, r.pos_n, r.vel_n, r.q_nb, r.stance)
                    n_rows += len(r)
                    n_stance += int(np.count_nonzero(r.stance))

                for ch in stance_stream():
                    if charts is not None:
                        charts.push_imu(ch.t_s, ch.acc_b, ch.gyro_b, ch.saturated)
                    acc_used = selftune.rotate_specific_force(ch.acc_b, ch.gyro_b, tau) if tau else ch.acc_b
                    emit(nav.push(ch.t_s, acc_used, ch.gyro_b, ch.stance, ch.saturated))
                    _call_progress(progress, "navigation", min(0.99, (ch.start + len(ch)) / n))
                emit(nav.finish())
            lap("navigation")

            t_mid, fp = fp_acc.finish()
            min_stride = settings.selftune.min_stride_m
            steps = footprint_strides(t_mid, fp, min_stride, floors=settings.floor_settings())
            if len(steps["t_s"]) == 0:
                raise InputError(f"{name}: no motion: not one stride of >= {min_stride:g} m; nothing to navigate "
                                 "(is the sensor on a walking foot?)")
            path_stats = footprint_summary(fp, settings.floor_settings(), min_stride, fp_acc.walked_s)
            path_stats["storeys"] = None
            if settings.floor_storeys:  # a look-back stage: a flight's landing corrects the samples before it
                warnings.append("chunked run: the storeys (floors.snap_storeys) need the whole path and were not "
                                "applied; the filter's level-stride height hold was")
            lap("strides")
            summary = {
                "input": {"source": name, "format": "hdf5", "samples_total": int(n), "samples_processed": n_rows,
                          "duration_s": float(t_all[n - 1] - t_all[0]), "rate_hz": float(rate),
                          "chunk_s": float(chunk_s), "device": None if device is None else str(device), "gravity_mps2": float(gravity)},
                "calibration": to_jsonable(sensor_cal.provenance),
                "software": dict(SOFTWARE),
                "stance": {"method": settings.detector.method, "fraction": n_stance / max(n_rows, 1),
                           "phases": int(len(fp)), "noise_floor_log10": floor},
                "navigation": {"stance_choice": f"configured ({settings.detector.method})", "chunked": True,
                               "timing_offset": to_jsonable(timing)},
                "filter": to_jsonable(nav.info),
                "path": path_stats,
                **{k: path_stats[k] for k in ("distance_m", "closure_pct") if k in path_stats},
                "timings_s": timings,
                "conventions": dict(CONVENTIONS),
                "settings": settings.to_dict(),
                "warnings": warnings,
            }
            if charts is not None:  # drawn by the chart processes while the files are finished
                charts.finish(t_mid, fp, steps, summary, settings)
                if worker is not None:
                    worker.submit(charts, out)
            files = {"trajectory": str(out / "trajectory.csv")}
            files["steps"] = str(write_steps_csv(out / "steps.csv", steps))
            if writer is not None:
                writer.close()
                attrs = {"software": f"bootnav {__version__}", "settings": settings.to_json(indent=None),
                         "summary": json.dumps(to_jsonable(summary)), "sample_index_start": 0,
                         "stance_method": settings.detector.method,
                         "calibration": json.dumps(to_jsonable(sensor_cal.provenance)),
                         **{f"convention_{k}": v for k, v in CONVENTIONS.items()}}
                write_group(tmp, group, {}, attrs, replace=False)
                step_units = {"t_s": "s", "x_m": "m", "y_m": "m", "z_m": "m", "stride_length_m": "m", "dz_m": "m",
                              "yaw_enu_rad": "rad", "heading_deg_cw_from_north": "deg", "floor": "1"}
                write_group(tmp, f"{group}/steps", {**steps, **heading_columns(steps["yaw_enu_rad"])},
                            {"description": "one row per stride, see postproc/strides.py"}, step_units)
                attach_dimension_scales(tmp, group)
                attach_dimension_scales(tmp, f"{group}/steps", dim="stride")
                atomic.commit(tmp, target)
                files["hdf5"] = f"{target}:{group}"
            lap("write")
            if charts is not None:
                drawn, error = worker.wait() if worker is not None else draw_here(charts, out)
                if error:
                    warnings.append(f"{out}: the charts were not drawn ({error}); the other outputs are complete")
                files.update(drawn)
                lap("plots")
        finally:
            if writer is not None:
                writer.close()
            tmp.unlink(missing_ok=True)
    return summary, files


def _stream_noise_floor(stance) -> float | None:
    """The running noise floor F of an adaptive ``StreamStance`` after every sample was pushed: the
    ``noise_quantile`` of its histogram of log10 T (``detectors.stream``), None before any decision."""
    from .detectors import stream as ds

    hist = stance._hist
    cum = np.cumsum(hist)
    if cum[-1] == 0:
        return None
    k = int(np.searchsorted(cum, stance.detector.noise_quantile * cum[-1], side="left"))
    return ds._HIST_LO + (k + 0.5) * ds._HIST_STEP
