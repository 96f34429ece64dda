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
* ``path.geojson`` (only with ``geo_anchor = (lat, lon[, h])``, ``--geo-anchor``: GIS tools read GeoJSON
  as WGS-84, so local metres would be drawn near 0° N 0° E): the footprint path in WGS-84 ``[lon, lat, h]``
  from a local tangent-plane approximation around the anchor (φ0, λ0, h0)::

      φ = φ0 + y / (M(φ0) + h0),   λ = λ0 + x / ((N(φ0) + h0) cos φ0),   h = h0 + z

  with the WGS-84 meridian radius M = a(1 − e²)/(1 − e² sin²φ0)^{3/2} and prime-vertical radius
  N = a/(1 − e² sin²φ0)^{1/2}. The error grows with the square of the distance: below 1 cm within 1 km,
  far below the drift of any foot-mounted INS.
* ``results.h5``: a copy of the input recording (the imported recording for a non-HDF5 input) plus
  ``/results/<name>`` with every setting used as group attributes; its ``t_s`` (and ``steps/t_s``) is the
  dimension scale of the first axis of every array, ``axis``/``q_component`` of the second, so netCDF
  readers (xarray with h5netcdf) see named dimensions, as in ``/imu``. The input itself is never written to,
  except with ``into_recording=True`` (``bootnav process --into-recording``), and then atomically: the
  results go into a copy beside it, which is flushed to disk and renamed over the original, so a crash or a
  full disk leaves either the old or the new recording, never a damaged one.

No file is overwritten unless ``force=True`` (``--force``), and no output may be one of the inputs
(``check_outputs``).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from bootnav.core.conventions import CONVENTIONS, __version__
from bootnav.core.jsonio import to_jsonable
from bootnav.errors import InputError

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


def geojson_path(result, anchor) -> dict:
    """FeatureCollection in WGS-84: the footprint LineString, start and end points (module docstring).

    Parameters
    ----------
    result
        ``pipeline.ProcessResult``.
    anchor : (lat_deg, lon_deg[, h_m])
        WGS-84 position of the nav-frame origin (the start).

    Returns
    -------
    dict
        The GeoJSON object.
    """
    _, fp = footprints(result.t_s, result.pos_n, result.stance)
    if len(fp) == 0:
        fp = result.pos_n[[0, -1]]
    pts = np.vstack((result.pos_n[:1], fp))  # the path starts at the origin of the nav frame
    c = np.round(enu_to_wgs84(pts, anchor), 8).tolist()
    frame = {"crs": "WGS-84 (EPSG:4979) [lon_deg, lat_deg, h_m]", "anchor_lat_lon_h": list(map(float, anchor)),
             "projection": "local tangent plane around the anchor (see postproc/outputs.py)"}
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


def planned_files(settings, out_dir: str | Path, into_recording: bool = False) -> list[Path]:
    """Every file ``write_outputs`` would create in ``out_dir`` with these settings.

    Parameters
    ----------
    settings
        ``ProcessSettings`` (only ``output`` is read).
    out_dir
        The output directory.
    into_recording
        Results go into the input recording instead of ``results.h5``.

    Returns
    -------
    list of Path
    """
    from .plots import FILES

    out, opts = Path(out_dir), settings.output
    names = ["trajectory.csv", "steps.csv", "summary.json"]
    if opts.geojson and opts.geo_anchor:
        names.append("path.geojson")
    if opts.write_hdf5 and not into_recording:
        names.append("results.h5")
    if opts.plots:
        names += [*FILES.values(), "path.html"]
    return [out / n for n in names]


def same_file(a: Path, b: Path) -> bool:
    """True when two paths name the same file (after resolving links), whether or not they exist yet."""
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except OSError:
        return False


def check_outputs(settings, out_dir: str | Path, inputs, into_recording: bool = False, force: bool = False) -> None:
    """Refuse, before any work, outputs that would replace an input or an existing file.

    Parameters
    ----------
    settings
        ``ProcessSettings`` (which files are written, the results group name).
    out_dir
        The output directory: it must not be an input nor an existing file.
    inputs : sequence of path or None
        Files the run reads, the recording first (then reference, settings, calibration files); never
        overwritten, even with ``force``.
    into_recording
        Results go into the recording ``inputs[0]``, which must then be an HDF5 recording.
    force
        Allow replacing existing files that are not inputs, and an existing results group in the recording.

    Raises
    ------
    InputError
        Naming the first offending path and the option that allows it, if any.
    """
    from .source import is_hdf5

    inputs = [Path(i) for i in inputs if i]
    out = Path(out_dir)
    if any(same_file(out, i) for i in inputs):
        raise InputError(f"--out {out} is an input; give a new directory for the outputs")
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} is an existing file, not a directory")
    for o in planned_files(settings, out, into_recording):
        if any(same_file(o, i) for i in inputs):
            raise InputError(f"{o}: output would replace an input file; choose another --out")
        if o.exists() and not force:
            raise InputError(f"{o} exists; use --force to overwrite it (or choose another --out)")
    if into_recording and settings.output.write_hdf5:
        rec = inputs[0] if inputs else None
        if rec is not None and not rec.exists():
            raise InputError(f"{rec}: no such file")
        if rec is None or not is_hdf5(rec):
            raise InputError(f"--into-recording needs an HDF5 recording as input, got {rec or 'an in-memory recording'}"
                             " (`bootnav import` it first, or drop the option)")
        if not force:
            import h5py

            group = f"/results/{settings.output.results_name}"
            with h5py.File(rec, "r") as f:
                if group in f:
                    raise InputError(f"{rec}: {group} exists; use --force to replace it, or --results-name NAME")


