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
4. **navigation**: the stance (zero-velocity) mask of the configured detector
   (``detectors``, [Heidari2019, eq. 2]); when it is implausible (``checks.stance_findings_of``, per-stride
   flags of ``selftune``) a truth-free fallback chooses another, with a warning and a confidence figure; the
   per-recording timing calibration of the vertical channel; the ZUPT error-state Kalman filter + RTS
   smoother (``ins.stream.StreamNavigator``, [Heidari2019, eqs. 1, 3-7]). Only input that cannot be a walking
   foot is refused.
5. **strides** (``strides``, ``checks.stride_findings``): strides (moves shorter than
   ``selftune.min_stride_m`` are not strides), distance, closure, floors; before them the storeys
   (``floors.storey_offsets``: flights counted in risers, landings on discrete storeys).
6. **reference** (``reference_path``), when a reference is given: its metrics [Heidari2019, Table 1].

**One pipeline, read in blocks**: ``process_to`` (what ``bootnav process`` runs) writes the outputs as the rows
become final; ``process`` (the Python API, ``eval``, two boots) runs the same passes and keeps the final pass's
rows in memory instead (``_Collected``: the ``ProcessResult``'s arrays, the same rows as ``trajectory.csv`` and
``results.h5``; its summary is the one ``summary.json`` holds), writing nothing (``outputs.write_outputs`` and
``plots`` write a ``ProcessResult``). The input is read through a
reader of blocks of ``settings.block_s`` seconds, the memory budget (900 s: about 400-440 MB at 200 Hz):
``recording.RecordingReader`` (the one decoder of the ``/imu`` layout) for an HDF5 recording,
``source.MemoryReader`` for any other file (read whole by ``bootnav import``'s reader), the crop a window of its
rows (``source.crop_window``). Every window, one block (every recording of the development datasets) or
many, runs the stages above as passes over its blocks (``_block_passes``; outputs as the former stages on whole
arrays: ``trajectory.csv``/``steps.csv`` byte for byte, ``results.h5`` to 1e-9), each whole-record decision
taken in a pass before the one that needs it, the last pass writing through incremental sinks (``trajectory.csv`` rows,
``outputs.ResultsWriter``, ``plots.ChartStream``). Passes over a single block keep its rows, calibrated and
read-only, and decode it once (a quarter of their time on a one-minute recording, for when one block
takes the passes too); over a single block the final pass also replays the rows of the filter pass before it
when that ran the same filter (the storeys', or the unaided one the heading decision left off), as ``navigate``
runs that filter once. Over many blocks the same is read back from temporary files (``passcache``: each block
decoded once, its rail bits found once, the stance detector run once, the filter rows replayed), within a disk
budget beyond which the passes compute again:

0. the nominal period Δt₀: the median step of the whole record (``_nominal_period``: exact order statistics
   from passes over the times, ``_order_statistics``), as ``timebase.sample_period`` gives ``process``;
1. checks and clipping rails: the rails' extremes, then the samples at them (``checks.ClipRails``); the sample
   checks per block (with the last samples of the block before), their warnings on the whole record's steps
   (``checks.StepWarnings``) and the saturated bursts joined across blocks; the initial alignment on the first
   seconds (with Δt₀);
2. the adaptive detector's noise floor F: one pass of ``StreamStance``, its histogram quantile then fixed, so
   every block length gives the same stance mask;
3. the forward runs: the two probe filters of the vertical timing calibration τ (``selftune.timing_from_probes``' rule, their footprints accumulated), their ZUPT-onset innovations over the part the whole run probes (the
   confidence), the gait period (``selftune.GaitPeriodAccumulator``), the stance findings
   (``checks.stance_findings_of``; ‖ω‖'s median at rest from a 1e-3-decade histogram);
4. with ``heading_aid="auto"``, the heading decision (``building.directions.heading_plan``): the
   unaided filter + smoother's footprints (after the timing offset τ, before the storeys), ``heading_plan``'s decision and per-stride flags, the gate as sample intervals
   (``gate_intervals``: one row per run of aided strides); the passes after it run the aided filter, each
   sample pushed with its gate flag (``StreamNavigator.push(heading_gate=…)``);
   the storeys (``floors``): the final filter's footprints, then ``floors.storey_offsets`` — a look-back stage:
   a flight's landing corrects the samples before it, so it needs the path before the one written (with the
   aid off, the unaided pass's footprints); with ``filter.revisits``, before the storeys, a pass of the final
   filter for the pose graph (``building.revisits.revisit_corrections``: footprints and their variances), whose
   corrections, interpolated in time, correct the rows of every pass after it;
5. the final filter + smoother; each row is written when final, its height corrected by the storey offset
   interpolated in time (``floors.snap_storeys``' rule), the stride flags (``selftune.StrideQualityAccumulator``)
   and the footprints' ellipses accumulated as it goes; with a reference, its rows (t, x, y, z, stance) go to a
   temporary file that ``reference_path.compute_metrics`` reads back memory-mapped;
6. the mount check: ‖ω‖'s 99th percentile, exact from passes (``_percentile``; ``summary.mount_check_of``).

Why passes and not per-block decisions: each decision then equals the one-block run's (to rounding), whatever
the block length (``tests/test_long_chunked.py``). A detector that cannot stream gets the samples of the whole
record and its stance is cut into the chunks the passes push (``detectors.stream.WholeRecordStance``; a warning
says memory grows with the length). The stance fallback runs in passes: when the configured mask fails (after pass 3) or its strides do (after pass 5),
the fallback's candidates (``selftune``'s docstring) are scored by forward runs over the blocks (``_CandidateScore``; the
"cycle minimum" from samples spilled to a temporary file, ``_cycle_minimum``), the chosen mask replaces the
configured one's (its statistic kept) and passes 3-5 run again.

The whole-array functions of some stages remain as the definitions the passes are tested against
(``detectors.detect_stance``, ``checks.stance_findings``, ``selftune.gait_period``, ``selftune.stride_quality``,
``selftune.level_timing_offset``, ``ins.run_filter``, ``floors.snap_storeys``, ``strides.segment_strides``);
``tests/test_pipeline.py`` composes them and checks that ``process`` gives their result.
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

from .checks import (ClipRails, StepWarnings, check_path_finite, check_samples, join_saturation_intervals,
                     refuse_fatal, saturation_intervals, saturation_warnings, stride_findings)
from .passcache import PassSpills
from .settings import ProcessSettings
from .source import is_hdf5, load_source

Progress = Callable[[str, float], None]


@dataclass
class Navigation:
    """The navigation stages' decisions and path (SI; masks and arrays have one row per sample)."""

    configured: Any  # detectors.StanceResult of the configured detector (its statistic; the mask the filter used)
    stance: np.ndarray  # (N,) bool, the mask the filter used
    nav: Any  # ins.NavSolution: the filter + smoother's path (before the storeys)
    acc_used_b: np.ndarray  # (N, 3) m/s², the specific force given to the filter (rotated by τ)
    choice: str  # "configured (<method>)" or the fallback candidate's name
    failed: str | None  # why the configured detector was not kept (None: it was)
    timing: dict  # the timing calibration's figures (tau_s, n_level, applied, ...); {} when off
    confidence: float  # in [0, 1], selftune.confidence
    period_s: float  # gait (stride) period, s; NaN without a periodic gait
    quality: Any  # selftune.StrideQuality of the raw strides (stance phase to stance phase)
    candidates: list[dict] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


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
    navigation: Any = None  # Navigation: stance choice, timing offset, confidence, stride flags
    sensor_calibration: Any = None  # calibration.AppliedCalibration: which calibration ran (or none, and why)
    saturation_bits: np.ndarray | None = None  # (N,) uint8, the bits the filter got (recording's + clipping rails)


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

    The same block passes as ``bootnav process`` (``_block_passes``), their final pass keeping its rows in
    memory instead of writing them: the result's arrays are the rows of ``trajectory.csv`` and ``results.h5``,
    its summary the one ``summary.json`` holds (but ``files``).

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
        The path, stance mask, strides, summary and every intermediate a writer or a plot needs.

    Raises
    ------
    InputError
        Bad settings, an unreadable input or reference, input that cannot be integrated
        (``checks.check_samples``), a recording that cannot be a walking foot, or a diverged filter.
    """
    from .reference_path import load_reference, truth_reference
    from .source import MemoryReader, crop_window

    settings = settings or ProcessSettings()
    settings.validate()
    lap = _StageClock(progress)
    ref = None
    if settings.reference and settings.reference != "truth":  # a bad reference fails before any work
        ref = load_reference(settings.reference)
    _call_progress(progress, "load", 0.0)
    src = load_source(source)
    if settings.reference == "truth":
        ref = truth_reference(src.recording, src.path if src.is_hdf5 else None)
    window = crop_window(MemoryReader(src.recording), settings.crop_s, src.name)
    run = _Input(window, src.name, src.path, src.is_hdf5, src.recording, False, ref, calibration, _Collected())
    summary, _ = _block_passes(run, settings, None, [], lap, None, progress)
    lap.timings["total_process"] = float(sum(lap.timings.values()))
    return _result_of(run, summary, settings, src)


def _result_of(run: _Input, summary: dict, settings: ProcessSettings, src) -> ProcessResult:
    """The ``ProcessResult`` of ``process``'s passes: their rows, samples and figures (``_Collected``)."""
    from .detectors import StanceResult
    from .ins.filter import NavSolution

    x, rows = run.rows.extra, run.rows.arrays()
    stance = rows["stance"].astype(bool)
    nav = NavSolution(rows["t_s"], rows["pos_filter"], rows["vel_n"], rows["q_nb"], rows["acc_bias_b"],
                      rows["gyro_bias_b"], rows["pos_sigma_n"], x["filter_info"], pos_cov_en=rows["pos_cov_en"])
    stance_result = StanceResult(stance, rows["statistic"], x["threshold"], settings.detector.method,
                                 dict(x["stance_info"]))
    acc_used = rows["acc_used"] if rows["acc_used"] is not None else rows["acc_b"]
    navigation = Navigation(
        configured=stance_result, stance=stance, nav=nav, acc_used_b=acc_used, choice=x["choice"],
        failed=x["failed"], timing=x["timing"], confidence=x["confidence"], period_s=x["period"],
        quality=x["quality"], candidates=x["candidates"], warnings=[])
    start = run.rec.start
    return ProcessResult(
        t_s=rows["t_s"], pos_n=rows["pos_n"], vel_n=rows["vel_n"], q_nb=rows["q_nb"], stance=stance,
        steps=x["steps"], summary=summary, settings=settings, warnings=summary["warnings"],
        saturated=rows["saturated"] != 0, acc_b=rows["acc_b"], gyro_b=rows["gyro_b"], gravity_mps2=x["gravity"],
        stance_result=stance_result, nav=nav, init=x["init"], recording=src.recording, source=src.path,
        source_is_hdf5=src.is_hdf5, index=slice(start, start + len(rows["t_s"])),
        saturation_intervals=x["saturation_intervals"], metrics=x["metrics"], reference=run.reference,
        navigation=navigation, sensor_calibration=x["sensor_cal"], saturation_bits=rows["saturated"])


# ---------------------------------------------------------------------------------------------------------------
# Chunked run: bounded memory for recordings of a whole shift


def process_to(source: str | Path, settings: ProcessSettings | None, out_dir: str | Path, force: bool = False,
               progress: Progress | None = None, into_recording: bool = False) -> tuple[dict, dict[str, str]]:
    """``process`` and its outputs in ``out_dir`` (``outputs.check_outputs`` rules): what ``bootnav process`` runs.

    The input is read in blocks of ``settings.block_s`` seconds: an HDF5 recording through ``RecordingReader``,
    any other file through ``source.MemoryReader`` (read whole by ``bootnav import``'s reader), the crop as a
    window of rows (``source.crop_window``). Every window, one block or many, runs the stages of ``process`` as
    passes over its blocks (``_block_passes``), memory bounded by the block. A detector that cannot stream
    gets the whole window's samples (``detectors.stream.WholeRecordStance``), with a warning when that is
    longer than ``block_s``.

    Returns
    -------
    (summary, files)
        The summary written to summary.json and {kind: path} of every file written.
    """
    import json
    from types import SimpleNamespace

    from bootnav.core.jsonio import to_jsonable
    from bootnav.logger.recording import RecordingReader

    from .outputs import ChartWorker, check_outputs, planned_files
    from .reference_path import load_reference, truth_reference
    from .source import MemoryReader, crop_window, load_source

    settings = settings or ProcessSettings()
    settings.validate()
    path, out = Path(source), Path(out_dir)
    ref = None
    if settings.reference and settings.reference != "truth":  # a bad reference fails before any work
        ref = load_reference(settings.reference)
    src = None
    hdf5 = path.is_file() and is_hdf5(path)
    if hdf5:
        reader = RecordingReader(path)
    else:
        src = load_source(path)  # missing, unreadable, too short: its message
        reader = MemoryReader(src.recording)
    worker = None
    try:
        window = crop_window(reader, settings.crop_s, str(path))
        rows = block_rows(window.times(0, min(window.n, 1 << 16)), settings.block_s)
        blocks = -(-window.n // rows) if window.n else 1
        whole_why = _needs_whole_record(settings)
        warnings = [] if whole_why is None or blocks == 1 else [  # ``detectors.stream.WholeRecordStance``
            f"{path}: {whole_why}: its stance is detected on the whole record ({blocks} blocks of "
            f"{settings.block_s:g} s held at once), so memory grows with the recording's length"]
        if settings.reference == "truth":
            ref = truth_reference(SimpleNamespace(n=reader.n, t_s=reader.times()) if hdf5 else src.recording,
                                  path if hdf5 else None)
        check_outputs(settings, out, [path], into_recording, force)
        worker = ChartWorker.start() if settings.output.plots else None  # warms matplotlib up during the passes
        with atomic.output_set(planned_files(settings, out, into_recording)):  # all outputs or none
            run = _Input(window, str(path), path, hdf5, None if src is None else src.recording, into_recording, ref)
            summary, files = _block_passes(run, settings, out, warnings, _StageClock(progress), worker, progress)
            files["summary"] = str(out / "summary.json")
            summary["files"] = files
            atomic.write_text(out / "summary.json", json.dumps(to_jsonable(summary), indent=1, allow_nan=False) + "\n")
    finally:
        reader.close()
        if worker is not None:
            worker.close()
    return summary, files


@dataclass
class _Input:
    """What the block passes read and where their results go."""

    rec: Any  # source.ReaderWindow: the rows processed (a crop's window, else every row)
    name: str  # how messages name the input
    path: Path  # the input file
    is_hdf5: bool  # a bootnav recording (results link to it; --into-recording writes into it)
    recording: Recording | None  # an imported file's Recording (written into results.h5), None for HDF5
    into_recording: bool
    reference: Any  # reference_path.Reference or None
    calibration: Any = None  # a SensorCalibration given to ``process`` (None: the settings' choice; False: none)
    rows: Any = None  # ``_Collected``: the final pass's rows and samples kept in memory (``process``), else None


class _Collected:
    """What the final pass gives ``process`` instead of files: its rows (``NavRows`` after the revisits' and the
    storeys' corrections, the filter's path before the storeys, the detector statistic) and its samples
    (calibrated, saturation bits, the specific force the filter got), in order; ``arrays()`` joins them, and
    ``extra`` holds the run's figures (``_block_passes`` sets it after the final pass)."""

    ROWS = ("t_s", "pos_n", "vel_n", "q_nb", "stance", "acc_bias_b", "gyro_bias_b", "pos_sigma_n", "pos_cov_en")

    def __init__(self):
        self.reset()

    def reset(self) -> None:
        """Forget every row and sample pushed."""
        self._rows: dict[str, list] = {k: [] for k in (*self.ROWS, "pos_filter", "statistic")}
        self._samples: dict[str, list] = {"acc_b": [], "gyro_b": [], "saturated": [], "acc_used": []}
        self.extra: dict = {}

    def push_rows(self, r, pos_filter, statistic) -> None:
        for k in self.ROWS:
            self._rows[k].append(np.asarray(getattr(r, k)))
        self._rows["pos_filter"].append(pos_filter)
        if statistic is not None:
            self._rows["statistic"].append(np.asarray(statistic, np.float64))

    def push_samples(self, ch, acc_used) -> None:
        self._samples["acc_b"].append(ch.acc_b)
        self._samples["gyro_b"].append(ch.gyro_b)
        self._samples["saturated"].append(np.asarray(ch.saturated))
        if acc_used is not None:  # None: the samples' own (no timing offset)
            self._samples["acc_used"].append(acc_used)

    def arrays(self) -> dict[str, np.ndarray]:
        """Every row and sample array joined (pushed arrays are released as they are joined)."""
        out = {}
        for parts in (self._rows, self._samples):
            for k in list(parts):
                v = parts.pop(k)
                out[k] = np.concatenate(v) if len(v) > 1 else (np.array(v[0]) if v else None)
        return out


def block_rows(t_head: np.ndarray, block_s: float) -> int:
    """Samples per block: ``block_s`` seconds at the nominal period (median step of the first samples)."""
    dt0 = float(np.median(np.diff(t_head))) if len(t_head) > 1 else 1.0
    if not (dt0 > 0 and np.isfinite(dt0)):
        return max(len(t_head), 2)  # time not increasing: the checks of ``process`` name it
    return max(int(round(block_s / dt0)), 2)


def _needs_whole_record(settings: ProcessSettings) -> str | None:
    """Why the stance detection of this run needs the whole record (None: it streams), as the passes' warning
    says it (``detectors.stream.WholeRecordStance`` holds the record's samples)."""
    from .detectors.stream import stream_refusal

    why = stream_refusal(settings.detector)
    if why:
        return f"the stance detector '{settings.detector.method}' cannot run block by block ({why})"
    return None


def _block_passes(run: _Input, settings: ProcessSettings, out: Path, warnings: list[str], lap,
                  worker, progress: Progress | None) -> tuple[dict, dict[str, str]]:
    """``process_to``'s passes over the blocks of a recording (module docstring) and its outputs but
    summary.json; (summary, files)."""
    import json

    from bootnav.core.conventions import CONVENTIONS, SOFTWARE, __version__
    from bootnav.core.jsonio import to_jsonable
    import contextlib
    import tempfile

    from bootnav.logger.recording import attach_dimension_scales, write_group

    from . import selftune
    from .calibration import apply_calibration, initial_alignment, resolve_calibration, stance_reference
    from .detectors.stream import StreamStance, stance_detector
    from .ins.filter import propagated_gaps_warning
    from .ins.measurements import LevelHeightMeasurement, ZaruMeasurement
    from .ins.filter import navigator
    from .outputs import (TRAJECTORY_COLUMNS, TRAJECTORY_FORMATS, ResultsWriter, draw_here, geojson_of,
                          start_results, append_csv_rows, heading_columns, trajectory_columns, write_steps_csv)
    from .reference_path import compute_metrics
    from .summary import is_closed_loop
    from .floors import storey_offsets
    from .building.revisits import revisit_corrections
    from .building.directions import aided_settings, gate_intervals, gate_of, heading_plan
    from bootnav.core.rotations import euler_zyx_from_quat

    from .ellipses import scale_error_covariance, scale_sigmas, unwrapped_yaw
    from .strides import FootprintAccumulator, footprint_strides, footprint_summary
    from .summary import HEADLINE_KEYS, PATH_CONVENTIONS, alignment_summary, final_uncertainty, mount_check_of
    from bootnav.core.arrays import row_norm
    from .checks import stance_findings_of

    name = run.name
    timings = lap.timings
    with contextlib.nullcontext(run.rec) as rec:
        device = rec.meta.get("device")
        sensor_cal = resolve_calibration(settings.calibration, rec.meta.get("device_id"), run.calibration)
        warnings += sensor_cal.warnings
        n = rec.n
        t_first, t_last = (float(rec.times(i, i + 1)[0]) for i in (0, n - 1)) if n else (0.0, 0.0)
        if n < 3:
            raise InputError(f"{name}: only {n} samples; nothing to process")
        rec.check_units()
        cal = settings.calibration
        gravity = cal.gravity()
        t_head = rec.times(0, min(n, 1 << 16))
        try:
            dt0 = _nominal_period(rec)  # the whole record's, as ``process`` takes it (``timebase.sample_period``)
        except ValueError:  # no positive step: the checks below refuse the record
            dt0 = float(np.median(np.diff(t_head)))
        rows = block_rows(t_head, settings.block_s)
        chunk_s = settings.block_s
        n_init = int(min(n, max(rows, np.searchsorted(t_head, t_head[0] + cal.still_search_s + cal.max_still_s + 1.0)
                                + 1)))
        blocks = [(i, min(n, i + rows)) for i in range(0, n, rows)]

        last_read: dict = {}  # one block: its rows, calibrated, decoded once for all the passes
        spills = PassSpills(blocks)  # many blocks: decoded, stance and filter rows computed once (``passcache``)

        def read(i0: int, i1: int):
            if last_read.get("rows") == (i0, i1):
                t, acc, gyro, sat = last_read["block"]
            elif (kept := spills.samples.get(i0, i1)) is not None:  # decoded and calibrated by an earlier pass
                t, acc, gyro, sat = kept
            else:
                t, acc, gyro, sat = rec.block(i0, i1)
                if sensor_cal.calibration is not None:
                    acc, gyro = apply_calibration(sensor_cal, acc, gyro, rec.temp_degc(i0, i1))
                    warnings.extend(w for w in sensor_cal.warnings if w not in warnings)
                if len(blocks) == 1:  # more blocks: none is read twice in a row, and keeping one adds to the peak
                    for a in (t, acc, gyro, sat):  # shared by the passes: a stage that wrote into them fails here
                        a.flags.writeable = False
                    last_read.update(rows=(i0, i1), block=(t, acc, gyro, sat))
                spills.samples.put(i0, i1, (t, acc, gyro, sat))
            if rails is not None and rails.rail_pos is not None:
                sat = spills.samples.railed(i0, i1, lambda: sat | rails.bits(acc, gyro))
            return t, acc, gyro, sat

        rails = None
        if settings.detector.detect_clipping:  # the extremes of the whole record, then the samples at them
            rails = ClipRails(settings.filter.sloping_rails)
            for i0, i1 in blocks:
                rails.add_peaks(*read(i0, i1)[1:3])
            for i0, i1 in blocks:
                rails.add_counts(*read(i0, i1)[1:3])
            rails.finish()
        duration = t_last - t_first
        if duration < settings.checks.min_duration_s:  # as check_samples refuses it
            raise InputError(f"{name}: too short: {duration:.2f} s of data (need >= {settings.checks.min_duration_s:g}"
                             " s: a still period plus a few strides)")
        step_checks = StepWarnings(dt0)  # the warnings of ``check_samples`` on the whole record's steps
        sat_iv: list[dict] = []
        for i0, i1 in blocks:  # the checks of ``process`` (each block with the last samples of the one before)
            a = max(i0 - 2, 0)
            t, acc, gyro, sat = read(a, i1)
            check_samples(name, t, acc, gyro, rec.start + a, settings.checks, (t_first, t_last))  # refusals; warnings
            # of the whole record below
            k = max(i0 - a - 1, 0)  # the steps that end in this block
            step_checks.push(t[k:-1], np.diff(t[k:]))
            sat_iv = join_saturation_intervals(sat_iv, saturation_intervals(t[i0 - a:], sat[i0 - a:], rec.start + i0))
        warnings[:0] = step_checks.warnings() + saturation_warnings(sat_iv)  # first, as ``process`` orders them

        t0_, a0_, g0_, _ = read(0, n_init)
        init = initial_alignment(t0_, a0_, g0_, cal, gravity, dt_s=dt0)
        warnings += list(init.warnings)
        alignment = alignment_summary(init, gravity, t0_)
        del t0_, a0_, g0_
        lap("load")
        rate = 1.0 / dt0
        bias_det, gravity_det = stance_reference(init, gravity)  # as ``navigate`` gives the detector
        probe_detector = settings.detector.build(gravity_det)

        chosen: dict = {}  # the fallback's stance: "detector" (settings, floor) or "cycle" (the mask); {}: configured

        def detector_stream(det_settings, det_floor):
            replayed = spills.stance.replay(det_settings, det_floor)  # the chunks an earlier pass spilled
            if replayed is not None:
                yield from replayed
                return
            det = stance_detector(det_settings, rate, gravity_det, noise_floor_log10=det_floor, gyro_bias_b=bias_det)
            keep = spills.stance.recorder(det_settings, det_floor).keep
            for i0, i1 in blocks:
                yield from keep(det.push(*read(i0, i1)))
            yield from keep(det.finish(), last=True)

        def stance_stream():
            """Yield StanceChunks of the whole recording (fixed floor: the same for every chunking): the configured
            detector's, their stance the fallback's when one was chosen (the statistic stays the configured one's,
            as ``process`` keeps it)."""
            if "cycle" in chosen:
                for ch in detector_stream(settings.detector, floor):
                    ch.stance = ch.stance | chosen["cycle"][ch.start:ch.start + len(ch)]
                    yield ch
            elif "detector" in chosen:
                yield from _with_stance_of(detector_stream(settings.detector, floor),
                                           detector_stream(*chosen["detector"]))
            else:
                yield from detector_stream(settings.detector, floor)

        def noise_floor(det_settings):
            """The adaptive detector's noise floor F over the whole recording (pass 1)."""
            det = det_settings.build(gravity_det)
            probe = StreamStance(det_settings, rate, gravity_det, gyro_bias_b=bias_det)
            lowest = _LowestValues(det.noise_quantile, n)
            for i0, i1 in blocks:
                for ch in probe.push(*read(i0, i1)):
                    lowest.add_chunk(ch, det.rest_floor())
            for ch in probe.finish():
                lowest.add_chunk(ch, det.rest_floor())
            low = lowest.quantile()
            return probe.noise_floor_log10 if low is None else low  # all excluded (saturated): the stream's

        def select_fallback(failed: str, period: float) -> dict:
            """The stance fallback in passes: ``selftune``'s candidates scored by forward runs
            over the blocks, the no-rest and mount rules; sets ``chosen``; returns choice, candidates, no_rest
            and the warnings."""
            st_ = settings.selftune
            name0 = f"configured ({settings.detector.method})"
            specs = [(name0, settings.detector, floor)]
            for a in st_.alphas:
                ds = settings.detector.with_method("adaptive", alpha=a)
                specs.append((f"adaptive alpha={a:g}", ds, noise_floor(ds)))
            if st_.shoe_threshold:
                specs.append((f"shoe {st_.shoe_threshold:g}", settings.detector.with_method(
                    "shoe", threshold=st_.shoe_threshold), None))
            rows = [_CandidateScore(nm, init, gravity, dt0, settings.filter).run(
                ((ch, ch.stance) for ch in detector_stream(ds, fl)), period, st_, n) for nm, ds, fl in specs]
            cyc = _cycle_minimum(detector_stream(settings.detector, floor), n, bias_det, gravity_det, period,
                                 settings)
            if cyc is not None:
                rows.append(_CandidateScore("cycle minimum", init, gravity, dt0, settings.filter).run(
                    ((ch, ch.stance | cyc[ch.start:ch.start + len(ch)])
                     for ch in detector_stream(settings.detector, floor)), period, st_, n))
            best = int(np.argmin([r["J"] for r in rows]))
            chosen_row = rows[best]
            sel_warnings = ["no periodic gait found (autocorrelation of |ω| below 0.2 at 0.4-3 s)"] \
                if not np.isfinite(period) else []
            sel_warnings.append(f"stance detection: the configured detector fails ({failed}); fallback "
                                f"'{chosen_row['name']}' chosen (criterion {chosen_row['J']:.3f} m/s vs "
                                f"{rows[0]['J']:.3f} m/s)")
            for r in rows:
                r.pop("_q", None)
            pick = {}
            if chosen_row["name"] == "cycle minimum":
                pick["cycle"] = cyc
            elif best > 0:
                pick["detector"] = specs[best][1:]
            chosen.clear()
            chosen.update(pick)
            # the median turning rate at rest of the chosen mask (exact, ``_order_statistics``)
            g0 = np.asarray(init.gyro_bias_b)
            rates = lambda: (row_norm(ch.gyro_b[ch.stance] - g0) for ch in stance_stream())  # noqa: E731
            m = sum(len(v) for v in rates())
            rate_ = float(np.mean(_order_statistics(rates, ((m - 1) // 2, m // 2)))) if m else np.inf
            gait_txt = ("no periodic gait" if not np.isfinite(period)
                        else f"a gait period of {period:.2f} s but no moment the foot rests")
            if not any(np.isfinite(r["J"]) for r in rows) or rate_ > st_.fail_stance_rate_radps:
                p99_ = rate_p99()
                mount_ = mount_check_of(p99_, t_last - t_first, period, 0.0)
                if not mount_["looks_like_foot"] or not np.isfinite(period):
                    why = (mount_["message"] if not mount_["looks_like_foot"] else
                           "a moving foot rests once per stride and repeats its stride: this signal does neither")
                    raise InputError(f"{name}: not a walking foot: {failed}; no other stance detection finds a "
                                     f"zero-velocity phase either ({gait_txt}), and {why}")
                chosen.clear()
                return {"choice": name0, "candidates": rows, "no_rest": True, "warnings": [
                    f"no stance detection finds a zero-velocity phase ({failed}; {gait_txt}): the path is mostly "
                    "unaided inertial integration and its confidence is 0; check that the sensor is on the foot"]}
            return {"choice": chosen_row["name"], "candidates": rows, "no_rest": False, "warnings": sel_warnings}

        floor = None
        if settings.detector.method == "adaptive":  # pass 1: the noise floor F over the whole recording
            floor = noise_floor(settings.detector)
        lap("stance_floor")


        rate_rows = tempfile.TemporaryFile(prefix="bootnav-rate-")  # ‖ω‖ per sample (8 B each), from pass 2

        def rate_p99() -> float:
            """‖ω‖'s 99th percentile over the record (``summary.mount_check``'s), exact from the spilled rows."""
            return _percentile(lambda: _spilled(rate_rows, n), 99)

        st = settings.selftune
        fallback = None  # the fallback chosen when the configured detector failed (``select_fallback``)
        for attempt in range(2):  # the passes again with the fallback's stance when the configured one failed
            timing: dict = {}
            tau = 0.0
            # pass 2: the gait period, and the forward filters of the timing calibration (two probes at ±δ) or, with
            # it off, the one forward run that scores the path (the RMS of its ZUPT-onset innovations, ``selftune.onset_innovations``)
            signs = (-1, 1) if st.timing_calibration else (0,)
            probe_filter = replace(settings.filter, smoother="none", level_height=False)  # as selftune's probes
            forward = probe_filter if st.timing_calibration else replace(settings.filter, smoother="none")
            probes = _ForwardProbes({s: navigator(init, gravity, dt0, forward) for s in signs},
                                    st.timing_probe_s, st.timing_max_level_strides if st.timing_calibration else None)
            gait = selftune.GaitPeriodAccumulator(dt0)
            phase_starts = _Runs()  # the stance phases
            stance_rate = _LogHistogram()  # ‖ω‖ over the stance samples (``checks.stance_findings``)
            n_stance_all = 0
            for ch in stance_stream():
                gait.push(ch.gyro_b)
                if attempt == 0:  # ‖ω‖ of every sample, for the mount check's percentile
                    np.linalg.norm(ch.gyro_b, axis=1).tofile(rate_rows)
                phase_starts.push(ch.start, ch.stance)
                stance_rate.add(row_norm(ch.gyro_b[ch.stance]))
                n_stance_all += int(np.count_nonzero(ch.stance))
                probes.push(ch, phase_starts.starts)
            period = gait.finish()
            fp_probe, cut, onsets = probes.finish(phase_starts.starts, n)
            if st.timing_calibration:
                cap = {"max_level_strides": st.timing_max_level_strides}  # the whole run's rule (level_timing_offset)
                timing["m_minus"], n_level = selftune.footprint_level_dz(*fp_probe[-1], **cap)
                timing["m_plus"], timing["n_level"] = selftune.footprint_level_dz(*fp_probe[1], **cap)
                timing["innovation_rms_mps"] = float(np.sqrt(np.mean([onsets[s].mean_square(cut) for s in signs])))
                timing["probe_s"] = float(rec.times(cut - 1, cut)[0] - t_first)
                timing = selftune.timing_from_probes(timing, st.timing_probe_s, st.timing_max_abs_s,
                                                     st.timing_min_level_strides)
                tau = timing["tau_s"]
                innovation = timing["innovation_rms_mps"]
            else:
                innovation = float(np.sqrt(onsets[0].mean_square(n)))
            del probes, fp_probe, onsets
            method = settings.detector.method
            if attempt == 0:  # the configured detector's mask (``checks.stance_findings_of``)
                findings = stance_findings_of(len(phase_starts.starts), n_stance_all / n, t_last - t_first,
                                              stance_rate.median() if n_stance_all else None, settings.checks, method)
                warnings += [f.message for f in findings if not f.fatal]
                fatal = [f.message for f in findings if f.fatal]
                failed = fatal[0] if fatal else None
                if failed and not st.fallback:
                    raise InputError(f"{name}: {failed}")
                n_warn = len(warnings)  # the warnings of the configured path start here
            lap("timing")
            if attempt == 0 and failed is not None:  # a fatal stance finding: the fallback's passes
                fallback = select_fallback(failed, period)
                warnings += fallback["warnings"]
                lap("fallback")
                continue

            def acc_used(ch):
                return selftune.rotate_specific_force(ch.acc_b, ch.gyro_b, tau) if tau else ch.acc_b

            def gate(ch):
                """The heading aid's per-sample gate of a chunk (None: the aid, if on, acts everywhere)."""
                return None if gate_iv is None else gate_of(gate_iv, ch.start, ch.start + len(ch.t_s))

            def corrected(r):
                """The revisits' horizontal correction of the rows (``building.revisits.apply_revisits``' rule:
                the footprints' corrections interpolated in time), in place."""
                if revisit is not None:
                    r.pos_n = r.pos_n.copy()
                    for ax in range(2):
                        r.pos_n[:, ax] += np.interp(r.t_s, revisit[0], revisit[1][:, ax])
                return r

            # no revisit correction: the navigator of the last filter pass and the rows of each of its pushes (in
            # memory over one block, spilled over more: ``passcache.NavRowSpill``), which the final pass replays when
            # it runs the same filter with the same gate (the heading decision off: the unaided path is the final
            # one, as ``navigate`` runs it once)
            replay: dict = {}

            def path_footprints(filter_settings, with_var=False):
                """A pass of the filter + smoother (its rows corrected by the revisits found): its footprints (mid
                times, (K,); (K, 3)) and, ``with_var``, the horizontal variance at their times (K,)."""
                path_nav = navigator(init, gravity, dt0, filter_settings)
                path_fp = FootprintAccumulator()
                var = _PhaseInterpolation() if with_var else None
                pieces = spills.nav_rows() if revisit is None else None  # one block: in memory; more: spilled
                replay.clear()
                for ch in stance_stream():
                    r = path_nav.push(ch.t_s, acc_used(ch), ch.gyro_b, ch.stance, ch.saturated, heading_gate=gate(ch))
                    if pieces is not None:
                        pieces.append(r)
                    r = corrected(r)
                    path_fp.push(r.t_s, r.pos_n, r.stance)
                    if var is not None:
                        var.push(r.t_s, r.pos_sigma_n[:, 0] ** 2 + r.pos_sigma_n[:, 1] ** 2, r.stance)
                r = path_nav.finish()
                if pieces is not None:
                    pieces.append(r)
                    if pieces.kept:
                        replay.update(filter=filter_settings, gate=gate_iv, nav=path_nav, rows=pieces)
                r = corrected(r)
                path_fp.push(r.t_s, r.pos_n, r.stance)
                if var is not None:
                    var.push(r.t_s, r.pos_sigma_n[:, 0] ** 2 + r.pos_sigma_n[:, 1] ** 2, r.stance)
                    return (*path_fp.finish(), var.finish())
                return path_fp.finish()

            floors = settings.floor_settings()
            storeys = None
            revisit, revisit_report = None, None  # the pose graph's (footprint times, corrections (K, 2))
            final_filter, gate_iv, heading_decision, path_fp = settings.filter, None, None, None
            if settings.filter.heading_aid == "auto":  # pass 3a: decided on the unaided path (after τ)
                path_fp = path_footprints(settings.filter)
                dec, ends, aided = heading_plan(path_fp[1][:, :2], settings.filter)
                heading_decision = dec.as_dict()
                if dec.on:
                    final_filter = aided_settings(settings.filter, dec)
                    gate_iv = None if aided is None else gate_intervals(phase_starts.stops(n), ends, aided)
                    path_fp = None  # the storeys are on the aided path
                lap("heading")
            if settings.filter.revisits != "none":  # pass 3b: the pose graph over the final filter's strides
                rt, rfp, rvar = path_footprints(final_filter, with_var=True)
                t_k, delta, revisit_report = revisit_corrections(rt, rfp, rvar, settings.filter)
                if delta is not None:
                    revisit = (t_k, delta)
                    path_fp = None  # the storeys are on the corrected path
                else:
                    path_fp = (rt, rfp)
                lap("revisits")
            if floors.storeys:  # pass 3: the final filter's footprints, for the storeys' height offsets
                storey_t, storey_fp = path_fp if path_fp is not None else path_footprints(final_filter)
                storeys = storey_offsets(storey_fp, settings.filter.level_max_dz_m, floors.riser_min_m,
                                         floors.riser_max_m, settings.filter.level_min_stride_m, floors.hysteresis_m,
                                         floors.floor_height_m)
                lap("storeys")
            del path_fp
            snap = storeys is not None and len(storey_t) > 0 and bool(np.any(storeys.offset_fp))

            # the final pass: the filter + smoother, outputs appended as rows become final (``out`` None: kept in
            # ``run.rows``, no file written)
            collect = run.rows
            if collect is not None:
                collect.reset()  # the fallback's passes run the final pass again: the rows of the last one
            opts = settings.output
            group = f"/results/{opts.results_name}"
            tmp = None
            if out is not None:
                out.mkdir(parents=True, exist_ok=True)
                target = run.path if run.into_recording else out / "results.h5"
                tmp = atomic.temporary_beside(target)
            reuse = bool(replay) and replay["filter"] is final_filter and replay["gate"] is gate_iv and revisit is None
            nav = replay["nav"] if reuse else navigator(init, gravity, dt0, final_filter)
            replayed = iter(replay.pop("rows")) if reuse else None
            fp_acc = FootprintAccumulator()
            yaw_acc = FootprintAccumulator()  # the unwrapped yaw at each phase's last sample (``ellipses``)
            yaw_last: list[float] = []  # the previous row's unwrapped yaw: np.unwrap continued across blocks
            quality_acc = selftune.StrideQualityAccumulator()
            gyro_rows = _RowQueue()  # the gyro of the rows the navigator holds back, for the stride flags
            charts = None
            if opts.plots and out is not None:
                from .plots import ChartStream

                charts = ChartStream(t_first, t_last, n, gravity, opts.plot_max_points)
            units = {"t_s": "s", "pos_n_m": "m", "vel_n_mps": "m/s", "q_nb": "1 (wxyz)", "stance": "1 (bool)",
                     "acc_bias_b_mps2": "m/s^2", "gyro_bias_b_radps": "rad/s", "pos_sigma_n_m": "m",
                     "stance_statistic": "detector-specific (see attrs stance_method, stance_threshold)"}
            stat_rows = _RowQueue()  # the detector statistic of the rows the navigator holds back
            n_rows = n_stance = 0
            ends = [None, None]  # the path's first and last positions (the GeoJSON's start and end)
            writer = None
            # a reference is compared with the whole path: its rows (t, x, y, z, stance) go to a temporary file,
            # read back memory-mapped by ``compute_metrics`` after the pass
            spill = tempfile.TemporaryFile(prefix="bootnav-path-") if run.reference is not None else None
            # the adaptive detector's per-sample log10 γ, for its representative threshold 10^median (``adaptive``)
            gamma_spill = tempfile.TemporaryFile(prefix="bootnav-gamma-") if method == "adaptive" else None
            n_gamma = 0
            gamma_range = [np.inf, -np.inf]  # the adaptive detector's log10 γ range (its ``threshold_log10_range``)
            n_saturated = 0  # samples the detector excluded as saturated (``detect_stance``'s ``n_saturated``)
            try:
                if opts.write_hdf5 and out is not None:
                    start_results(tmp, target, run.path, run.is_hdf5, run.recording, run.into_recording)
                writer = ResultsWriter(tmp, group, n, units) if opts.write_hdf5 and out is not None else None
                # trajectory.csv appears complete or not at all
                with atomic.replacing(out / "trajectory.csv") if out is not None else contextlib.nullcontext() as csv:
                    if csv is not None:
                        csv.write((",".join(TRAJECTORY_COLUMNS) + "\n").encode("ascii"))

                    def emit(r) -> None:
                        nonlocal n_rows, n_stance
                        if not len(r):
                            return
                        if not np.all(np.isfinite(r.pos_n)):
                            check_path_finite(name, r.t_s, r.pos_n, rec.start + r.start)
                        corrected(r)
                        quality_acc.push(r.t_s, r.pos_n, r.stance, gyro_rows.take(r.start, r.start + len(r)),
                                         r.gyro_bias_b)  # on the filter's path, before the storeys
                        pos_filter = r.pos_n  # the filter's path (revisits corrected), before the storeys
                        if snap:  # ``floors.snap_storeys``: the offsets interpolated in time between the footprints
                            r.pos_n = r.pos_n.copy()
                            r.pos_n[:, 2] += np.interp(r.t_s, storey_t, storeys.offset_fp)
                        if csv is not None:
                            append_csv_rows(csv, trajectory_columns(r.t_s, r.pos_n, r.vel_n, r.stance, r.q_nb),
                                            TRAJECTORY_FORMATS)
                        if spill is not None:
                            np.column_stack((r.t_s, r.pos_n, r.stance)).astype(np.float64).tofile(spill)
                        stat = (stat_rows.take(r.start, r.start + len(r))
                                if writer is not None or collect is not None else None)
                        if writer is not None:
                            writer.append({"t_s": r.t_s, "pos_n_m": r.pos_n, "vel_n_mps": r.vel_n, "q_nb": r.q_nb,
                                           "stance": r.stance.astype(np.uint8), "acc_bias_b_mps2": r.acc_bias_b,
                                           "gyro_bias_b_radps": r.gyro_bias_b, "pos_sigma_n_m": r.pos_sigma_n,
                                           "stance_statistic": stat})
                        if collect is not None:
                            collect.push_rows(r, pos_filter, stat)
                        fp_acc.push(r.t_s, r.pos_n, r.stance,
                                    np.column_stack((r.pos_sigma_n[:, 0] ** 2, r.pos_sigma_n[:, 1] ** 2, r.pos_cov_en)))
                        yaw = unwrapped_yaw(r.q_nb) if not yaw_last else np.unwrap(
                            np.concatenate((yaw_last, euler_zyx_from_quat(np.asarray(r.q_nb, float))[:, 2])))[1:]
                        yaw_last[:] = [float(yaw[-1])]
                        yaw_acc.push(r.t_s, np.zeros((len(r), 3)), r.stance, np.column_stack((yaw, yaw, yaw)))
                        if charts is not None:
                            charts.push_nav(r.t_s, r.pos_n, r.vel_n, r.q_nb, r.stance)
                        if not n_rows:
                            ends[0] = r.pos_n[0].copy()
                        ends[1] = r.pos_n[-1].copy()
                        n_rows += len(r)
                        n_stance += int(np.count_nonzero(r.stance))

                    for ch in stance_stream():
                        if charts is not None:
                            charts.push_imu(ch.t_s, ch.acc_b, ch.gyro_b, ch.saturated)
                        gyro_rows.put(ch.start, ch.gyro_b)
                        n_saturated += int(np.count_nonzero(np.any(np.reshape(ch.saturated, (len(ch), -1)), axis=1)))
                        if gamma_spill is not None and ch.threshold_log10 is not None:
                            np.asarray(ch.threshold_log10, np.float64).tofile(gamma_spill)
                            n_gamma += len(ch)
                            if len(ch):
                                gamma_range[:] = [min(gamma_range[0], float(np.min(ch.threshold_log10))),
                                                  max(gamma_range[1], float(np.max(ch.threshold_log10)))]
                        if writer is not None or collect is not None:
                            stat_rows.put(ch.start, np.asarray(ch.statistic, np.float64))
                        if collect is not None:
                            collect.push_samples(ch, acc_used(ch) if tau else None)
                        emit(next(replayed) if replayed is not None else
                             nav.push(ch.t_s, acc_used(ch), ch.gyro_b, ch.stance, ch.saturated, heading_gate=gate(ch)))
                        _call_progress(progress, "navigation", min(0.99, (ch.start + len(ch)) / n))
                    emit(next(replayed) if replayed is not None else nav.finish())
                lap("navigation")

                t_mid, fp = fp_acc.finish()
                min_stride = settings.selftune.min_stride_m
                quality = quality_acc.finish(period, settings.selftune)
                confidence = selftune.confidence(innovation, quality.bad_fraction, period, st)
                split = selftune.split_strides(quality, period, st)
                if split:
                    warnings.append(split)
                if not np.isfinite(period):
                    warnings.append("no periodic gait found: the confidence of this path is 0")
                cov_h = fp_acc.cov.copy() if len(fp_acc.cov) == len(fp) else None
                yaw_acc.finish()
                if cov_h is not None and len(yaw_acc.cov) == len(fp):  # the sensor errors the filter does not model
                    cov_h = cov_h + scale_error_covariance(fp, yaw_acc.cov[:, 0], *scale_sigmas(
                        settings, sensor_cal.provenance.get("status") == "applied"))
                # the floor number: the storeys found as heights of whole nominal storeys (as ``process``)
                floor_z = storeys.storey_fp * floors.floor_height_m if storeys is not None else None
                steps = footprint_strides(t_mid, fp, min_stride, quality.flags & np.uint8(0xFF ^ selftune.TINY), floors,
                                          cov_h, floor_z)
                if len(steps["t_s"]) == 0 and not np.isfinite(period):
                    raise InputError(f"{name}: no motion: not one stride of >= {min_stride:g} m and no periodic gait in "
                                     f"{t_last - t_first:.1f} s; nothing to navigate (is the sensor on a walking foot?)")
                if attempt == 0 and failed is None and quality.bad_fraction > st.max_bad_fraction:
                    failed = selftune.implausible_strides(quality)
                    if st.fallback:  # the configured path's strides fail: the fallback's passes
                        del warnings[n_warn:]
                        fallback = select_fallback(failed, period)
                        warnings[n_warn:n_warn] = fallback["warnings"]
                        lap("fallback")
                        continue
                    warnings.insert(n_warn, f"stance detector '{method}': {failed}")
                choice = fallback["choice"] if fallback else f"configured ({settings.detector.method})"
                if fallback and fallback["no_rest"]:
                    confidence = 0.0
                if nav.info.get("n_gaps"):  # as ``ins.run_filter`` says it
                    warnings.append(propagated_gaps_warning(nav.info["n_gaps"], nav.info["max_dt_s"]))
                findings = stride_findings(steps, settings.checks, choice)
                warnings += ([f.message for f in findings] if settings.selftune.fallback else refuse_fatal(name, findings))
                path_stats = footprint_summary(fp, floors, min_stride, fp_acc.walked_s, floor_z)
                path_stats["storeys"] = storeys.summary() if storeys is not None else None
                lap("strides")
                p99 = rate_p99()
                mount = mount_check_of(p99, t_last - t_first, period, float(path_stats.get("distance_m", 0.0)))
                if not mount["looks_like_foot"]:  # as ``summary.build_summary``
                    warnings.append(mount["message"])
                threshold = getattr(probe_detector, "threshold", None)
                if gamma_spill is not None and n_gamma:  # np.median, exact from the spilled rows
                    threshold = float(10.0 ** np.mean(_order_statistics(
                        lambda: _spilled(gamma_spill, n_gamma), ((n_gamma - 1) // 2, n_gamma // 2))))
                metrics = None
                if spill is not None:  # as ``process``: the path with its storeys, every row
                    spill.flush()
                    path_rows = np.memmap(spill, np.float64, "r", shape=(n_rows, 5))
                    metrics = compute_metrics(run.reference, path_rows[:, 0], path_rows[:, 1:4], path_rows[:, 4] > 0.5,
                                              rec.meta.get("mount"), min_stride)
                    del path_rows
                    lap("reference")
                summary = {
                    "input": {"source": name, "format": "hdf5" if run.is_hdf5 else "imported",
                              "samples_total": int(rec.reader.n), "samples_processed": n_rows,
                              "t_start_s": t_first, "t_end_s": t_last,
                              "crop_s": list(settings.crop_s) if settings.crop_s else None,
                              "duration_s": t_last - t_first, "rate_hz": float(rate),
                              "chunk_s": float(chunk_s), "device": None if device is None else str(device), "gravity_mps2": float(gravity)},
                    "calibration": to_jsonable(sensor_cal.provenance),
                    "alignment": alignment,
                    "software": dict(SOFTWARE),
                    "stance": {"method": settings.detector.method, "fraction": n_stance / max(n_rows, 1),
                               "phases": int(len(fp)), "noise_floor_log10": floor,
                               # a fixed-threshold detector's γ; the adaptive one's 10^median of its γ per sample
                               "threshold": to_jsonable(threshold),
                               # what the detector used (``detect_stance``'s info: the parts a run in passes knows)
                               "info": {"dt_s": float(dt0), "noise_floor_log10": floor, "n_saturated": n_saturated,
                                        **({"threshold_log10_range": gamma_range} if n_gamma else {})}},
                    "navigation": {"stance_choice": choice, "blocks": len(blocks),
                                   "fallback_used": failed is not None and not choice.startswith("configured"),
                                   "configured_failed": failed,
                                   "candidates": to_jsonable(fallback["candidates"] if fallback else []),
                                   "confidence": float(confidence), "gait_period_s": to_jsonable(float(period)),
                                   "implausible_stride_fraction": to_jsonable(float(quality.bad_fraction)),
                                   "stride_flags": {nm: int(np.count_nonzero(quality.flags & bit))
                                                    for bit, nm in selftune.FLAG_NAMES.items()},
                                   "stride_flag_bits": {nm: bit for bit, nm in selftune.FLAG_NAMES.items()},
                                   "timing_offset": to_jsonable(timing)},
                    "filter": to_jsonable({"mode": final_filter.mode, "engine": final_filter.engine,
                                           "n_states": final_filter.n_states, "smoother": final_filter.smoother,
                                           # which aids ran (as ``ins.run_filter`` says it)
                                           "zaru": ZaruMeasurement.active(final_filter),
                                           "heading_aid": final_filter.heading_aid,
                                           "level_height": LevelHeightMeasurement.active(final_filter),
                                           **nav.info,  # with the filter's (not smoothed) 1-σ of each error state at
                                           # the last sample, as ``ins.run_filter`` gives it
                                           "final_state_sigma": np.sqrt(np.maximum(np.diag(nav.covariance), 0.0)),
                                           **({} if heading_decision is None else
                                                          {"heading_decision": heading_decision}),
                                           **({} if revisit_report is None else {"revisits": revisit_report})}),
                    "path": path_stats,
                    "metrics": to_jsonable(metrics),
                    "saturation_intervals": sat_iv,
                    "closed_loop": is_closed_loop(run.reference),
                    "mount": mount,
                    "uncertainty": final_uncertainty(steps),
                    "confidence": float(confidence),
                    **{k: path_stats[k] for k in HEADLINE_KEYS if k in path_stats},  # as ``summary.build_summary``
                    "timings_s": timings,
                    "conventions": dict(PATH_CONVENTIONS),
                    "settings": settings.to_dict(),
                    "warnings": warnings,
                }
                if collect is not None:  # ``process``: the run's figures beside its rows
                    collect.extra.update(
                        init=init, gravity=float(gravity), sensor_cal=sensor_cal, saturation_intervals=sat_iv,
                        steps=steps, metrics=metrics, period=float(period), quality=quality, timing=timing,
                        confidence=float(confidence), choice=choice, failed=failed,
                        candidates=fallback["candidates"] if fallback else [], threshold=threshold,
                        stance_info=summary["stance"]["info"], filter_info=summary["filter"])
                    break
                if charts is not None:  # drawn by the chart processes while the files are finished
                    charts.finish(t_mid, fp, steps, summary, settings)
                    if worker is not None:
                        worker.submit(charts, out)
                files = {"trajectory": str(out / "trajectory.csv")}
                files["steps"] = str(write_steps_csv(out / "steps.csv", steps))
                if opts.geojson and opts.geo_anchor:  # as ``outputs.write_outputs``
                    atomic.write_text(out / "path.geojson", json.dumps(geojson_of(
                        fp, ends[0], ends[1], summary.get("distance_m"), opts.geo_anchor)))
                    files["geojson"] = str(out / "path.geojson")
                if writer is not None:
                    writer.close()
                    attrs = {"software": f"bootnav {__version__}", "settings": settings.to_json(indent=None),
                             "summary": json.dumps(to_jsonable(summary)), "sample_index_start": rec.start,
                             "created_utc": _utc_now(), "stance_method": settings.detector.method,
                             "stance_threshold": json.dumps(summary["stance"]["threshold"]),
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
                if spill is not None:
                    spill.close()
                if gamma_spill is not None:
                    gamma_spill.close()
                if tmp is not None:
                    tmp.unlink(missing_ok=True)
            break
        rate_rows.close()
    return summary, ({} if out is None else files)


def _with_stance_of(chunks, other):
    """``chunks`` (StanceChunks) with the stance of ``other`` (another detector's StanceChunks of the same samples,
    cut elsewhere): the fallback keeps the configured detector's statistic and takes another mask."""
    queue, upto, other = _RowQueue(), 0, iter(other)
    for ch in chunks:
        end = ch.start + len(ch)
        while upto < end:
            c = next(other)
            queue.put(c.start, np.asarray(c.stance, bool))
            upto = c.start + len(c)
        if len(ch):
            ch.stance = queue.take(ch.start, end)
        yield ch


class _CandidateScore:
    """One candidate of the stance fallback (``selftune``'s docstring) scored in a pass: a forward run of
    the filter (no smoother, the specific force not rotated by τ) on its mask, the RMS of its ZUPT-onset
    innovations and its stride flags (``selftune.StrideQualityAccumulator`` on the forward path)."""

    def __init__(self, name: str, init, gravity: float, dt0: float, filter_settings):
        from . import selftune
        from .ins.filter import navigator

        self.name = name
        self.nav = navigator(init, gravity, dt0, replace(filter_settings, smoother="none"))
        self.onsets = _OnsetInnovations()
        self.quality = selftune.StrideQualityAccumulator()
        self.gyro = _RowQueue()  # the gyro of the rows the navigator holds back
        self.phases = _Runs()
        self.n_stance = 0
        self.finite = True

    def _rows(self, r) -> None:
        if len(r):
            self.onsets.push(r)
            self.quality.push(r.t_s, r.pos_n, r.stance, self.gyro.take(r.start, r.start + len(r)), r.gyro_bias_b)
            self.finite = self.finite and bool(np.all(np.isfinite(r.pos_n)))

    def run(self, pairs, period_s: float, settings, n: int) -> dict:
        """Push every (StanceChunk, mask) of the record; the candidate's row (the summary's ``navigation.candidates``)."""
        for ch, mask in pairs:
            mask = np.asarray(mask, bool)
            self.phases.push(ch.start, mask)
            self.n_stance += int(np.count_nonzero(mask))
            self.gyro.put(ch.start, ch.gyro_b)
            self._rows(self.nav.push(ch.t_s, ch.acc_b, ch.gyro_b, mask, ch.saturated))
        self._rows(self.nav.finish())
        frac = self.n_stance / n
        if len(self.phases.starts) < 2:  # no stance-to-swing edge: not scored
            return {"name": self.name, "innovation_rms_mps": float("inf"), "bad_fraction": 1.0, "J": float("inf"),
                    "stance_fraction": frac}
        e = float(np.sqrt(self.onsets.mean_square(n))) if self.finite else float("inf")
        q = self.quality.finish(period_s, settings)
        return {"name": self.name, "innovation_rms_mps": e, "bad_fraction": q.bad_fraction,
                "J": e + settings.v_pen_mps * q.bad_fraction, "stance_fraction": frac, "_q": q}


def _cycle_minimum(chunks, n: int, bias_det, gravity_det: float, period_s: float, settings) -> np.ndarray | None:
    """``selftune.cycle_minimum_candidate`` of a record pushed as the configured detector's StanceChunks: the
    samples (t, specific force, rates less the rest bias, saturation) and the configured mask go to temporary
    files read back memory-mapped; the candidate's arithmetic (the SHOE statistic, its minima and their
    prominences over the whole record) makes temporaries of the record's length: the fallback's exception to
    memory bounded by the block (about 60 B per sample while it runs)."""
    import tempfile

    from . import selftune

    if not np.isfinite(period_s):
        return None
    with tempfile.TemporaryFile(prefix="bootnav-cycle-") as f:
        mm = np.memmap(f, np.float64, "w+", shape=(n, 9))  # t, acc (3), gyro less the bias (3), bad, configured
        for ch in chunks:
            a, b = ch.start, ch.start + len(ch)
            mm[a:b, 0] = ch.t_s
            mm[a:b, 1:4] = ch.acc_b
            mm[a:b, 4:7] = ch.gyro_b - bias_det
            mm[a:b, 7] = np.asarray(ch.saturated) != 0
            mm[a:b, 8] = np.asarray(ch.stance, bool)
        mm.flush()
        t = np.ascontiguousarray(mm[:, 0])
        return selftune.cycle_minimum_candidate(t, mm[:, 1:4], mm[:, 4:7], gravity_det, period_s, settings.detector,
                                                settings.selftune, mm[:, 7] > 0.5, mm[:, 8] > 0.5)


def _nominal_period(rec, rows: int = 1 << 20, cap: int = 1 << 20) -> float:
    """``timebase.nominal_period`` of every step of a reader's rows (the median of the positive finite steps, s),
    exact, from passes over its times ``rows`` at a time (``_order_statistics``). ValueError, as
    ``sample_period``, without a positive step."""
    def steps():
        prev = None
        for i0 in range(0, rec.n, rows):
            t = rec.times(i0, min(rec.n, i0 + rows))
            dt = np.diff(t if prev is None else np.concatenate(([prev], t)))
            prev = t[-1]
            yield dt[np.isfinite(dt) & (dt > 0)]

    m = sum(len(dt) for dt in steps())
    if m == 0:
        raise ValueError("the time axis has no positive step")
    return float(np.mean(_order_statistics(steps, ((m - 1) // 2, m // 2), cap)))  # as np.median


def _spilled(f, n: int, rows: int = 1 << 20):
    """The n float64 values written to the temporary file ``f``, read back ``rows`` at a time (8 MB): a
    memory map of the whole file would keep every page read resident until it is closed (8 B per sample,
    138 MB at 24 h at 200 Hz)."""
    f.flush()
    for i in range(0, n, rows):
        f.seek(8 * i)
        yield np.fromfile(f, np.float64, count=min(rows, n - i))
    f.seek(0, 2)  # the end again, where the next values are written


def _percentile(pieces, q: float, cap: int = 1 << 20) -> float:
    """``np.percentile(x, q)`` (linear) of the values ``pieces()`` yields, exact (``_order_statistics``)."""
    m = sum(len(v) for v in pieces())
    pos = q / 100.0 * (m - 1)
    lo = int(np.floor(pos))
    a, b = _order_statistics(pieces, (lo, min(lo + 1, m - 1)), cap)
    t = pos - lo
    return float(a + (b - a) * t if t < 0.5 else b - (b - a) * (1 - t))  # numpy's lerp


def _order_statistics(pieces, ks: tuple[int, int], cap: int = 1 << 20) -> np.ndarray:
    """The values of rank ``ks`` (0-based, ascending; ks[0] <= ks[1]) among every value ``pieces()`` yields (a
    generator called once per pass, e.g. over the blocks of a record), exact with bounded memory: each pass
    counts the values in the interval [lo, hi) known to hold both on a 4096-bin histogram and narrows it to
    their bins, until at most ``cap`` values are left in it (then sorted) or it is one float wide."""
    lo, hi = np.inf, -np.inf
    for v in pieces():
        if len(v):
            lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    hi = float(np.nextafter(hi, np.inf))
    below = 0  # values < lo
    while True:
        if float(np.nextafter(lo, np.inf)) >= hi:  # one float wide: every value in it is lo
            return np.array([lo, lo])
        edges = np.linspace(lo, hi, 4097)
        edges[-1] = hi
        hist = np.zeros(4096, np.int64)
        inside: list | None = []  # the values in [lo, hi), kept while they are at most ``cap``
        count = 0
        for v in pieces():
            v = v[(v >= lo) & (v < hi)]
            count += len(v)
            hist += np.bincount(np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 4095), minlength=4096)
            if inside is not None:
                inside.append(v)
                if count > cap:  # more: the histogram narrows the interval (bounded memory)
                    inside = None
        if inside is not None:
            v = np.sort(np.concatenate(inside)) if inside else np.zeros(0)
            return v[[ks[0] - below, ks[1] - below]]
        cum = below + np.cumsum(hist)
        b0, b1 = (int(np.searchsorted(cum, k, side="right")) for k in ks)  # the bins holding the two
        below = int(cum[b0 - 1]) if b0 else below
        lo, hi = float(edges[b0]), float(edges[b1 + 1])


class _PhaseInterpolation:
    """``np.interp(t_mid, t_s, values)`` at each stance phase's mid time (``strides.footprints``' t_mid) of rows
    pushed in consecutive chunks: the mid time lies between the phase's first and last sample, so the phase's
    own rows give numpy's interpolation (bounded memory: the open phase's rows)."""

    def __init__(self):
        self._out: list[float] = []
        self._t: list[np.ndarray] = []
        self._v: list[np.ndarray] = []

    def push(self, t_s, values, stance) -> None:
        from bootnav.core.runs import runs

        if not len(t_s):
            return
        starts, stops = runs(np.asarray(stance, bool))
        if self._t and (starts.size == 0 or starts[0] > 0):
            self._close()
        for a, b in zip(starts.tolist(), stops.tolist()):
            self._t.append(np.asarray(t_s[a:b], float))
            self._v.append(np.asarray(values[a:b], float))
            if b < len(t_s):
                self._close()

    def _close(self) -> None:
        if self._t:
            t, v = np.concatenate(self._t), np.concatenate(self._v)
            self._out.append(float(np.interp(0.5 * (t[0] + t[-1]), t, v)))
            self._t, self._v = [], []

    def finish(self) -> np.ndarray:
        self._close()
        return np.array(self._out)


class _LowestValues:
    """The ``q`` quantile of log10 T over the usable samples, as ``adaptive.AdaptiveDetector`` takes its noise
    floor (``np.quantile``, linear between order statistics), from chunks: only the smallest ⌊q (n − 1)⌋ + 2
    values can be those order statistics, n the samples of the record, so only they are kept (8 q bytes per
    sample: 7 MB at 24 h at 200 Hz). Equal to the whole-array floor to the last bit of the interpolation."""

    def __init__(self, q: float, n: int):
        self.q = float(q)
        self.k = int(np.floor(self.q * max(n - 1, 0))) + 2
        self._low = np.zeros(0)
        self._n = 0

    def add_chunk(self, ch, rest_floor: float) -> None:
        bad = (ch.saturated > 0) | ~np.all(np.isfinite(ch.acc_b), axis=1) | ~np.all(np.isfinite(ch.gyro_b), axis=1)
        L = np.log10(np.maximum(np.asarray(ch.statistic)[~bad], rest_floor))
        self._n += len(L)
        low = np.concatenate((self._low, L))
        self._low = np.partition(low, self.k - 1)[: self.k] if len(low) > self.k else low

    def quantile(self) -> float | None:
        if self._n == 0:
            return None
        s = np.sort(self._low)
        pos = self.q * (self._n - 1)
        lo = int(np.floor(pos))
        hi = min(lo + 1, len(s) - 1)
        t = pos - lo
        return float(s[lo] + (s[hi] - s[lo]) * t if t < 0.5 else s[hi] - (s[hi] - s[lo]) * (1 - t))


class _LogHistogram:
    """Median of positive values added in chunks, from a histogram of log10 in 1e-3-decade bins (bounded memory;
    within 0.12 % of the exact median, as ``detectors.stream``'s noise floor)."""

    LO, STEP, N = -8.0, 1e-3, 12_000

    def __init__(self):
        self._hist = np.zeros(self.N, np.int64)

    def add(self, values: np.ndarray) -> None:
        if len(values):
            x = np.log10(np.maximum(values, 1e-300))
            self._hist += np.bincount(np.clip(np.floor((x - self.LO) / self.STEP).astype(np.int64), 0, self.N - 1),
                                      minlength=self.N)

    def median(self) -> float:
        cum = np.cumsum(self._hist)
        k = int(np.searchsorted(cum, 0.5 * cum[-1], side="left"))
        return float(10 ** (self.LO + (k + 0.5) * self.STEP))


class _Runs:
    """The runs of True in a mask pushed in consecutive chunks: ``starts``, the absolute index of the first
    sample of every run, and ``stops(n)``, the index after its last (``core.runs.runs``' stops; a run still
    open at the end of the n samples stops at n)."""

    def __init__(self):
        from bootnav.core.arrays import GrowingRows

        self._starts, self._stops = GrowingRows(1, np.int64), GrowingRows(1, np.int64)  # 16 B per run
        self._prev = False

    def push(self, start: int, mask: np.ndarray) -> None:
        if len(mask):
            mask = np.asarray(mask, bool)
            before = np.concatenate(([self._prev], mask[:-1]))
            self._starts.extend(start + np.flatnonzero(mask & ~before))
            self._stops.extend(start + np.flatnonzero(~mask & before))
            self._prev = bool(mask[-1])

    @property
    def starts(self) -> np.ndarray:
        """The first sample of every run so far (a view)."""
        return self._starts.rows[:, 0]

    def stops(self, n: int) -> np.ndarray:
        return np.concatenate((self._stops.rows[:, 0], [n] if self._prev else [])).astype(np.int64)


class _OnsetInnovations:
    """``selftune.onset_innovations`` of a forward filter's rows pushed in order (``NavRows``: ``zupt`` is the
    mask after the onset delay): |v|² one sample before each ZUPT onset (the first phase, at sample 0, has no
    swing before it), with the onset's sample index."""

    def __init__(self):
        self._k0: list[np.ndarray] = []
        self._e2: list[np.ndarray] = []
        self._prev_zupt = True  # a phase at sample 0 is not an onset
        self._prev_v = np.zeros(3)

    def push(self, r) -> None:
        if not len(r):
            return
        z = np.asarray(r.zupt, bool)
        rise = np.flatnonzero(z & ~np.concatenate(([self._prev_zupt], z[:-1])))
        v_before = np.vstack((self._prev_v[None, :], r.vel_n[:-1]))[rise]
        self._k0.append(r.start + rise)
        self._e2.append(np.sum(v_before**2, axis=1))
        self._prev_zupt, self._prev_v = bool(z[-1]), np.array(r.vel_n[-1], float)

    def mean_square(self, cut: int) -> float:
        """Mean |v|² over the onsets before sample ``cut``, (m/s)²; inf without one."""
        k0 = np.concatenate(self._k0) if self._k0 else np.zeros(0, np.int64)
        e2 = np.concatenate(self._e2) if self._e2 else np.zeros(0)
        e2 = e2[k0 < cut]
        return float(np.mean(e2)) if len(e2) else float("inf")


def _probe_cut(starts: np.ndarray, n: int, fp_probe: dict, max_level_strides: int | None) -> int:
    """The samples ``selftune.level_timing_offset`` probes: whole stance phases, the first 2K + 1, doubled while
    either probe has fewer than K level strides in them, up to the whole record (its docstring); n = all."""
    from . import selftune

    if max_level_strides is None:
        return n
    phases = 2 * max_level_strides + 1
    while phases < len(starts):
        n_level = min(selftune.footprint_level_dz(t[:phases], fp[:phases], max_level_strides=max_level_strides)[1]
                      for t, fp in fp_probe.values())
        if n_level >= max_level_strides:
            return int(starts[phases])
        phases *= 2
    return n


class _ForwardProbes:
    """The forward filter runs of pass 2 (the timing calibration's two probes at ±δ, keyed -1 and 1, or the one
    run at 0 that scores the path), pushed chunk by chunk side by side in two threads (the kernel releases the
    GIL), and no further than the samples ``selftune.level_timing_offset`` reads: once both probes have emitted
    the rows before ``starts[2K + 1]`` (doubled as ``_probe_cut`` doubles it) with K level strides each there,
    the rest of the record changes none of their figures (the first K level strides, the onsets before the
    cut), so they stop: a long recording costs the probes of its first part, as in ``process``."""

    def __init__(self, navs: dict, probe_s: float, max_level_strides: int | None):
        import os

        from .strides import FootprintAccumulator

        self.navs = navs
        self.probe_s = probe_s
        self.k = max_level_strides
        self.fps = {s: FootprintAccumulator() for s in navs}
        self.onsets = {s: _OnsetInnovations() for s in navs}
        self.done = {s: 0 for s in navs}  # samples emitted by each run
        self.cut: int | None = None  # found: the runs stopped
        self._phases = None if max_level_strides is None else 2 * max_level_strides + 1
        self._pool = None
        if len(navs) > 1 and (os.cpu_count() or 1) > 1:
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(max_workers=2)

    PIECE = 1 << 13  # samples pushed between two looks for the cut (41 s at 200 Hz)

    def _push(self, s: int, ch, a: int, b: int):
        from . import selftune

        acc, gyro = ch.acc_b[a:b], ch.gyro_b[a:b]
        f_rot = selftune.rotate_specific_force(acc, gyro, s * self.probe_s) if s else acc
        return self.navs[s].push(ch.t_s[a:b], f_rot, gyro, ch.stance[a:b], ch.saturated[a:b])

    def _keep(self, s: int, r) -> None:
        self.fps[s].push(r.t_s, r.pos_n, r.stance)
        self.onsets[s].push(r)
        self.done[s] = r.start + len(r)

    def push(self, ch, starts: np.ndarray) -> None:
        """Push a stance chunk (``starts``: the stance phases' first samples so far, this chunk's included)."""
        step = self.PIECE if self._phases is not None else max(len(ch.t_s), 1)
        for a in range(0, len(ch.t_s), step):
            if self.cut is not None:
                return
            b = min(a + step, len(ch.t_s))
            signs = list(self.navs)
            rows = (self._pool.map(lambda s: self._push(s, ch, a, b), signs) if self._pool is not None
                    else [self._push(s, ch, a, b) for s in signs])
            for s, r in zip(signs, rows):
                self._keep(s, r)
            self._look(starts)

    def _look(self, starts: np.ndarray) -> None:
        """``_probe_cut`` on the rows so far: stop the runs once it is decided."""
        from . import selftune

        while self._phases is not None and self._phases < len(starts):
            c = int(starts[self._phases])
            if min(self.done.values()) < c:
                return
            n_level = min(selftune.footprint_level_dz(fp.t_mid[:self._phases], fp.fp[:self._phases],
                                                      max_level_strides=self.k)[1] for fp in self.fps.values())
            if n_level >= self.k:
                self.cut = c
                self.navs = {}
                self._close()
                return
            self._phases *= 2

    def finish(self, starts: np.ndarray, n: int) -> tuple[dict, int, dict]:
        """({sign: (mid times, footprints)}, the probes' cut, {sign: _OnsetInnovations}) after the last chunk."""
        self._close()
        for s, nav in self.navs.items():
            self._keep(s, nav.finish())
        fp = {s: acc.finish() for s, acc in self.fps.items()}
        cut = self.cut if self.cut is not None else _probe_cut(starts, n, fp, self.k)
        return fp, cut, self.onsets

    def _close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None


class _RowQueue:
    """Per-sample rows pushed in order by absolute index and taken back in order (bounded memory: what was
    put and not yet taken)."""

    def __init__(self):
        self._parts: list[tuple[int, np.ndarray]] = []

    def put(self, start: int, rows: np.ndarray) -> None:
        if len(rows):
            self._parts.append((start, rows))

    def take(self, i0: int, i1: int) -> np.ndarray:
        """Rows i0..i1-1 (put before); everything before i1 is dropped."""
        out = []
        while self._parts and i0 < i1:
            start, rows = self._parts[0]
            a, b = i0 - start, min(i1 - start, len(rows))
            out.append(rows[a:b])
            i0 = start + b
            if b == len(rows):
                self._parts.pop(0)
            else:
                self._parts[0] = (start + b, rows[b:])
        return np.concatenate(out) if len(out) != 1 else out[0]


def _utc_now() -> str:
    import datetime as _dt

    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")

