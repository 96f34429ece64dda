"""Files written by ``bootnav process --out DIR`` (columns and units are part of the public interface).

* ``trajectory.csv``: ``t_s,x_m,y_m,z_m,vx_mps,vy_mps,vz_mps,stance,qw,qx,qy,qz,sensor_yaw_enu_rad,
  sensor_heading_deg_cw_from_north``, one row per processed sample, nav frame ENU (x east, y north, z up),
  origin at the first processed sample; stance 1 = foot at rest; attitude ``q_nb`` scalar first (body to nav);
  the heading of the sensor's x axis counter-clockwise from east (rad) and clockwise from north (deg).
* ``steps.csv``: ``t_s,x_m,y_m,z_m,stride_length_m,dz_m,yaw_enu_rad,heading_deg_cw_from_north``, one row
  per stride (``bootnav.postproc.strides``): mid time of the stance phase ending the stride, its footprint,
  horizontal length, height change, and direction twice (``heading_columns``, ``bootnav.CONVENTIONS``):
  ``atan2(Δy, Δx)`` counter-clockwise from x (east), and clockwise from y (north) in degrees; then
  ``quality_flags``, ``floor`` (integer floor level, 0 = the start's) and the footprint's horizontal 1-σ error
  ellipse ``ellipse_major_m,ellipse_minor_m,ellipse_orientation_rad`` (semi-axes in m; major axis in rad
  counter-clockwise from east, in (−π/2, π/2]; ``strides.ellipse``; ``docs/floors.md``).
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
* ``results.h5``: ``/results/<name>`` with every setting used as group attributes, and the recording by
  reference, not by copy (``logger.recording.start_results_file``): HDF5 external links to its groups and its
  file name and SHA-256 as root attributes (the imported recording itself for a non-HDF5 input, which has no
  HDF5 file to refer to). The first dimension of every array is the row index ``sample`` (``stride`` in
  ``steps``), ``t_s`` its coordinate, ``axis``/``q_component`` the second, so netCDF readers (xarray with
  h5netcdf) see named dimensions, as in ``/imu``. The per-sample arrays are resizable
  (``ResultsWriter``: a run of many blocks appends them as they come); the float ones are stored uncompressed
  (``ResultsWriter``). The input itself is never written to,
  except with ``into_recording=True`` (``bootnav process --into-recording``), and then atomically: the
  results go into a copy beside it, which is flushed to disk and renamed over the original, so a crash or a
  full disk leaves either the old or the new recording, never a damaged one.

No file is overwritten unless ``force=True`` (``--force``), and no output may be one of the inputs
(``check_outputs``).

Speed: the CSV files are formatted by numpy and one compiled loop over the rows (``_csv_text``: the same text
as Python's ``%``), the HDF5 results are written on a thread meanwhile, and the charts are drawn by two forked
processes (``ChartWorker``), warmed up while the path is computed and given the small decimated chart stream;
a chart failure is a warning, never a lost output.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import shutil
import signal
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable

import numpy as np

from bootnav.core import atomic
from bootnav.core.conventions import CONVENTIONS, __version__
from bootnav.core.jsonio import to_jsonable
from bootnav.errors import InputError

from .strides import ELLIPSE_COLUMNS, FLOOR_COLUMN, STEP_COLUMNS, footprints

#: trajectory.csv: time, position, velocity, stance, attitude ``q_nb`` (wxyz, body to nav) and the heading of the
#: sensor's x axis (its horizontal projection) in both conventions of ``bootnav.CONVENTIONS["heading"]``.
TRAJECTORY_COLUMNS = ("t_s", "x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "stance", "qw", "qx", "qy", "qz",
                      "sensor_yaw_enu_rad", "sensor_heading_deg_cw_from_north")
RESULTS_CHUNK_ROWS = 65_536  # rows per HDF5 chunk of the per-sample results (about 0.5-2 MB per chunk)
WGS84_A_M = 6378137.0
WGS84_E2 = 6.69437999014e-3


_BLOCK_ROWS = 100_000  # rows formatted per pass: bounds the temporary arrays and text (~20 MB)


def _decimals(fmt: str) -> int:
    """Decimals of a ``%.Nf`` format, -1 for ``%d``."""
    if fmt == "%d":
        return -1
    if not (fmt.startswith("%.") and fmt.endswith("f") and fmt[2:-1].isdigit()):
        raise ValueError(f"CSV column format {fmt!r}: only %d and %.Nf are supported")
    return int(fmt[2:-1])


def _number_parts(x: np.ndarray, dec: int):
    """The parts of ``fmt % value`` for every value of a column: (digits, negative, rows, texts).

    ``digits`` (int64) are the field's digits without sign and point: ``rint(|x| 10^N)`` for ``%.Nf``, ``|int(x)|``
    (truncated towards zero, as ``%d``) for ``%d`` (``dec`` = -1); ``negative`` whether a '-' leads. The values
    whose rounding the float product cannot decide (within a few ulp of a half, |x| >= 1e15, NaN, inf) are
    formatted by Python's ``%`` instead: their ``rows`` and ASCII ``texts`` (rare: a few ties per million
    values), so every field equals ``fmt % value`` exactly (tests/test_long_csv.py).
    """
    if dec < 0:
        v = np.asarray(x).astype(np.int64)
        return np.abs(v), v < 0, np.zeros(0, np.int64), []
    x = np.asarray(x, dtype=np.float64)
    ax = np.abs(x)
    with np.errstate(invalid="ignore"):
        v = ax * 10.0**dec
        frac = v - np.floor(v)
        slow = ~np.isfinite(x) | (ax >= 1e15) | (np.abs(frac - 0.5) <= v * 2.0**-48 + 1e-9)
    rows = np.flatnonzero(slow)
    fmt = f"%.{dec}f"
    return (np.rint(np.where(slow, 0.0, v)).astype(np.int64), np.signbit(x), rows,
            [(fmt % float(x[i])).encode("ascii") for i in rows])


_PAIRS = np.frombuffer("".join(f"{i:02d}" for i in range(100)).encode("ascii"), np.uint8)  # "00".."99"


def _csv_text_kernel(digits, negative, decimals, special_at, special_text, special_end, out):
    """Write the CSV text of rows into ``out``; return its length in bytes (``_csv_text``).

    ``digits``, ``negative``: (k, n) per column and row; ``decimals``: (k,) digits after the point (0: no point);
    ``special_at`` (S,): ``row * k + column`` of the fields whose text is given, increasing; field j's bytes
    end at ``special_end[j]`` in ``special_text`` and begin where field j - 1's end (the first at 0).
    """
    k, n = digits.shape
    buf = np.empty(24, np.uint8)
    p = 0
    j = 0
    b = 0
    for r in range(n):
        for c in range(k):
            if j < special_at.shape[0] and special_at[j] == r * k + c:
                e = special_end[j]
                while b < e:
                    out[p] = special_text[b]
                    p += 1
                    b += 1
                j += 1
            else:
                if negative[c, r]:
                    out[p] = 45  # '-'
                    p += 1
                v = np.uint64(digits[c, r])  # unsigned: the divisions compile to multiplications
                d = decimals[c]
                m = 0  # digits in buf, least significant first, two per division
                while v >= 100:
                    q = v // np.uint64(100)
                    t = 2 * (v - q * np.uint64(100))
                    buf[m] = _PAIRS[t + 1]
                    buf[m + 1] = _PAIRS[t]
                    m += 2
                    v = q
                if v >= 10:
                    buf[m] = _PAIRS[2 * v + 1]
                    buf[m + 1] = _PAIRS[2 * v]
                    m += 2
                else:
                    buf[m] = 48 + v
                    m += 1
                while m <= d:  # zeros up to the units digit: 0.0012
                    buf[m] = 48
                    m += 1
                for i in range(m - 1, -1, -1):
                    out[p] = buf[i]
                    p += 1
                    if i == d and d > 0:
                        out[p] = 46  # '.'
                        p += 1
            out[p] = 44 if c < k - 1 else 10  # ',' or '\n'
            p += 1
    return p


_KERNEL = []  # the compiled _csv_text_kernel (numba is imported on the first CSV written, not with this module)


def _kernel():
    """The numba dispatcher of ``_csv_text_kernel`` (cached on disk), made on first use."""
    if not _KERNEL:
        from numba import njit

        _KERNEL.append(njit(cache=True, nogil=True)(_csv_text_kernel))
    return _KERNEL[0]


def warm_csv_writer(notice: Callable[[], None] | None = None) -> None:
    """Load the CSV kernel (``_csv_text``) into this process, so that writing does not wait for it.

    ``notice()`` is called first when numba must really compile it (a first run on this machine, or after an
    edit of this module: about 2 s), not when it loads it from its cache, as ``ins.fast.compile_notice`` does
    for the filter kernels; ``bootnav process`` calls it before the run with its progress line's notice.
    """
    kernel = _kernel()
    if kernel.signatures:
        return
    if notice is not None:
        from bootnav.postproc.ins.fast import cached_on_disk

        if not cached_on_disk(kernel):
            notice()
    _csv_text([np.zeros(1), np.zeros(1, np.int8)], ["%.1f", "%d"])  # the argument types of every CSV written



def _csv_text(columns: list[np.ndarray], fmts: list[str]) -> np.ndarray:
    """CSV text of equal-length ``columns`` (no header), ``fmt % value`` per field and ',' between them.

    The numbers' digits and signs are decided by numpy (``_number_parts``), the bytes written by one compiled
    loop over the rows (numba, cached on disk; ~0.1 µs per field), so no text is made per value in Python.

    Parameters
    ----------
    columns : list of (n,) arrays.
    fmts : one ``%.Nf`` or ``%d`` per column.

    Returns
    -------
    (bytes,) uint8 array
        The ASCII text: n lines, each ending in a line feed.
    """
    kernel = _kernel()
    k, n = len(columns), len(columns[0])
    digits = np.empty((k, n), np.int64)
    negative = np.empty((k, n), np.bool_)
    decimals = np.empty(k, np.int64)
    at, texts = [], []
    for c, (col, fmt) in enumerate(zip(columns, fmts)):
        dec = _decimals(fmt)
        digits[c], negative[c], rows, text = _number_parts(col, dec)
        decimals[c] = max(dec, 0)
        at.append(rows * k + c)
        texts += text
    at = np.concatenate(at)
    order = np.argsort(at, kind="stable")
    texts = [texts[i] for i in order]
    special_text = np.frombuffer(b"".join(texts), np.uint8)
    special_end = np.cumsum([len(t) for t in texts], dtype=np.int64)
    width = 23 * k + int(decimals.sum())  # per row: sign, <= 20 digits, point and ',' per field, the decimals
    out = np.empty(n * width + len(special_text), np.uint8)
    size = kernel(digits, negative, decimals, at[order], special_text, special_end, out)
    return out[:size]


def write_csv(path: Path, header: tuple[str, ...], columns: list[np.ndarray], fmts: list[str]) -> None:
    """Write columns as CSV, ``fmt % value`` per field (``_csv_text``, in blocks of rows: no full (N, k) copy
    of the data or of the text is ever made)."""
    with atomic.replacing(path) as f:  # never a half-written CSV under its name (kill -9, full disk)
        f.write((",".join(header) + "\n").encode("ascii"))
        append_csv_rows(f, columns, fmts)


#: the name before issue #25 made it public, for code of this module written against it (use ``write_csv``)
_write_csv = write_csv


def append_csv_rows(f, columns: list[np.ndarray], fmts: list[str]) -> None:
    """Append rows (one per element of the equal-length ``columns``) to the open binary file ``f``."""
    for i in range(0, len(columns[0]), _BLOCK_ROWS):
        f.write(_csv_text([np.asarray(c[i : i + _BLOCK_ROWS]) for c in columns], fmts))


TRAJECTORY_FORMATS = ["%.6f"] + ["%.4f"] * 6 + ["%d"] + ["%.6f"] * 4 + ["%.4f", "%.2f"]


def trajectory_columns(t_s, pos_n, vel_n, stance, q_nb) -> list[np.ndarray]:
    """The columns of trajectory.csv (``TRAJECTORY_COLUMNS``) of some rows. The sensor's heading is the ZYX
    Euler yaw of ``q_nb``: the direction of its x axis projected on the level plane, counter-clockwise from
    east (``sensor_yaw_enu_rad``) and as a compass reads it (``sensor_heading_deg_cw_from_north``)."""
    from bootnav.core.rotations import euler_zyx_from_quat

    q = np.asarray(q_nb, float)
    heading = heading_columns(euler_zyx_from_quat(q)[:, 2] if len(q) else np.zeros(0))
    return [t_s, pos_n[:, 0], pos_n[:, 1], pos_n[:, 2], vel_n[:, 0], vel_n[:, 1], vel_n[:, 2], stance.astype(np.int8),
            q[:, 0], q[:, 1], q[:, 2], q[:, 3], heading["yaw_enu_rad"], heading["heading_deg_cw_from_north"]]


def write_trajectory_csv(path: Path, result) -> Path:
    write_csv(path, TRAJECTORY_COLUMNS, trajectory_columns(result.t_s, result.pos_n, result.vel_n, result.stance,
                                                           result.q_nb), TRAJECTORY_FORMATS)
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
    ``selftune.FLAG_NAMES``; 0 = plausible), ``floor`` and the 1-σ ellipse columns (``strides.ELLIPSE_COLUMNS``)."""
    columns = {**{c: np.asarray(steps[c]) for c in STEP_COLUMNS}, **heading_columns(steps["yaw_enu_rad"])}
    fmts = ["%.6f", "%.4f", "%.4f", "%.4f", "%.4f", "%.4f", "%.5f", "%.3f"]
    if "quality_flags" in steps:
        columns["quality_flags"] = np.asarray(steps["quality_flags"])
        fmts.append("%d")
    if FLOOR_COLUMN in steps:
        columns[FLOOR_COLUMN] = np.asarray(steps[FLOOR_COLUMN])
        fmts.append("%d")
    if all(c in steps for c in ELLIPSE_COLUMNS):
        columns.update((c, np.asarray(steps[c])) for c in ELLIPSE_COLUMNS)
        fmts += ["%.4f", "%.4f", "%.5f"]
    write_csv(path, tuple(columns), list(columns.values()), fmts)
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
    return geojson_of(fp, result.pos_n[0], result.pos_n[-1], result.summary.get("distance_m"), anchor)


