"""``bootnav pdr INPUT [options] --out DIR``: step-and-heading dead reckoning.

Settings: defaults < ``--settings FILE.json`` (a full or partial ``PdrSettings`` dict, or a summary.json of
an earlier run) < the options given on the command line; ``--save-settings`` writes the effective ones.
Every detector and step-length parameter is reachable with ``--detector-param NAME=VALUE`` /
``--length-param NAME=VALUE`` (names: the dataclass fields, listed in summary.json "detector_params" /
"settings"); the common ones have their own flags, and ``--set NAME=VALUE`` reaches any other field of
``PdrSettings``. Every setting is checked before any work (``PdrSettings.validate``: unknown keys, wrong
types, negative durations, named by their key path).

Writes steps.csv (t_s,length_m,yaw_enu_rad,heading_deg_cw_from_north,x_m,y_m; headings as
``bootnav.CONVENTIONS["heading"]``), path_local.csv, path_latlon.csv (with --start or GPS), gps.csv (with GPS),
summary.json (counts, distance, settings, conventions, GPS and checkpoint comparisons) and plots
(bootnav.postproc.pdr.plots). No existing file is overwritten without ``--force`` and none may be an input;
each file is written to a temporary name and renamed (an interrupted run leaves no half-written file)."""

from __future__ import annotations

from bootnav.core import atomic

DETECTOR_NAMES = ["robust", "peak_valley", "zero_crossing", "pan_tompkins", "template", "two_axis", "footpath",
                  "leppakoski", "li", "peak_group"]
LENGTH_NAMES = ["frequency_variance", "renaudin", "weinberg", "ladetto", "footpath", "constant", "frequency"]
HEADING_NAMES = ["auto", "none", "gyro", "mag", "complementary", "compass"]
MAG_TILT_NAMES = ["gravity", "weights", "none"]
MAG_CAL_NAMES = ["none", "percentile", "percentile_literal", "ellipse", "ellipsoid"]


