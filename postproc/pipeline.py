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
many, runs the stages above as passes over its blocks (``passes.BlockPasses``; outputs as the former stages on whole
arrays: ``trajectory.csv``/``steps.csv`` byte for byte, ``results.h5`` to 1e-9), each whole-record decision
taken in a pass before the one that needs it, the last pass writing through incremental sinks (``trajectory.csv`` rows,
``outputs.ResultsWriter``, ``plots.ChartStream``). Passes over a single block keep its rows, calibrated and
read-only, and decode it once (a quarter of their time on a one-minute recording, for when one block
takes the passes too); over a single block the final pass also replays the rows of the filter pass before it
when that ran the same filter (the storeys', or the unaided one the heading decision left off), as ``navigate``
runs that filter once. Over many blocks the same is read back from temporary files (``passcache``: each block
decoded once, its rail bits found once, the stance detector run once, the filter rows replayed), within a disk
budget beyond which the passes compute again:

0. the nominal period Δt₀: the median step of the whole record (``passes._nominal_period``: exact order statistics
   from passes over the times, ``passes._order_statistics``), as ``timebase.sample_period`` gives ``process``;
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
6. the mount check: ‖ω‖'s 99th percentile, exact from passes (``passes._percentile``; ``summary.mount_check_of``).

Why passes and not per-block decisions: each decision then equals the one-block run's (to rounding), whatever
the block length (``tests/test_long_chunked.py``). A detector that cannot stream gets the samples of the whole
record and its stance is cut into the chunks the passes push (``detectors.stream.WholeRecordStance``; a warning
says memory grows with the length). The stance fallback runs in passes: when the configured mask fails (after pass 3) or its strides do (after pass 5),
the fallback's candidates (``selftune``'s docstring) are scored by forward runs over the blocks (``passes._CandidateScore``; the
"cycle minimum" from samples spilled to a temporary file, ``passes._cycle_minimum``), the chosen mask replaces the
configured one's (its statistic kept) and passes 3-5 run again.

The whole-array functions of some stages remain as the definitions the passes are tested against
(``detectors.detect_stance``, ``checks.stance_findings``, ``selftune.gait_period``, ``selftune.stride_quality``,
``selftune.level_timing_offset``, ``ins.run_filter``, ``floors.snap_storeys``, ``strides.segment_strides``);
``tests/test_pipeline.py`` composes them and checks that ``process`` gives their result.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from bootnav.core import atomic
from bootnav.logger.recording import Recording

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

    The same block passes as ``bootnav process`` (``passes.BlockPasses``), their final pass keeping its rows in
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
    from . import passes
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
    summary, _ = passes.BlockPasses(run, settings, None, [], lap, None, progress).run()
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
    passes over its blocks (``passes.BlockPasses``), memory bounded by the block. A detector that cannot stream
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
    from . import passes
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
        rows = passes.block_rows(window.times(0, min(window.n, 1 << 16)), settings.block_s)
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
            try:
                run = _Input(window, str(path), path, hdf5, None if src is None else src.recording, into_recording,
                             ref)
                summary, files = passes.BlockPasses(run, settings, out, warnings, _StageClock(progress), worker,
                                                    progress).run()
            except BaseException:  # a failure or a stop signal: the chart processes end before the outputs are
                if worker is not None:  # removed, so none renames a chart into place after the removal
                    worker.close()
                    worker = None
                raise
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
    ``extra`` holds the run's figures (``passes.BlockPasses`` sets it after the final pass)."""

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

    def push(self, rows) -> None:
        """The final pass's rows (``_FinalRows``), as a sink of ``_FinalSinks``."""
        self.push_rows(rows.r, rows.pos_filter, rows.statistic)

    def close(self) -> None:
        """Nothing: the rows stay for ``arrays``."""

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


def _needs_whole_record(settings: ProcessSettings) -> str | None:
    """Why the stance detection of this run needs the whole record (None: it streams), as the passes' warning
    says it (``detectors.stream.WholeRecordStance`` holds the record's samples)."""
    from .detectors.stream import stream_refusal

    why = stream_refusal(settings.detector)
    if why:
        return f"the stance detector '{settings.detector.method}' cannot run block by block ({why})"
    return None