def geojson_of(fp: np.ndarray, first_n: np.ndarray, last_n: np.ndarray, distance_m, anchor) -> dict:
    """``geojson_path`` from the footprints (K, 3), the path's first and last positions (3,) (m, nav frame) and
    its distance: what a run in blocks has of the path when it is written."""
    fp = np.asarray(fp, float)
    if len(fp) == 0:
        fp = np.vstack((first_n, last_n))
    pts = np.vstack((np.asarray(first_n, float)[None, :3], fp))  # the path starts at the origin of the nav frame
    c = np.round(enu_to_wgs84(pts, anchor), 8).tolist()
    frame = {"crs": "WGS-84 (EPSG:4979) [lon_deg, lat_deg, h_m]", "anchor_lat_lon_h": list(map(float, anchor)),
             "projection": "local tangent plane around the anchor (see postproc/outputs.py)"}
    feat = lambda geom, props: {"type": "Feature", "geometry": geom, "properties": props}  # noqa: E731
    return {
        "type": "FeatureCollection",
        "properties": {**frame, "software": f"bootnav {__version__}", "footprints": int(len(fp))},
        "features": [
            feat({"type": "LineString", "coordinates": c},
                 {"name": "path", "distance_m": distance_m}),
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

    from bootnav.core.paths import output_folder

    inputs = [Path(i) for i in inputs if i]
    out = Path(out_dir)
    # the one output rule of every command (bootnav.core.paths): never an input, never an existing file
    # without force, never a non-HDF5 file replaced by HDF5, never a FIFO or a device
    output_folder(out, [p.name for p in planned_files(settings, out, into_recording)], force=force, inputs=inputs)
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


class ResultsWriter:
    """Per-sample results of ``/results/<name>`` appended block by block to resizable datasets.

    The group is created empty (an existing one is replaced); ``append`` adds rows to every array (created on
    the first call, chunks of up to ``RESULTS_CHUNK_ROWS`` rows). Only integer arrays (the stance mask) are
    gzip-compressed: they shrink a hundredfold, while the float results, noise in their low mantissa bits,
    shrink by 10-40 % at ten times the writing time (``docs/tuning-log.md``, "Long recordings").
    """

    def __init__(self, path: Path, group: str, n_rows: int, units: dict[str, str]):
        import h5py

        from bootnav.logger.recording import LIBVER

        self._file = h5py.File(path, "r+", libver=LIBVER)
        if group in self._file:
            del self._file[group]
        self.group = self._file.create_group(group)
        self.chunk_rows = int(min(RESULTS_CHUNK_ROWS, max(n_rows, 1)))
        self.units = units

    def append(self, arrays: dict[str, np.ndarray]) -> None:
        """Append the same number of rows to every array (the first call fixes the set of arrays)."""
        for key, value in arrays.items():
            value = np.asarray(value)
            if key not in self.group:
                kw = dict(compression="gzip", compression_opts=4, shuffle=True) if value.dtype.kind in "iub" else {}
                ds = self.group.create_dataset(key, shape=(0,) + value.shape[1:], maxshape=(None,) + value.shape[1:],
                                               dtype=value.dtype, chunks=(self.chunk_rows,) + value.shape[1:], **kw)
                ds.attrs["units"] = self.units.get(key, "1")
            ds = self.group[key]
            n0 = ds.shape[0]
            ds.resize(n0 + len(value), axis=0)
            ds[n0:] = value

    def close(self) -> None:
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def start_results(tmp: Path, target: Path, source, source_is_hdf5: bool, recording, into_recording: bool) -> None:
    """The file the results group is added to (``tmp``, committed to ``target``): a copy of the recording
    (``into_recording``), links to an HDF5 recording (``start_results_file``), or the recording an imported
    file or an in-memory ``Recording`` is (``recording``), as ``bootnav import`` would write it."""
    from bootnav.logger.recording import start_results_file, write_recording

    if source_is_hdf5 and source and into_recording:
        shutil.copy2(source, tmp)  # the whole recording: /imu, /events, /truth, earlier results
    elif source_is_hdf5 and source:
        start_results_file(tmp, source, target.parent)  # links to the recording, not a copy
    else:
        meta = dict(recording.meta)
        meta.setdefault("source_file", str(source) if source else "")
        imported = recording.raw.get("import_result")
        if imported is not None:  # the exact recording `bootnav import` would write (raw values kept)
            from bootnav.logger.importers.core import write_result_into

            write_result_into(imported, tmp)  # into the temporary itself: its commit is the caller's
        else:
            write_recording(tmp, recording.t_s, recording.acc_mps2, recording.gyro_radps, events=recording.events,
                            meta=meta, saturated=recording.saturated)


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
    from bootnav.logger.recording import attach_dimension_scales, write_group

    name = result.settings.output.results_name
    group = f"/results/{name}"
    target = Path(result.source) if into_recording else out_dir / "results.h5"  # checked by check_outputs
    tmp = atomic.temporary_beside(target)
    try:
        start_results(tmp, target, result.source, result.source_is_hdf5, result.recording, into_recording)
        arrays, units = results_arrays(result)
        with ResultsWriter(tmp, group, len(result.t_s), units) as writer:
            writer.append(arrays)
        attrs = {
            "software": f"bootnav {__version__}",
            "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
            "settings": result.settings.to_json(indent=None),
            "summary": json.dumps(result.summary, default=str),
            "sample_index_start": int(result.index.start or 0),  # row 0 here is /imu row sample_index_start
            "stance_method": str(result.summary["stance"]["method"]),
            "stance_threshold": json.dumps(result.summary["stance"]["threshold"]),
            "calibration": json.dumps(result.summary.get("calibration"), default=str),  # which one ran, or why none
            **{f"convention_{k}": v for k, v in CONVENTIONS.items()},
        }
        write_group(tmp, group, {}, attrs, replace=False)
        step_units = {"t_s": "s", "x_m": "m", "y_m": "m", "z_m": "m", "stride_length_m": "m", "dz_m": "m",
                      "yaw_enu_rad": "rad", "heading_deg_cw_from_north": "deg", "quality_flags": "1", "floor": "1",
                      "ellipse_major_m": "m", "ellipse_minor_m": "m", "ellipse_orientation_rad": "rad"}
        steps = {**{k: np.asarray(v) for k, v in result.steps.items()}, **heading_columns(result.steps["yaw_enu_rad"])}
        write_group(tmp, f"{group}/steps", steps,
                    {"description": "one row per stride, see postproc/strides.py"}, step_units)
        attach_dimension_scales(tmp, group)  # xarray/netCDF readers see named dims (t_s, axis), as in /imu
        attach_dimension_scales(tmp, f"{group}/steps", dim="stride")
        atomic.commit(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)
    return target, group


class ChartWorker:
    """Two forked processes that draw charts 1-7 and ``path.html`` while this one writes the other files.

    Started early (``start``: before the navigation, by ``bootnav process``), the child imports matplotlib
    and warms it up (``plots.warm_up``) while the path is computed, then forks the second (which inherits
    the warm matplotlib: no second import) and waits for one job: the decimated ``plots.ChartStream``
    (about 2 MB, pickled; not the per-sample arrays). Each draws half of the charts (``CHART_PARTS``) while
    this process writes the CSV and HDF5 files. A failure, whatever it is (an exception, a crash, being
    killed), is reported by ``wait`` and becomes a warning: the other outputs never depend on the charts.
    Ctrl-C reaches every process; the chart processes ignore it and are ended by ``close`` (SIGTERM: each
    removes its temporary PNG and exits, and is reaped, so no zombie remains); when its parent dies, a chart
    process notices within 0.1 s and ends the same way. The charts are written through temporary files
    renamed over the targets (``plots``), so a chart is never half written.
    """

    def __init__(self, proc, conn):
        self._proc, self._conn = proc, conn
        self._unsent: str | None = None  # why the job could not be sent (then ``wait`` must not wait for it)

    @classmethod
    def start(cls) -> ChartWorker | None:
        """Fork the chart process; None where fork is not available (or this is a daemon process, which may
        not have children): the charts are then drawn in this process."""
        import multiprocessing as mp

        if "fork" not in mp.get_all_start_methods() or mp.current_process().daemon:
            return None
        ctx = mp.get_context("fork")
        ours, theirs = ctx.Pipe(duplex=True)
        proc = ctx.Process(target=_chart_child, args=(theirs, ours, os.getpid()), daemon=True,
                           name="bootnav-charts")
        proc.start()
        theirs.close()
        return cls(proc, ours)

    def submit(self, stream, out: Path) -> None:
        """Send the job: draw ``stream`` (a finished ``plots.ChartStream``) into ``out``."""
        try:
            self._conn.send((stream, Path(out)))
        except OSError:  # the child is gone: ``wait`` reports it
            pass
        except Exception as exc:  # noqa: BLE001 - not sent (e.g. out of memory pickling): never wait for it
            self._unsent = f"{type(exc).__name__}: {exc}"

    def wait(self) -> tuple[dict[str, str], str | None]:
        """The child's answer: ({kind: path} of the files drawn, None) or ({}, the reason it failed)."""
        if self._unsent is not None:
            self.close()
            return {}, self._unsent
        try:
            status, value = self._conn.recv()
        except (EOFError, OSError):  # the child died without a word (killed, out of memory)
            self._proc.join()
            status, value = "error", f"the chart process ended with exit code {self._proc.exitcode}"
        self._proc.join(timeout=1.0)  # it ends right after answering
        self.close()
        return (value, None) if status == "ok" else ({}, value)

    def close(self) -> None:
        """End the child if it still runs (SIGTERM) and reap it."""
        self._conn.close()
        if self._proc.is_alive():
            self._proc.terminate()
        self._proc.join()


# What each of the two chart processes draws: about half of the drawing time each (the first chart, with three
# axes, costs about two of the others; docs/tuning-log.md "Long recordings")
CHART_PARTS = ({"keys": ("raw_imu", "acc_gravity_free", "velocity"), "html": False},
               {"keys": ("position", "path_2d", "path_3d", "height"), "html": True})


def _chart_child(conn, parent_end, parent_pid: int) -> None:
    """Body of the chart process (``ChartWorker``): warm matplotlib up, fork the second chart process (it
    inherits the warm matplotlib), take one job, draw ``CHART_PARTS[0]`` while the second draws
    ``CHART_PARTS[1]``, answer ("ok", {kind: path}) or ("error", one-line message)."""
    parent_end.close()  # the parent's end: its death must read as the end of this pipe here
    _end_with_parent(parent_pid)
    try:
        from .plots import warm_up

        warm_up()
        ready = None
    except Exception as exc:  # reported with the job: the parent is busy now
        ready = f"{type(exc).__name__}: {exc}"
    helper = _fork_helper() if ready is None else None
    done = False
    try:
        _serve(conn, CHART_PARTS[0], helper, ready)
        done = True
    finally:
        if helper is not None:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a late SIGTERM must not cut the reaping short
            pid, link = helper
            link.close()
            if not done:  # stopped: the helper must not go on drawing
                os.kill(pid, signal.SIGTERM)
            os.waitpid(pid, 0)


def _end_with_parent(parent_pid: int) -> None:
    """Ctrl-C is the parent's to handle (it ends this process by ``ChartWorker.close``); SIGTERM unwinds the
    drawing (its temporary file is removed); the death of the parent (its pid is no longer this process's
    parent) is noticed within 0.1 s and ends this process the same way."""
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(0.1)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, daemon=True).start()


def _fork_helper():
    """Fork the second chart process; (pid, connection to it)."""
    import multiprocessing as mp

    mine, theirs = mp.Pipe(duplex=True)
    parent = os.getpid()
    pid = os.fork()
    if pid == 0:  # the helper: serve one job, then leave without returning into the first one's code
        code = 1
        try:
            mine.close()
            _end_with_parent(parent)
            _serve(theirs, CHART_PARTS[1], None, None)
            code = 0
        except BaseException:  # noqa: BLE001 - reported to the first process by the closed pipe
            pass
        finally:
            os._exit(code)
    theirs.close()
    return pid, mine


def _serve(conn, part: dict, helper, ready: str | None) -> None:
    """Take one job from ``conn`` (EOF: none), pass it on to ``helper`` (pid, connection) if any, draw
    ``part`` and answer with every file drawn, the helper's too, or the first failure."""
    try:
        stream, out = conn.recv()
    except EOFError:
        return
    if helper is not None:
        try:
            helper[1].send((stream, out))
        except OSError:  # it is gone: its recv below says so
            pass
    if ready is not None:
        answer = ("error", ready)
    else:
        try:
            answer = ("ok", _draw(stream, out, **part))
        except Exception as exc:
            answer = ("error", f"{type(exc).__name__}: {exc}")
    if helper is not None:
        try:
            status, value = helper[1].recv()
        except (EOFError, OSError):
            status, value = "error", "the second chart process ended without an answer"
        if answer[0] == "ok":
            answer = ("ok", {**answer[1], **value}) if status == "ok" else (status, value)
    try:
        conn.send(answer)
    finally:
        conn.close()


def _exit_on_sigterm(signum, frame) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: the unwinding must not be interrupted again
    raise SystemExit(128 + signum)  # unwinds the drawing: its temporary file is removed


def _draw(stream, out: Path, keys=None, html: bool = True) -> dict[str, str]:
    """Charts 1-7 (those of ``keys``, all when None) and path.html from a finished ``plots.ChartStream``;
    {kind: path}."""
    from .plots import FILES, draw_charts, draw_html

    files = {f"plot_{key}": str(path) for key, path in draw_charts(stream, out, keys or tuple(FILES)).items()}
    if html:
        files["html"] = str(draw_html(stream, out))
    return files


def draw_here(stream, out: Path) -> tuple[dict[str, str], str | None]:
    """Draw in this process (no chart process), a failure reported as ``ChartWorker.wait`` does."""
    try:
        return _draw(stream, out), None
    except Exception as exc:  # noqa: BLE001 - the charts must never cost the other outputs
        return {}, f"{type(exc).__name__}: {exc}"


def write_outputs(result, out_dir: str | Path, into_recording: bool = False, force: bool = False,
                  charts: ChartWorker | None = None) -> dict[str, str]:
    """Write every output file into ``out_dir`` (created); updates ``result.summary``.

    The charts are drawn by a ``ChartWorker`` while this process writes the CSV files and, on a thread, the
    HDF5 results; a chart failure is a warning (in the summary and the report), never a lost output.

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
    charts
        A chart process started earlier (``ChartWorker.start``), used and closed here; None: one is started
        now when the settings ask for charts.

    Returns
    -------
    dict
        {kind: path} of every file written.
    """
    out = Path(out_dir)
    opts = result.settings.output
    if charts is None and opts.plots:
        charts = ChartWorker.start()  # before any thread: fork copies one thread
    try:
        check_outputs(result.settings, out, [result.source], into_recording, force)
        out.mkdir(parents=True, exist_ok=True)
        result.summary["settings"] = result.settings.to_dict()  # output options may have changed since process()
        files: dict[str, str] = {}
        t0 = time.perf_counter()
        stream = None
        chart_error = None
        with ThreadPoolExecutor(max_workers=2) as pool:
            # HDF5 compression runs outside the GIL: overlap it with the chart stream and the CSV formatting
            h5_job = pool.submit(write_hdf5_results, result, out, into_recording, force) if opts.write_hdf5 else None
            if opts.plots:
                from .plots import ChartStream

                try:
                    stream = ChartStream.from_result(result)
                except Exception as exc:  # noqa: BLE001 - the charts must never cost the other outputs
                    chart_error = f"{type(exc).__name__}: {exc}"
                if charts is not None and stream is not None:
                    pool.submit(charts.submit, stream, out)  # a thread: a child still warming up reads it later
            files["trajectory"] = str(write_trajectory_csv(out / "trajectory.csv", result))
            files["steps"] = str(write_steps_csv(out / "steps.csv", result.steps))
            if opts.geojson and opts.geo_anchor:  # without an anchor, GIS tools would draw local metres at 0° N 0° E
                p = out / "path.geojson"
                atomic.write_text(p, json.dumps(geojson_path(result, opts.geo_anchor)))
                files["geojson"] = str(p)
            if h5_job is not None:
                h5, group = h5_job.result()
                files["hdf5"] = f"{h5}:{group}"
        result.summary["timings_s"]["write"] = time.perf_counter() - t0
        if opts.plots:
            t1 = time.perf_counter()
            if chart_error is not None:
                drawn, error = {}, chart_error
            else:
                drawn, error = charts.wait() if charts is not None else draw_here(stream, out)
            if error:
                result.warnings.append(f"{out}: the charts were not drawn ({error}); the other outputs are complete")
            files.update(drawn)
            result.summary["timings_s"]["plots"] = time.perf_counter() - t1  # the wait after writing (0 if done)
    finally:
        if charts is not None:
            charts.close()
    files["summary"] = str(out / "summary.json")
    result.summary["files"] = files
    result.summary["warnings"] = list(result.warnings)
    atomic.write_text(out / "summary.json", json.dumps(to_jsonable(result.summary), indent=1, allow_nan=False) + "\n")
    return files