def add_arguments(parser) -> None:
    parser.add_argument("input", help="acc.csv.gz / imu.csv.gz, an HDF5 recording, or a file bootnav.logger.importers reads")
    parser.add_argument("--settings", metavar="FILE.json", help="PdrSettings as JSON (full or partial, or a summary.json)")
    parser.add_argument("--save-settings", metavar="FILE.json", help="write the effective settings to this file")
    from bootnav.postproc.cli_process import add_calibration_arguments

    add_calibration_arguments(parser)
    parser.add_argument("--detector", default=None, choices=DETECTOR_NAMES, help="step detector (default robust)")
    parser.add_argument("--detector-param", action="append", default=[], metavar="NAME=VALUE",
                        help="a detector parameter (repeatable), e.g. min_distance_s=0.3 or literal=false")
    parser.add_argument("--engineered", action="store_true",
                        help="source methods with literal=False (engineered fixes) instead of their literal form")
    parser.add_argument("--length", default=None, choices=LENGTH_NAMES,
                        help="step-length model (default frequency_variance)")
    parser.add_argument("--length-param", action="append", default=[], metavar="NAME=VALUE",
                        help="a step-length model parameter (repeatable), e.g. k=0.55")
    parser.add_argument("--weinberg-k", type=float, default=None, metavar="K",
                        help="= --length weinberg --length-param k=K, dimensionless (0.95 code / 0.55 text of "
                             "NKUA2009; default: the model's own)")
    parser.add_argument("--step-length", type=float, default=None, metavar="M",
                        help="= --length constant --length-param length_m=M, m (default: the model's own)")
    parser.add_argument("--calibrate-length", action="append", default=[], metavar="FILE=METRES",
                        help="fit the length model on a walk of known distance (repeatable: NKUA2009 5.4 uses "
                             "20 m at normal, slow and fast pace)")
    parser.add_argument("--height", type=float, default=None, metavar="M", help="walker height, m (default 1.83)")
    parser.add_argument("--heading", default=None, choices=HEADING_NAMES, help="heading method (default auto)")
    parser.add_argument("--heading0", type=float, default=None, metavar="DEG",
                        help="start bearing, deg clockwise from north (gyro / none)")
    parser.add_argument("--forward-axis", default=None, metavar="X,Y,Z", help="body axis pointing forward (default 0,1,0)")
    parser.add_argument("--complementary-tau", type=float, default=None, metavar="S", help="gyro/mag crossover, s (default 10 s)")
    parser.add_argument("--mag-tilt", default=None, choices=MAG_TILT_NAMES,
                        help="levelling of the magnetometer: gravity (default), weights (NKUA2009 4.2), none "
                             "(level device, Lazarevskiy2021 eq. 3.2)")
    parser.add_argument("--mag-calibration", default=None, choices=MAG_CAL_NAMES,
                        help="magnetometer calibration fitted on the recording (NKUA2009 4.3 percentiles, fits)")
    parser.add_argument("--mag-calibration-window", default=None, metavar="T0,T1",
                        help="fit the calibration on these seconds after the start only (e.g. a turn on the spot)")
    parser.add_argument("--mag-percentiles", default=None, metavar="LO,HI",
                        help="percentiles of the percentile calibrations (default 5,95 as NKUA2009 4.3)")
    parser.add_argument("--gyro-signed-magnitude", action="store_true",
                        help="integrate sgn(w_v)|w| instead of the vertical rate (Lazarevskiy2021 eqs. 2.7-2.8)")
    parser.add_argument("--declination", type=float, default=None, metavar="DEG", help="magnetic declination, deg, east positive (default 0)")
    parser.add_argument("--start", default=None, metavar="LAT,LON", help="start point for the lat/lon path")
    parser.add_argument("--no-gps", action="store_true", help="ignore GPS columns of the input")
    parser.add_argument("--checkpoints", default=None, metavar="FILE.csv",
                        help="true checkpoints t_s,x_m,y_m (m east/north of the start): errors without reset")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", dest="set_fields",
                        help="any other PdrSettings field (repeatable), e.g. compass_window_s=0.4 or "
                             "tilt_weight_window_s=0.4; values read as JSON")
    parser.add_argument("--no-plots", action="store_true", help="write no charts (only the CSV and JSON files)")
    parser.add_argument("--force", action="store_true", help="overwrite existing output files (never an input)")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="output directory (created): steps.csv, summary.json and the charts")


def _parse_start(text):
    from bootnav.errors import InputError

    if text is None:
        return None
    try:
        lat, lon = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--start {text!r}: expected LAT,LON in degrees, e.g. 46.66213,32.63982")
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise InputError(f"--start {text!r}: latitude must be in [-90, 90] and longitude in [-180, 180]")
    return (lat, lon)


def _floats(text, n, flag):
    from bootnav.errors import InputError

    try:
        v = tuple(float(x) for x in text.split(","))
    except ValueError:
        v = ()
    if len(v) != n:
        raise InputError(f"{flag} {text!r}: expected {n} comma-separated numbers")
    return v


def _params(items, cls, flag) -> dict:
    """NAME=VALUE pairs, the value read as JSON (numbers, true/false, null, lists) or else as text; names
    checked against the dataclass fields of ``cls``."""
    import json

    from bootnav.errors import InputError

    known = cls.__dataclass_fields__
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        name = name.strip().replace("-", "_")
        if not sep or not name:
            raise InputError(f"{flag} {item!r}: expected NAME=VALUE")
        if name not in known:
            raise InputError(f"{flag} {name!r}: {cls.__name__} has no such parameter; known: {sorted(known)}")
        try:
            out[name] = json.loads(value)
        except json.JSONDecodeError:
            out[name] = value
    return out


