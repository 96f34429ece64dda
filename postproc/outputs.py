"""Files written by ``bootnav process --out DIR`` (columns and units are part of the public interface).

* ``trajectory.csv``: ``t_s,x_m,y_m,z_m,vx_mps,vy_mps,vz_mps,stance``, one row per processed sample,
  nav frame ENU (x east, y north, z up), origin at the first processed sample; stance 1 = foot at rest.
* ``steps.csv``: ``t_s,x_m,y_m,z_m,stride_length_m,dz_m,yaw_enu_rad,heading_deg_cw_from_north``, one row
  per stride (``bootnav.postproc.strides``): mid time of the stance phase ending the stride, its footprint,
  horizontal length, height change, and direction twice (``heading_columns``, ``bootnav.CONVENTIONS``):
  ``atan2(Δy, Δx)`` counter-clockwise from x (east), and clockwise from y (north) in degrees.
* ``summary.json``: distance, closure, floors, reference metrics, settings, software version, timings,
  conventions, warnings, saturation intervals, and the list of files written.
* ``1_raw_imu.png`` … ``7_height.png`` and ``path.html``: charts 1-7 and the interactive path (``plots``).
* ``path.geojson``: the footprint path. Without an anchor, coordinates are local ENU metres (x, y, z), *not*
  WGS-84 (stated in the collection's properties). With ``geo_anchor = (lat, lon[, h])`` they are WGS-84
  ``[lon, lat, h]`` from a local tangent-plane approximation around the anchor (φ0, λ0, h0)::

      φ = φ0 + y / (M(φ0) + h0),   λ = λ0 + x / ((N(φ0) + h0) cos φ0),   h = h0 + z

  with the WGS-84 meridian radius M = a(1 − e²)/(1 − e² sin²φ0)^{3/2} and prime-vertical radius
  N = a/(1 − e² sin²φ0)^{1/2}. The error grows with the square of the distance: below 1 cm within 1 km,
  far below the drift of any foot-mounted INS.
* ``/results/<name>`` in the HDF5 recording (the input file when it is HDF5; otherwise ``DIR/results.h5``
  = the imported recording + results) with every setting used as group attributes.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from bootnav import CONVENTIONS, __version__
from bootnav.core.jsonio import to_jsonable

from .strides import STEP_COLUMNS, footprints

TRAJECTORY_COLUMNS = ("t_s", "x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "stance")
WGS84_A_M = 6378137.0
WGS84_E2 = 6.69437999014e-3


def _write_csv(path: Path, header: tuple[str, ...], columns: list[np.ndarray], fmts: list[str]) -> None:
    """Write columns fast: one C-level %-format per block of rows (np.savetxt loops per row in Python).
    Rows are stacked block by block, so no full (N, k) copy of the data is ever made."""
    row = ",".join(fmts) + "\n"
    n = len(columns[0])
    with open(path, "w", newline="") as f:
        f.write(",".join(header) + "\n")
        block = 20_000  # rows per format call: bounds the temporary Python floats (~5 MB)
        for i in range(0, n, block):
            chunk = np.column_stack([np.asarray(c[i : i + block], dtype=np.float64) for c in columns])
            f.write((row * len(chunk)) % tuple(chunk.ravel()))


def write_trajectory_csv(path: Path, result) -> Path:
    p, v = result.pos_n, result.vel_n
    _write_csv(path, TRAJECTORY_COLUMNS,
               [result.t_s, p[:, 0], p[:, 1], p[:, 2], v[:, 0], v[:, 1], v[:, 2], result.stance.astype(np.int8)],
               ["%.6f"] + ["%.4f"] * 6 + ["%d"])
    return path


def heading_columns(yaw_enu_rad) -> dict[str, np.ndarray]:
    """The two heading columns of every output with a direction of travel (``bootnav.CONVENTIONS["heading"]``).

    Parameters
    ----------
    yaw_enu_rad : array_like
        Direction of travel, rad, counter-clockwise from east (x) in the ENU frame.

    Returns
    -------
    dict
        ``yaw_enu_rad`` (as given, float) and ``heading_deg_cw_from_north``, the compass reading of the same
        direction: clockwise from north (y), degrees in [0, 360).
    """
    yaw = np.asarray(yaw_enu_rad, float)
    deg = np.mod(90.0 - np.degrees(yaw), 360.0)
    return {"yaw_enu_rad": yaw, "heading_deg_cw_from_north": np.where(deg >= 360.0, 0.0, deg)}


def write_steps_csv(path: Path, steps: dict) -> Path:
    """steps.csv: ``STEP_COLUMNS``, both heading columns and, when present, ``quality_flags`` (bitmask of
    ``selftune.FLAG_NAMES``; 0 = plausible)."""
    columns = {**{c: np.asarray(steps[c]) for c in STEP_COLUMNS}, **heading_columns(steps["yaw_enu_rad"])}
    fmts = ["%.6f", "%.4f", "%.4f", "%.4f", "%.4f", "%.4f", "%.5f", "%.3f"]
    if "quality_flags" in steps:
        columns["quality_flags"] = np.asarray(steps["quality_flags"])
        fmts.append("%d")
    _write_csv(path, tuple(columns), list(columns.values()), fmts)
    return path


def enu_to_wgs84(xyz_m: np.ndarray, anchor) -> np.ndarray:
    """(K, 3) local ENU metres -> (K, 3) [lon_deg, lat_deg, h_m] (tangent-plane approximation, see docstring)."""
    lat0, lon0 = float(anchor[0]), float(anchor[1])
    h0 = float(anchor[2]) if len(anchor) > 2 else 0.0
    if not (-90 < lat0 < 90 and -180 <= lon0 <= 180):
        raise ValueError(f"geo anchor ({lat0}, {lon0}) out of range (lat in (-90, 90), lon in [-180, 180])")
    s2 = math.sin(math.radians(lat0)) ** 2
    m = WGS84_A_M * (1 - WGS84_E2) / (1 - WGS84_E2 * s2) ** 1.5
    n = WGS84_A_M / math.sqrt(1 - WGS84_E2 * s2)
    xyz = np.asarray(xyz_m, float)
    lat = lat0 + np.degrees(xyz[:, 1] / (m + h0))
    lon = lon0 + np.degrees(xyz[:, 0] / ((n + h0) * math.cos(math.radians(lat0))))
    return np.column_stack((lon, lat, h0 + xyz[:, 2]))


def geojson_path(result, anchor=None) -> dict:
    """FeatureCollection: the footprint LineString, start and end points (module docstring for frames)."""
    _, fp = footprints(result.t_s, result.pos_n, result.stance)
    if len(fp) == 0:
        fp = result.pos_n[[0, -1]]
    pts = np.vstack((result.pos_n[:1], fp))  # the path starts at the origin of the nav frame
    if anchor:
        coords = enu_to_wgs84(pts, anchor)
        frame = {"crs": "WGS-84 (EPSG:4979) [lon_deg, lat_deg, h_m]",
                 "anchor_lat_lon_h": list(map(float, anchor)),
                 "projection": "local tangent plane around the anchor (see postproc/outputs.py)"}
        nd = 8
    else:
        coords = pts
        frame = {"crs": "local ENU metres [x_east_m, y_north_m, z_up_m], origin at the start; NOT WGS-84",
                 "note": "pass --geo-anchor LAT,LON[,H] for WGS-84 coordinates"}
        nd = 4
    c = np.round(coords, nd).tolist()
    feat = lambda geom, props: {"type": "Feature", "geometry": geom, "properties": props}  # noqa: E731
    return {
        "type": "FeatureCollection",
        "properties": {**frame, "software": f"bootnav {__version__}", "footprints": int(len(fp))},
        "features": [
            feat({"type": "LineString", "coordinates": c},
                 {"name": "path", "distance_m": result.summary.get("distance_m")}),
            feat({"type": "Point", "coordinates": c[0]}, {"name": "start"}),
            feat({"type": "Point", "coordinates": c[-1]}, {"name": "end"}),
        ],
    }


def results_arrays(result) -> tuple[dict, dict]:
    """Per-sample results for ``/results/<name>`` and their units."""
    arrays = {
        "t_s": result.t_s,
        "pos_n_m": result.pos_n,
        "vel_n_mps": result.vel_n,
        "q_nb": result.q_nb,
        "stance": result.stance.astype(np.uint8),
    }
    units = {"t_s": "s", "pos_n_m": "m", "vel_n_mps": "m/s", "q_nb": "1 (wxyz)", "stance": "1 (bool)"}
    nav = result.nav
    for attr, key, unit in (("acc_bias_b", "acc_bias_b_mps2", "m/s^2"), ("gyro_bias_b", "gyro_bias_b_radps", "rad/s"),
                            ("pos_sigma_n", "pos_sigma_n_m", "m")):
        value = getattr(nav, attr, None)
        if value is not None:
            arrays[key], units[key] = np.asarray(value), unit
    if result.stance_result is not None and getattr(result.stance_result, "statistic", None) is not None:
        arrays["stance_statistic"] = np.asarray(result.stance_result.statistic, dtype=np.float64)
        units["stance_statistic"] = "detector-specific (see attrs stance_method, stance_threshold)"
    return arrays, units


def write_hdf5_results(result, out_dir: Path) -> tuple[Path, str, list[str]]:
    """Write ``/results/<name>`` (+ ``/steps``); returns (file, group, warnings)."""
    from bootnav.logger.recording import write_group, write_recording

    warnings: list[str] = []
    name = result.settings.output.results_name
    group = f"/results/{name}"
    target = result.source if result.source_is_hdf5 else None
    if target is not None:
        try:
            import h5py

            with h5py.File(target, "r+"):
                pass
        except OSError as exc:
            warnings.append(f"{target}: cannot write results into the input recording ({exc}); wrote {out_dir / 'results.h5'}")
            target = None
    if target is None:
        rec = result.recording
        target = out_dir / "results.h5"
        meta = dict(rec.meta)
        meta.setdefault("source_file", str(result.source) if result.source else "")
        imported = rec.raw.get("import_result")
        if imported is not None:  # the exact recording `bootnav import` would write (raw values kept)
            from bootnav.logger.importers.core import write_result

            write_result(imported, target)
        else:
            write_recording(target, rec.t_s, rec.acc_mps2, rec.gyro_radps, events=rec.events, meta=meta,
                            saturated=rec.saturated)
    arrays, units = results_arrays(result)
    attrs = {
        "software": f"bootnav {__version__}",
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "settings": result.settings.to_json(indent=None),
        "summary": json.dumps(result.summary, default=str),
        "sample_index_start": int(result.index.start or 0),  # row 0 here is /imu row sample_index_start
        "stance_method": str(result.summary["stance"]["method"]),
        "stance_threshold": json.dumps(result.summary["stance"]["threshold"]),
        **{f"convention_{k}": v for k, v in CONVENTIONS.items()},
    }
    write_group(target, group, arrays, attrs, units)
    step_units = {"t_s": "s", "x_m": "m", "y_m": "m", "z_m": "m", "stride_length_m": "m", "dz_m": "m",
                  "yaw_enu_rad": "rad", "heading_deg_cw_from_north": "deg", "quality_flags": "1"}
    steps = {**{k: np.asarray(v) for k, v in result.steps.items()}, **heading_columns(result.steps["yaw_enu_rad"])}
    write_group(target, f"{group}/steps", steps,
                {"description": "one row per stride, see postproc/strides.py"}, step_units)
    return Path(target), group, warnings


def write_outputs(result, out_dir: str | Path) -> dict[str, str]:
    """Write every output file into ``out_dir`` (created); returns {kind: path}. Updates result.summary."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    opts = result.settings.output
    result.summary["settings"] = result.settings.to_dict()  # output options may have changed since process()
    files: dict[str, str] = {}
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=1) as pool:
        # HDF5 compression runs outside the GIL: overlap it with the CSV formatting (1 h: 3.8 s -> 2.2 s)
        h5_job = pool.submit(write_hdf5_results, result, out) if opts.write_hdf5 else None
        files["trajectory"] = str(write_trajectory_csv(out / "trajectory.csv", result))
        files["steps"] = str(write_steps_csv(out / "steps.csv", result.steps))
        if opts.geojson:
            p = out / "path.geojson"
            p.write_text(json.dumps(geojson_path(result, opts.geo_anchor)))
            files["geojson"] = str(p)
        if h5_job is not None:
            h5, group, warns = h5_job.result()
            files["hdf5"] = f"{h5}:{group}"
            result.warnings.extend(warns)
    result.summary["timings_s"]["write"] = time.perf_counter() - t0
    if opts.plots:
        from .plots import make_html, make_plots

        t1 = time.perf_counter()
        for key, path in make_plots(result, out).items():
            files[f"plot_{key}"] = str(path)
        files["html"] = str(make_html(result, out))
        result.summary["timings_s"]["plots"] = time.perf_counter() - t1
    files["summary"] = str(out / "summary.json")
    result.summary["files"] = files
    result.summary["warnings"] = list(result.warnings)
    (out / "summary.json").write_text(json.dumps(to_jsonable(result.summary), indent=1, allow_nan=False) + "\n")
    return files
