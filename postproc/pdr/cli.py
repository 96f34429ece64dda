"""``bootnav pdr INPUT [--detector NAME] [--length NAME] [--heading NAME] [--height M]
[--start LAT,LON] --out DIR``: step-and-heading dead reckoning.

Writes steps.csv (t_s,length_m,heading_rad,x_m,y_m), path_local.csv, path_latlon.csv (with --start),
summary.json (counts, distance, settings) and plots (bootnav.postproc.pdr.plots)."""

from __future__ import annotations

DETECTOR_NAMES = ["robust", "peak_valley", "zero_crossing", "pan_tompkins", "template", "two_axis", "footpath",
                  "leppakoski", "li", "peak_group"]
LENGTH_NAMES = ["frequency_variance", "renaudin", "weinberg", "ladetto", "footpath", "constant", "frequency"]
HEADING_NAMES = ["auto", "none", "gyro", "mag", "complementary", "compass"]


def add_arguments(parser) -> None:
    parser.add_argument("input", help="acc.csv.gz / imu.csv.gz, an HDF5 recording, or a file bootnav.logger.importers reads")
    parser.add_argument("--detector", default="robust", choices=DETECTOR_NAMES)
    parser.add_argument("--length", default="frequency_variance", choices=LENGTH_NAMES, help="step-length model")
    parser.add_argument("--heading", default="auto", choices=HEADING_NAMES)
    parser.add_argument("--height", type=float, default=None, metavar="M", help="walker height, m (default 1.83)")
    parser.add_argument("--engineered", action="store_true",
                        help="seed methods with literal=False (engineered fixes) instead of their literal form")
    parser.add_argument("--declination", type=float, default=0.0, metavar="DEG", help="east positive")
    parser.add_argument("--start", default=None, metavar="LAT,LON", help="start point for the lat/lon path")
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--out", required=True, metavar="DIR")


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


def run(args) -> int:
    import json
    import time
    from pathlib import Path

    import numpy as np

    from bootnav.postproc.pdr.detectors import DETECTORS
    from bootnav.postproc.pdr.io import load_input
    from bootnav.postproc.pdr.pipeline import PdrSettings, run_pdr

    t0 = time.perf_counter()
    inp = load_input(args.input)
    params = {}
    if args.engineered and "literal" in DETECTORS[args.detector].__dataclass_fields__:
        params["literal"] = False
    settings = PdrSettings(detector=args.detector, detector_params=params, length=args.length,
                           height_m=args.height, heading=args.heading, declination_deg=args.declination,
                           start_lat_lon=_parse_start(args.start))
    res = run_pdr(inp.t_s, inp.acc_b, inp.gyro_b, settings, mag_b=inp.mag_b, compass_deg=inp.compass_deg)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = np.column_stack([res.t_s, res.length_m, res.heading_rad, res.x_m, res.y_m])
    np.savetxt(out / "steps.csv", table, delimiter=",", fmt="%.6f", header="t_s,length_m,heading_rad,x_m,y_m",
               comments="")
    np.savetxt(out / "path_local.csv", np.column_stack([np.r_[res.t_s[:1] if res.count else [], res.t_s],
                                                        np.r_[[0.0] if res.count else [], res.x_m],
                                                        np.r_[[0.0] if res.count else [], res.y_m]]),
               delimiter=",", fmt="%.6f", header="t_s,x_m,y_m", comments="")
    if res.lat_deg is not None:
        np.savetxt(out / "path_latlon.csv", np.column_stack([res.t_s, res.lat_deg, res.lon_deg]), delimiter=",",
                   fmt=["%.6f", "%.9f", "%.9f"], header="t_s,lat_deg,lon_deg", comments="")
    summary = res.summary()
    summary.update({"input": inp.source, "input_kind": inp.kind, "n_samples": int(len(inp.t_s)),
                    "has_gyro": inp.gyro_b is not None, "has_mag": inp.mag_b is not None,
                    "has_compass": inp.compass_deg is not None,
                    "detector_params": DETECTORS[args.detector](**params).to_dict(),
                    "runtime_s": time.perf_counter() - t0})
    if not args.no_plots:
        from bootnav.postproc.pdr.plots import write_plots

        summary["plots"] = [p.name for p in write_plots(res, out)]
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    print(f"{res.count} steps, {summary['distance_m']:.1f} m, heading from {res.heading_source} -> {out}")
    return 0