def _fsync(path: Path) -> None:
    """Flush a file (or a directory entry) to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _replace_atomically(tmp: Path, target: Path) -> None:
    """fsync ``tmp``, rename it over ``target`` (atomic on one file system), fsync the directory."""
    _fsync(tmp)
    os.replace(tmp, target)
    _fsync(target.parent)


def write_hdf5_results(result, out_dir: Path, into_recording: bool = False, force: bool = False) -> tuple[Path, str]:
    """Write ``/results/<name>`` (+ ``/steps``) into ``out_dir/results.h5`` or, when asked, the input recording.

    Both go through a temporary copy in the target's directory renamed over the target (module docstring).

    Parameters
    ----------
    result
        ``pipeline.ProcessResult``.
    out_dir
        Directory of ``results.h5``.
    into_recording
        Write into the input recording (an HDF5 file) instead.
    force
        Replace an existing ``results.h5``, or an existing ``/results/<name>`` group of the input recording.

    Returns
    -------
    (Path, str)
        The file written and the group.
    """
    from bootnav.logger.recording import attach_dimension_scales, write_group, write_recording

    name = result.settings.output.results_name
    group = f"/results/{name}"
    target = Path(result.source) if into_recording else out_dir / "results.h5"  # checked by check_outputs
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        if result.source_is_hdf5 and result.source:
            shutil.copy2(result.source, tmp)  # the whole recording: /imu, /events, /truth, earlier results
        else:
            rec = result.recording
            meta = dict(rec.meta)
            meta.setdefault("source_file", str(result.source) if result.source else "")
            imported = rec.raw.get("import_result")
            if imported is not None:  # the exact recording `bootnav import` would write (raw values kept)
                from bootnav.logger.importers.core import write_result

                write_result(imported, tmp)
            else:
                write_recording(tmp, rec.t_s, rec.acc_mps2, rec.gyro_radps, events=rec.events, meta=meta,
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
        write_group(tmp, group, arrays, attrs, units)
        step_units = {"t_s": "s", "x_m": "m", "y_m": "m", "z_m": "m", "stride_length_m": "m", "dz_m": "m",
                      "yaw_enu_rad": "rad", "heading_deg_cw_from_north": "deg", "quality_flags": "1"}
        steps = {**{k: np.asarray(v) for k, v in result.steps.items()}, **heading_columns(result.steps["yaw_enu_rad"])}
        write_group(tmp, f"{group}/steps", steps,
                    {"description": "one row per stride, see postproc/strides.py"}, step_units)
        attach_dimension_scales(tmp, group)  # xarray/netCDF readers see named dims (t_s, axis), as in /imu
        attach_dimension_scales(tmp, f"{group}/steps")
        _replace_atomically(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
    return target, group


def write_outputs(result, out_dir: str | Path, into_recording: bool = False, force: bool = False) -> dict[str, str]:
    """Write every output file into ``out_dir`` (created); updates ``result.summary``.

    Parameters
    ----------
    result
        ``pipeline.ProcessResult``.
    out_dir
        Output directory.
    into_recording
        Write the HDF5 results into the input recording (atomically) instead of ``out_dir/results.h5``.
    force
        Overwrite existing output files (inputs are never overwritten, ``check_outputs``).

    Returns
    -------
    dict
        {kind: path} of every file written.
    """
    out = Path(out_dir)
    opts = result.settings.output
    check_outputs(result.settings, out, [result.source], into_recording, force)
    out.mkdir(parents=True, exist_ok=True)
    result.summary["settings"] = result.settings.to_dict()  # output options may have changed since process()
    files: dict[str, str] = {}
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=1) as pool:
        # HDF5 compression runs outside the GIL: overlap it with the CSV formatting (1 h: 3.8 s -> 2.2 s)
        h5_job = pool.submit(write_hdf5_results, result, out, into_recording, force) if opts.write_hdf5 else None
        files["trajectory"] = str(write_trajectory_csv(out / "trajectory.csv", result))
        files["steps"] = str(write_steps_csv(out / "steps.csv", result.steps))
        if opts.geojson and opts.geo_anchor:  # without an anchor, GIS tools would draw local metres at 0° N 0° E
            p = out / "path.geojson"
            p.write_text(json.dumps(geojson_path(result, opts.geo_anchor)))
            files["geojson"] = str(p)
        if h5_job is not None:
            h5, group = h5_job.result()
            files["hdf5"] = f"{h5}:{group}"
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