def build_settings(args):
    """Defaults < --settings file < command-line options."""
    from bootnav.errors import InputError
    from bootnav.postproc.pdr.detectors import DETECTORS
    from bootnav.postproc.pdr.length import LENGTH_MODELS
    from bootnav.postproc.pdr.pipeline import PdrSettings

    s = PdrSettings.from_file(args.settings) if args.settings else PdrSettings()
    for name, value in _params(args.set_fields, PdrSettings, "--set").items():
        setattr(s, name, value)
    if getattr(args, "no_calibration", False):
        s.sensor_calibration = "none"
    elif getattr(args, "calibration", None) or getattr(args, "accel_calibration", None):
        s.sensor_calibration = args.calibration or args.accel_calibration
    if args.detector and args.detector != s.detector:
        s.detector, s.detector_params = args.detector, {}
    if s.detector not in DETECTORS:
        raise InputError(f"unknown step detector {s.detector!r}; choose one of {sorted(DETECTORS)}")
    if args.engineered:
        if "literal" not in DETECTORS[s.detector].__dataclass_fields__:
            raise InputError(f"--engineered: step detector {s.detector!r} has no literal form to leave (it is "
                             "engineered already); drop the option")
        s.detector_params["literal"] = False
    s.detector_params.update(_params(args.detector_param, DETECTORS[s.detector], "--detector-param"))
    from bootnav.core.limits import check_range
    from bootnav.core.validate import SETTING_RANGES

    for flag, value, key in (("--step-length", args.step_length, ".length_params.length_m"),
                             ("--weinberg-k", args.weinberg_k, ".length_params.k"), ("--height", args.height, ".height_m")):
        lo, hi, unit, why = SETTING_RANGES[key]  # the settings file's ranges (one definition)
        check_range(flag, value, lo, hi, unit, why=why)
    for flag, value in (("--heading0", args.heading0), ("--declination", args.declination)):
        check_range(flag, value, -360.0, 360.0, "deg")
    check_range("--complementary-tau", args.complementary_tau, 0.0, 3600.0, "s", lo_open=True)
    length = args.length
    for flag, model, key, value in (("--weinberg-k", "weinberg", "k", args.weinberg_k),
                                    ("--step-length", "constant", "length_m", args.step_length)):
        if value is not None:
            if length not in (None, model):
                raise InputError(f"{flag} sets the {model} model; it contradicts --length {length}")
            length = model
            args.length_param = [*args.length_param, f"{key}={value}"]
    if length and length != s.length:
        s.length, s.length_params = length, {}
    if s.length not in LENGTH_MODELS:
        raise InputError(f"unknown step-length model {s.length!r}; choose one of {sorted(LENGTH_MODELS)}")
    s.length_params.update(_params(args.length_param, LENGTH_MODELS[s.length], "--length-param"))
    for attr, value in (("height_m", args.height), ("heading", args.heading), ("heading0_deg", args.heading0),
                        ("complementary_tau_s", args.complementary_tau), ("mag_tilt", args.mag_tilt),
                        ("mag_calibration", args.mag_calibration), ("declination_deg", args.declination)):
        if value is not None:
            setattr(s, attr, value)
    if args.forward_axis:
        s.forward_axis = _floats(args.forward_axis, 3, "--forward-axis")
    if args.mag_calibration_window:
        s.mag_calibration_window_s = _floats(args.mag_calibration_window, 2, "--mag-calibration-window")
    if args.mag_percentiles:
        s.mag_percentiles = _floats(args.mag_percentiles, 2, "--mag-percentiles")
    if args.gyro_signed_magnitude:
        s.gyro_signed_magnitude = True
    if args.start:
        s.start_lat_lon = _parse_start(args.start)
    if args.no_gps:
        s.use_gps = False
    refuse_unused_heading_flags(args, s.heading)
    return s.validate()


#: Heading options and the heading methods that read them ("auto" is gyro, compass or none: never the
#: magnetometer): a flag the chosen method does not read is refused, never silently ignored.
HEADING_FLAG_USERS = (
    ("--heading0", "heading0", {"auto", "none", "gyro"}),
    ("--declination", "declination", {"auto", "compass", "mag", "complementary"}),
    ("--complementary-tau", "complementary_tau", {"complementary"}),
    ("--mag-tilt", "mag_tilt", {"mag", "complementary"}),
    ("--mag-calibration", "mag_calibration", {"mag", "complementary"}),
    ("--mag-calibration-window", "mag_calibration_window", {"mag", "complementary"}),
    ("--mag-percentiles", "mag_percentiles", {"mag", "complementary"}),
    ("--gyro-signed-magnitude", "gyro_signed_magnitude", {"auto", "gyro", "complementary"}),
)


