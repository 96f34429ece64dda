"""``bootnav process INPUT --out DIR``: reconstruct the walked 3-D path and write every output.

Settings: defaults < ``--settings FILE.json`` (a full or partial ProcessSettings dict) < the options given
on the command line. The settings actually used are saved in summary.json and the HDF5 results group.

Nothing the user gave is modified unless asked: results go to ``DIR/results.h5``; ``--into-recording``
writes them into the input recording atomically (``outputs``). Before any processing, every output is
checked: none may be an input (even with ``--force``), none may exist already (unless ``--force``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time


def _floats(text: str) -> tuple[float, ...]:
    try:
        vals = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LAT,LON[,H] numbers, got {text!r}") from None
    if len(vals) not in (2, 3):
        raise argparse.ArgumentTypeError(f"expected LAT,LON[,H], got {len(vals)} numbers")
    if not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"expected finite numbers LAT,LON[,H], got {text!r} (a NaN or infinite "
                                         "coordinate would be written into the GeoJSON)")
    return vals


class _DetectorNames:
    """The stance-detector registry's names as argparse ``choices``, imported on first use: building the
    parser must not import numpy (``bootnav --help`` builds every subcommand's parser)."""

    def _names(self) -> list[str]:
        from bootnav.postproc.detectors import DETECTORS

        return sorted(DETECTORS)

    def __contains__(self, name) -> bool:
        return name in self._names()

    def __iter__(self):
        return iter(self._names())


class _ListDetectors(argparse.Action):
    """``--list-detectors``: print each registered stance detector with its one-line description, exit 0
    (like ``--version``, before the required arguments are checked)."""

    def __init__(self, option_strings, dest, help=None):
        super().__init__(option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        from bootnav.postproc.detectors import DETECTORS, DetectorSettings

        default = DetectorSettings().method
        for name in sorted(DETECTORS):
            print(f"{name:<13} {DETECTORS[name].description()}{'  (default)' if name == default else ''}")
        parser.exit(0)


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The options of ``bootnav process`` (each maps onto a ``ProcessSettings`` field, see ``build_settings``)."""
    p.add_argument("input", metavar="INPUT", nargs="+",
                   help="recording (.h5) or any file `bootnav import` reads (e.g. a canonical imu.csv.gz); "
                        "several inputs are processed in parallel, each into DIR/<name>/")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output directory (created): CSVs, summary.json, plots and results.h5 (a copy of the "
                        "recording with /results); the input is never modified")
    p.add_argument("--into-recording", action="store_true",
                   help="write /results/NAME into the input HDF5 recording itself instead of DIR/results.h5 "
                        "(atomically: a copy is written, flushed and renamed over the original)")
    p.add_argument("--force", action="store_true",
                   help="overwrite existing output files (and an existing /results/NAME with --into-recording); "
                        "an input is never overwritten")
    p.add_argument("--jobs", type=int, metavar="N", help="parallel processes for several inputs (default: all cores)")
    p.add_argument("--block-s", "--chunk-s", dest="block_s", type=float, metavar="S",
                   help="seconds of samples held in memory at once (settings block_s, default 900): a longer "
                        "recording runs as passes over blocks of S s, memory bounded by the block "
                        "(docs/long-recordings.md); --chunk-s is its old name")
    p.add_argument("--memory-limit", type=float, metavar="MB", help=argparse.SUPPRESS)  # deprecated: --block-s
    p.add_argument("--settings", metavar="FILE.json", help="ProcessSettings as JSON (full or partial)")
    p.add_argument("--save-settings", metavar="FILE.json", help="write the effective settings to this file")
    g = p.add_argument_group("algorithm")
    g.add_argument("--detector", choices=_DetectorNames(), metavar="NAME",
                   help="stance detector: %(choices)s (default: adaptive; --list-detectors describes them)")
    g.add_argument("--list-detectors", action=_ListDetectors, help="list the stance detectors and exit")
    g.add_argument("--threshold", type=float,
                   help="threshold of a fixed-threshold detector in its statistic's units, dimensionless for shoe "
                        "(shoe, ared, mv, mag, xio, paper_accmag, shoe-literal; default: the detector's own); an "
                        "error with the default adaptive detector, which reads its own threshold off the recording")
    g.add_argument("--mode", choices=("time_varying", "riccati"),
                   help="filter gain: time_varying (Kalman, default) or riccati (the paper's steady-state gain)")
    g.add_argument("--states", type=int, choices=(9, 15), help="error states: 9 (position, velocity, attitude) or 15 (+ sensor biases); "
                        "default: FilterSettings.n_states")
    g.add_argument("--engine", choices=("fast", "reference"), help="fast (numba, default) or reference (filterpy)")
    g.add_argument("--no-smoother", action="store_true", help="forward filter only (no RTS smoothing)")
    g.add_argument("--latitude", type=float, metavar="DEG", help="latitude for WGS-84 normal gravity, deg (default 45)")
    g.add_argument("--height", type=float, metavar="M", help="ellipsoidal height for normal gravity, m (default 0)")
    g.add_argument("--gravity", type=float, metavar="MPS2", help="gravity in m/s^2 (overrides latitude/height; default: WGS-84 "
                                                                   "normal gravity there)")
    add_calibration_arguments(g)
    w = p.add_argument_group("data and outputs")
    w.add_argument("--crop", nargs=2, type=float, metavar=("T0", "T1"), help="process only T0..T1 s of the recording's clock (default: all)")
    w.add_argument("--floor-height", type=float, metavar="M", help="storey height for floor counting, m (default 3)")
    w.add_argument("--stair-min-dz", type=float, metavar="M",
                   help="floors are counted from stair strides only, |dz| >= M per stride (default 0.1 m): "
                        "immune to slow vertical drift, but a gentle ramp never counts")
    w.add_argument("--floors-from-height", action="store_true",
                   help="count floors from the footprint height itself (ramps count; drift counts too)")
    w.add_argument("--reference", metavar="FILE",
                   help="reference path: CSV (t_s,x_m,y_m[,z_m] or x_m,y_m[,z_m]) or JSON "
                        "({\"closed_loop\": true} / {\"straight_m\": 9} / {\"waypoints\": [...]}), "
                        "or such a JSON object inline, or 'truth' (a simulated recording's /truth); see docs/metrics.md")
    w.add_argument("--closed-loop", action="store_true", help="the walk ends where it started (closure metrics)")
    w.add_argument("--geo-anchor", type=_floats, metavar="LAT,LON[,H]",
                   help="WGS-84 position of the start: writes path.geojson (not written without it)")
    w.add_argument("--results-name", metavar="NAME", help="HDF5 results group /results/NAME (default 'default')")
    w.add_argument("--no-hdf5", action="store_true", help="do not write results.h5 (nor the results group)")
    w.add_argument("--no-plots", action="store_true", help="skip the PNG charts")
    from bootnav.postproc.twoboots.cli import add_arguments as add_two_boot_arguments

    add_two_boot_arguments(p)


def add_calibration_arguments(g) -> None:
    """``--calibration FILE`` / ``--no-calibration`` / ``--accel-calibration FILE`` (every command that reads a
    recording; ``calibration.resolve_calibration`` decides what applies)."""
    c = g.add_mutually_exclusive_group()
    c.add_argument("--calibration", metavar="FILE.json",
                   help="sensor calibration file (`bootnav calibrate`); default: the stored calibration of the "
                        "recording's device id, if any (store: $BOOTNAV_CALIBRATION_DIR or "
                        "~/.local/share/bootnav/calibrations)")
    c.add_argument("--no-calibration", action="store_true", help="apply no sensor calibration, not even a stored one")
    c.add_argument("--accel-calibration", metavar="FILE.json",
                   help="older accelerometer-only file: bias + 3x3 matrix (JSON); same as --calibration")


def apply_calibration_arguments(args, cal) -> None:
    """Put the calibration flags into ``CalibrationSettings`` ``cal`` (the choice is saved with the results)."""
    if getattr(args, "no_calibration", False):
        cal.sensor_calibration, cal.accel_calibration_file = "none", None
    elif getattr(args, "calibration", None):
        cal.sensor_calibration, cal.accel_calibration_file = args.calibration, None
    elif getattr(args, "accel_calibration", None):
        cal.accel_calibration_file = args.accel_calibration


#: Flags that contradict each other: (flag, attribute, flags, attributes, why the second would be ignored).
CONTRADICTIONS = (
    ("--gravity", "gravity", ("--latitude", "--height"), ("latitude", "height"),
     "--gravity fixes g; --latitude and --height only choose the WGS-84 normal gravity: give one or the other"),
    ("--floors-from-height", "floors_from_height", ("--stair-min-dz",), ("stair_min_dz",),
     "--floors-from-height counts floors from the height itself, without stair strides: drop --stair-min-dz"),
    ("--reference", "reference", ("--closed-loop",), ("closed_loop",),
     'a closed loop is a reference of its own (--reference \'{"closed_loop": true}\'): give one of them'),
    ("--no-hdf5", "no_hdf5", ("--into-recording", "--results-name"), ("into_recording", "results_name"),
     "with --no-hdf5 no results group is written: drop the HDF5 options or --no-hdf5"),
)


def _given(args, attr: str) -> bool:
    value = getattr(args, attr, None)
    return value is not None and value is not False


def check_flag_combinations(args) -> None:
    """A flag that another flag makes meaningless is refused (one line naming both), never silently ignored."""
    from bootnav.errors import InputError

    for flag, attr, others, other_attrs, why in CONTRADICTIONS:
        if _given(args, attr):
            for other, other_attr in zip(others, other_attrs):
                if _given(args, other_attr):
                    raise InputError(f"{flag} with {other}: {why}")


def build_settings(args):
    """Defaults < --settings file < command-line options."""
    from bootnav.errors import InputError
    from bootnav.postproc.settings import ProcessSettings

    check_flag_combinations(args)
    s = ProcessSettings.from_file(args.settings) if args.settings else ProcessSettings()
    if args.detector:  # argparse checked the name
        s.detector = s.detector.with_method(args.detector)
    if args.threshold is not None:  # validated as a file's value is, and refused by a detector without one
        try:
            s.detector = s.detector.with_params(threshold=args.threshold)
        except ValueError as exc:
            raise InputError(f"--threshold {args.threshold:g}: {exc}") from None
    if args.mode:
        s.filter.mode = args.mode
    if args.states:
        s.filter.n_states = args.states
    if args.engine:
        s.filter.engine = args.engine
    if args.no_smoother:
        s.filter.smoother = "none"
    if args.latitude is not None:
        s.calibration.latitude_deg = args.latitude
    if args.height is not None:
        s.calibration.height_m = args.height
    if args.gravity is not None:
        s.calibration.gravity_mps2 = args.gravity
    apply_calibration_arguments(args, s.calibration)
    if args.crop:
        s.crop_s = tuple(args.crop)
    if args.block_s is not None:
        s.block_s = args.block_s
    if getattr(args, "memory_limit", None) is not None:
        print("bootnav process: warning: --memory-limit is deprecated and ignored: memory is bounded by the block "
              "length (--block-s, settings block_s)", file=sys.stderr)
    if args.floor_height is not None:
        s.floor_height_m = args.floor_height
    if args.stair_min_dz is not None:
        s.floor_stair_min_dz_m = args.stair_min_dz
    if args.floors_from_height:
        s.floor_stair_min_dz_m = None
    if args.reference:
        s.reference = args.reference
    elif args.closed_loop:
        s.reference = '{"closed_loop": true}'
    if args.geo_anchor:
        s.output.geo_anchor = args.geo_anchor
    if args.results_name:
        s.output.results_name = args.results_name
    if args.no_hdf5:
        s.output.write_hdf5 = False
    if args.no_plots:
        s.output.plots = False
    # the values the flags set are checked by the code that checks a settings file (types, finite numbers,
    # ranges: ``settings.from_plain``), so a flag is refused exactly as the same value in a file would be, and
    # the settings saved with the results always load again
    try:
        ProcessSettings.from_dict(s.to_dict())
    except InputError as exc:
        raise InputError(f"command line: {exc}") from None
    return s


class StageProgress:
    """The pipeline's ``progress(stage, fraction)`` shown through ``bootnav.core.progress.Progress``: one
    rewritten line on a tty, plain periodic lines (no carriage returns) when stderr is a log or a pipe.

    Parameters
    ----------
    quiet : bool
        Show nothing.
    """

    def __init__(self, quiet: bool = False, stream=None):
        from bootnav.core.progress import Progress

        self.shown = Progress(stream, quiet=quiet)
        self.t0 = time.perf_counter()
        self._compiling_said = False

    def __call__(self, stage: str, fraction: float) -> None:
        if fraction >= 1.0:  # a stage boundary always shows (a handful per run)
            self.shown.update(f"bootnav process: {stage} done ({time.perf_counter() - self.t0:.1f} s)", force=True)
        else:
            self.shown.update(f"bootnav process: {stage} {100 * fraction:3.0f} %")

    def compiling(self) -> None:
        """numba compiles kernels (a first run on this machine: the CSV writer's, then the filter's): say so
        once, it takes seconds (about 40 s in all on a 2-core machine)."""
        if self._compiling_said:
            return
        self._compiling_said = True
        self.shown.update("bootnav process: compiling numerical kernels, about 40 s (first run on this machine "
                          "only)", force=True)

    def done(self) -> None:
        """Clear the tty line before the report is printed."""
        self.shown.done()


def format_summary(summary: dict, files: dict) -> str:
    """The human-readable report printed after one run.

    Parameters
    ----------
    summary
        ``ProcessResult.summary`` (``summary.build_summary``).
    files
        What ``outputs.write_outputs`` wrote (name -> path).

    Returns
    -------
    str
        One line per figure (input, stance, strides, closure, height, reference metrics, timings), the
        warnings, and the files.
    """
    p = summary.get("path", {})
    lines = [
        f"input        {summary['input']['source']}  ({summary['input']['samples_processed']} samples, "
        f"{summary['input']['duration_s']:.1f} s at {summary['input']['rate_hz']:.0f} Hz)",
        f"stance       {summary['stance']['method']}: {summary['stance']['phases']} phases, "
        f"{100 * summary['stance']['fraction']:.0f} % of samples",
        f"strides      {p.get('strides', 0)}, distance {p.get('distance_m', 0):.2f} m (horizontal)",
    ]
    from bootnav.postproc.summary import endpoint_label

    m = summary.get("metrics")
    if "closure_3d_m" in p:
        label = f"{endpoint_label(summary):<12}"
        note = "; the error when the walk ends where it started" if summary.get("closed_loop") else ""
        lines.append(f"{label} {p['closure_3d_m']:.3f} m = {p['closure_pct']:.2f} % of distance "
                     f"(horizontal {p['closure_h_m']:.3f} m, vertical {p['closure_v_m']:.3f} m{note})")
        lines.append(f"height       {p['height_change_m']:+.2f} m net; floors climbed {p['floors_climbed']}, "
                     f"descended {p['floors_descended']} (floor height {p['floor_height_m']:g} m)")
    if m and "stride_mae_m" in m:
        lines.append(f"strides ref  {m['strides_ref']} reference strides (foot {m['stride_foot']}): stride length "
                     f"MAE {m['stride_mae_m']:.3f} m ({m['stride_mae_pct']:.1f} %), bias {m['stride_bias_m']:+.3f} m; "
                     f"distance error {m['distance_error_pct']:.2f} % ({m['distance_error_m']:.3f} m)")
    elif m and "distance_error_pct" in m:
        lines.append(f"end point    {m['final_error_m']:.3f} m from the reference's end")
        lines.append(f"reference    distance error {m['distance_error_pct']:.2f} % ({m['distance_error_m']:.3f} m), "
                     f"deviation {m['deviation_error_pct']:.2f} % ({m['deviation_error_m']:.3f} m), "
                     f"height {m['height_error_pct']:.2f} % ({m['height_error_m']:.3f} m)")
    t = summary.get("timings_s", {})
    lines.append("timings      " + ", ".join(f"{k} {v:.2f} s" for k, v in t.items()))
    for w in summary.get("warnings", []):
        lines.append(f"warning      {w}")
    lines.append("files")
    lines += [f"  {k:<22} {v}" for k, v in files.items()]
    return "\n".join(lines)


def _one(input_path: str, settings, out_dir: str, progress, into_recording: bool = False,
         force: bool = False) -> tuple[dict, dict]:
    from bootnav.postproc.pipeline import process_to

    return process_to(input_path, settings, out_dir, force, progress, into_recording)


def _batch_job(job) -> tuple[str, dict | None, dict | None, str | None]:
    from bootnav.errors import BootnavError

    input_path, settings_dict, out_dir, into_recording, force = job
    from bootnav.postproc.settings import ProcessSettings

    try:
        summary, files = _one(input_path, ProcessSettings.from_dict(settings_dict), out_dir, None, into_recording,
                              force)
        return input_path, summary, files, None
    except BootnavError as exc:  # one bad file must not stop the batch; reported at the end
        return input_path, None, None, str(exc)


def stop_workers(pool, grace_s: float = 10.0) -> None:
    """Cancel what a process pool has not started and send SIGTERM to its workers: each removes its unfinished
    outputs (``bootnav.cli.Stopped``, ``atomic.output_set``); a worker still alive after ``grace_s`` is killed."""
    import time

    processes = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        if p.is_alive():
            p.terminate()
    t_end = time.monotonic() + grace_s
    for p in processes:
        p.join(max(t_end - time.monotonic(), 0.0))
        if p.is_alive():
            p.kill()


def output_names(inputs: list[str]) -> list[str]:
    """A distinct folder name per input: the file stem, prefixed by parent folders while names collide."""
    from pathlib import Path

    def stem(p: Path) -> str:
        name = p.name
        for suffix in (".gz", ".csv", ".txt", ".h5", ".hdf5"):
            name = name[: -len(suffix)] if name.endswith(suffix) else name
        return name

    paths = [Path(i).resolve() for i in inputs]
    depth = 0
    while True:
        names = ["_".join([*(q.name for q in reversed(list(p.parents)[:depth])), stem(p)]) for p in paths]
        if len(set(names)) == len(names) or depth > 8:
            return names
        depth += 1


def _is_file(text) -> bool:
    """``--reference`` names a file (not 'truth', not an inline JSON object)."""
    from pathlib import Path

    try:
        return bool(text) and Path(text).is_file()
    except (OSError, ValueError):
        return False


def _check_save_settings(args, others) -> None:
    """``--save-settings FILE``: never an input, never an existing file without ``--force``."""
    from pathlib import Path

    from bootnav.core.paths import output_file

    output_file(Path(args.save_settings), force=args.force, inputs=[*args.input, *others], flag="--save-settings")


def run(args) -> int:
    """Process one input (report on stdout) or several in parallel (one line each); exit code 1 if any failed.

    The garbage collector waits while the numerics are imported, then ignores what they made (``imports_done``);
    it is as before when this returns."""
    import gc

    enabled, frozen = gc.isenabled(), gc.get_freeze_count()
    gc.disable()
    try:
        return _run(args)
    finally:
        if not frozen:  # main() called from Python: the objects frozen here are collectable again
            gc.unfreeze()
        if enabled:
            gc.enable()


def imports_done() -> None:
    """Called by ``run`` once the numerics are imported and loaded: the objects made so far (numba's and scipy's,
    ~100 k, kept to the end) are frozen and the collector runs again. Collecting during the imports walked them in
    two full collections and never found garbage (0.1 s of CPU); frozen, the run's collections walk only its own."""
    import gc

    gc.freeze()
    gc.enable()


def _run(args) -> int:
    import os
    from pathlib import Path

    from bootnav.errors import InputError
    from bootnav.postproc.outputs import check_outputs
    from bootnav.postproc.summary import endpoint_label

    from bootnav.core.limits import check_jobs

    check_jobs("--jobs", args.jobs)
    settings = build_settings(args)
    from bootnav.postproc.twoboots import cli as two_boots

    if two_boots.wanted(args):
        if args.into_recording:
            raise InputError("--into-recording: a two-boot run writes its own folder (two_boots.json, left/, right/); "
                             "drop the option")
        imports_done()
        return two_boots.run(args, settings, StageProgress(quiet=args.quiet))
    two_boots.refuse_two_boot_flags(args)
    outs = [args.out] if len(args.input) == 1 else [str(Path(args.out) / n) for n in output_names(args.input)]
    others = [settings.reference if _is_file(settings.reference) else None, args.settings, args.accel_calibration,
              args.calibration]
    if len(args.input) > 1 and Path(args.out).exists() and not Path(args.out).is_dir():
        raise InputError(f"--out {args.out} is an existing file, not a directory")
    for i, o in zip(args.input, outs):  # every refusal before any work (module docstring)
        check_outputs(settings, o, [i, *args.input, *others], args.into_recording, args.force)
    if args.save_settings:
        _check_save_settings(args, others)
        settings.save(args.save_settings)
    if len(args.input) == 1:
        progress = StageProgress(quiet=args.quiet)
        from bootnav.postproc.ins.fast import compile_notice
        from bootnav.postproc.outputs import warm_csv_writer

        from bootnav.postproc.pipeline import process_to  # noqa: F401  (imported before the collector runs again)

        try:
            with compile_notice(progress.compiling):
                warm_csv_writer(progress.compiling)
                imports_done()
                summary, files = _one(args.input[0], settings, args.out, progress, args.into_recording, args.force)
        finally:
            progress.done()
        print(format_summary(summary, files))
        return 0
    from concurrent.futures import ProcessPoolExecutor, as_completed

    imports_done()
    jobs = [(i, settings.to_dict(), o, args.into_recording, args.force) for i, o in zip(args.input, outs)]
    failed = 0
    with ProcessPoolExecutor(max_workers=args.jobs or os.cpu_count() or 1) as pool:
        try:
            for fut in as_completed([pool.submit(_batch_job, j) for j in jobs]):
                input_path, summary, files, error = fut.result()
                if error:
                    failed += 1
                    print(f"bootnav process: error: {error}", file=sys.stderr)
                    continue
                p = summary["path"]
                print(f"{input_path}: {p.get('distance_m', 0):.2f} m, {endpoint_label(summary)} "
                      f"{p.get('closure_3d_m', float('nan')):.3f} m -> {Path(files['summary']).parent}")
        except BaseException:  # Ctrl-C, SIGTERM: stop the workers (they clean up like this process), then exit
            stop_workers(pool)
            raise
    print(f"{len(jobs) - failed} of {len(jobs)} inputs processed into {args.out}")
    return 1 if failed else 0