def refuse_unused_heading_flags(args, heading: str) -> None:
    """One line naming a heading flag that the heading method ``heading`` does not read, and who reads it."""
    from bootnav.errors import InputError

    for flag, attr, users in HEADING_FLAG_USERS:
        value = getattr(args, attr, None)
        if value is not None and value is not False and heading not in users:
            raise InputError(f"{flag}: heading {heading!r} does not use it (it is read by --heading "
                             f"{' / '.join(sorted(users - {'auto'}))}); drop the option or choose that heading")


def _calibration_walks(items):
    from bootnav.errors import InputError
    from bootnav.postproc.pdr.io import load_input

    for item in items:
        path, sep, dist = item.rpartition("=")
        try:
            d = float(dist)
        except ValueError:
            d = float("nan")
        if not sep or not path or not d > 0:
            raise InputError(f"--calibrate-length {item!r}: expected FILE=METRES with a positive distance")
        inp = load_input(path)
        yield inp.t_s, inp.acc_b, d


def _checkpoints(path):
    from bootnav.errors import InputError

    import numpy as np

    try:
        a = np.atleast_2d(np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2))
    except (OSError, ValueError) as exc:
        raise InputError(f"--checkpoints {path}: {exc}") from None
    if a.shape[1] != 3 or a.shape[0] < 1:
        raise InputError(f"--checkpoints {path}: expected a header line and rows t_s,x_m,y_m")
    return a.T


OUTPUT_FILES = ("steps.csv", "path_local.csv", "path_latlon.csv", "gps.csv", "summary.json")


def _check_outputs(args) -> None:
    """Before any work: the output folder is not a file, no output (or --save-settings) would replace an
    input, and none exists unless --force."""
    from pathlib import Path

    from bootnav.core.paths import output_file, output_folder
    from bootnav.postproc.pdr.plots import PLOT_FILES

    inputs = [Path(args.input), *(Path(p) for p in [args.settings, args.checkpoints] if p)]
    inputs += [Path(item.rpartition("=")[0]) for item in args.calibrate_length]
    # the one output rule of every command (bootnav.core.paths)
    output_folder(args.out, [*OUTPUT_FILES, *PLOT_FILES], force=args.force, inputs=inputs)
    if args.save_settings:
        output_file(args.save_settings, force=args.force, inputs=inputs, flag="--save-settings")


def _csv(path, columns: dict, fmt="%.6f") -> None:
    import numpy as np

    table = np.column_stack(list(columns.values()))
    atomic.replace_with(path, lambda tmp: np.savetxt(tmp, table, delimiter=",", fmt=fmt, header=",".join(columns),
                                                     comments=""))


def run(args) -> int:
    import json
    import sys
    import time
    from pathlib import Path

    import numpy as np

    from bootnav.core.jsonio import to_jsonable
    from bootnav.errors import InputError
    from bootnav.postproc.outputs import heading_columns
    from bootnav.postproc.pdr.detectors import make_detector
    from bootnav.postproc.pdr.io import load_input
    from bootnav.postproc.pdr.path import checkpoint_report
    from bootnav.postproc.pdr.pipeline import calibrate_length, run_pdr

    t0 = time.perf_counter()
    _check_outputs(args)
    settings = build_settings(args)
    if args.calibrate_length:
        settings.length_params = calibrate_length(settings, _calibration_walks(args.calibrate_length))
    if args.save_settings:
        settings.save(args.save_settings)
    inp = load_input(args.input)
    from bootnav.postproc.pdr.io import calibrated

    inp, sensor_cal = calibrated(inp, settings.sensor_calibration)
    _check_finite(args.input, inp.t_s, inp.acc_b, inp.gyro_b)
    try:
        res = run_pdr(inp.t_s, inp.acc_b, inp.gyro_b, settings, mag_b=inp.mag_b, compass_deg=inp.compass_deg,
                      gps=inp.gps)
    except InputError as exc:
        raise InputError(f"{args.input}: {exc}") from None
    out = Path(args.out)
    from bootnav.postproc.pdr.plots import PLOT_FILES

    with atomic.output_set([out / n for n in (*OUTPUT_FILES, *PLOT_FILES)]):  # all outputs or none
        out.mkdir(parents=True, exist_ok=True)
        _csv(out / "steps.csv", {"t_s": res.t_s, "length_m": res.length_m, **heading_columns(res.yaw_enu_rad),
                                 "x_m": res.x_m, "y_m": res.y_m})
        first = [0.0] if res.count else []
        _csv(out / "path_local.csv", {"t_s": np.r_[res.t_s[:1], res.t_s], "x_m": np.r_[first, res.x_m],
                                      "y_m": np.r_[first, res.y_m]})
        if res.lat_deg is not None:
            _csv(out / "path_latlon.csv", {"t_s": res.t_s, "lat_deg": res.lat_deg, "lon_deg": res.lon_deg},
                 fmt=["%.6f", "%.9f", "%.9f"])
        if res.gps is not None:
            _csv(out / "gps.csv", {k: res.gps[k] for k in ("t_s", "gps_east_m", "gps_north_m", "pdr_east_m",
                                                           "pdr_north_m")})
        summary = res.summary()
        summary.setdefault("warnings", []).extend(sensor_cal.warnings)
        summary.update({"calibration": sensor_cal.provenance, "input": inp.source, "input_kind": inp.kind, "n_samples": int(len(inp.t_s)),
                        "has_gyro": inp.gyro_b is not None, "has_mag": inp.mag_b is not None,
                        "has_compass": inp.compass_deg is not None, "has_gps": inp.gps is not None,
                        "detector_params": make_detector(settings.detector, **settings.detector_params).to_dict(),
                        "start_lat_lon": None if res.start_lat_lon is None else list(res.start_lat_lon)})
        if args.checkpoints:
            summary["checkpoints"] = checkpoint_report(res.t_s, res.x_m, res.y_m, float(inp.t_s[0]),
                                                       *_checkpoints(args.checkpoints))
        if not args.no_plots:
            from bootnav.postproc.pdr.plots import write_plots

            summary["plots"] = [p.name for p in write_plots(res, out)]
        summary["runtime_s"] = time.perf_counter() - t0
        text = json.dumps(to_jsonable(summary), indent=1, allow_nan=False)
        atomic.write_text(out / "summary.json", text)
    msg = f"{res.count} steps, {summary['distance_m']:.1f} m, heading from {res.heading_source}"
    if res.gps is not None:
        msg += f", {res.gps['mean_m']:.1f} m mean / {res.gps['final_m']:.1f} m final from GPS"
    print(f"{msg} -> {out}")
    for w in summary.get("warnings", []):
        print(f"bootnav pdr: warning: {w}", file=sys.stderr)
    return 0


def _check_finite(name, t_s, acc_b, gyro_b) -> None:
    """Refuse NaN/inf samples (they would turn into NaN steps), naming the first one; a gyro that is NaN
    throughout means "no gyroscope" and is allowed (the heading then comes from elsewhere)."""
    import numpy as np

    from bootnav.errors import InputError

    gyro_absent = gyro_b is None or not np.isfinite(gyro_b).any()
    channels = [("time", np.asarray(t_s)[:, None]), ("acc", acc_b)] + ([] if gyro_absent else [("gyro", gyro_b)])
    for what, arr in channels:
        bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
        if bad.size:
            i = int(bad[0])
            raise InputError(f"{name}: {what} of sample {i} (t = {t_s[i]:.6g} s) is not finite ({bad.size} samples); "
                             "repair or crop the file")
