"""The Python API, for notebooks and scripts: ``bootnav.load``, ``bootnav.process``, ``bootnav.pdr``.

::

    import bootnav

    rec = bootnav.load("walk.h5")                     # a recording, or any file `bootnav import` reads
    res = bootnav.process(rec, reference={"closed_loop": True}, detector="shoe")
    res.pos_n_m, res.stance, res.steps["stride_length_m"], res.summary["distance_m"]
    res = bootnav.process(t_s, acc_mps2, gyro_radps)  # or straight from arrays (SI units, body frame)
    res = bootnav.process(t_s, acc_g, gyro_dps, acc_unit="g", gyro_unit="dps")  # other units, declared
    res = bootnav.process(df)                         # a DataFrame: t_s, ax_mps2 ... gz_radps (FRAME_COLUMNS)
    df = res.to_dataframe()                           # pandas (optional), columns as trajectory.csv, index t_s
    res.save("out/")                                  # every file `bootnav process --out out/` writes
    steps = bootnav.pdr(t_s, acc_mps2, gyro_radps)    # step-and-heading for waist / phone sensors
    both = bootnav.process_two_boots("left.h5", "right.h5")  # two feet of one walker, fused (or one multi-boot file)
    both.left.pos_n_m, both.walker_pos_n_m, both.strides["step_width_m"], both.save("out/")

Settings are given as keywords: any field of ``bootnav.postproc.settings.ProcessSettings`` (``PdrSettings``
for ``pdr``), nested ones as dicts or by name, e.g. ``process(rec, crop_s=(0, 60), detector={"method": "shoe",
"params": {"threshold": 2e5}})`` (a detector's parameters are the fields of its class, validated as a settings
file's are) or ``detector="shoe"``; or a whole object / dict / JSON file as ``settings=``. Frames and units:
``bootnav.CONVENTIONS``.

Arrays are checked against physics as ``bootnav import`` checks a file (``bootnav.logger.importers.checks``, the
one definition, here in the API's words: ``API_WORDS``): gravity at rest ≈ 1 means g, gyro peaks beyond any
foot mean deg/s, time steps ≫ 1 s mean ms; a mismatch is an ``InputError`` naming the keyword that declares the
unit (``acc_unit="g"``, ``gyro_unit="dps"``, ``time_unit="ms"``; ``check_units=False`` keeps the arrays as
given). Every message speaks the API's keywords (``force=True``, ``crop_s=(t0, t1)``: ``api_words``), and every
warning of a result is also issued as a Python warning of category ``bootnav.errors.BootnavWarning``.

``import bootnav`` imports none of this (nor numpy): the package resolves these names on first use.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

__all__ = ["load", "process", "process_two_boots", "pdr", "PathResult", "StepResult", "TwoBootPathResult"]


def load(path: str | Path, *, acc_unit: str | None = None, gyro_unit: str | None = None,
         time_unit: str | None = None, check_units: bool = True):
    """Read a recording: a bootnav HDF5 file or any file ``bootnav import`` reads (CSV, SD-card log, ...).

    Parameters
    ----------
    path
        The file.
    acc_unit, gyro_unit, time_unit
        The units of a text file's columns when its header or profile does not declare them, or declares them
        wrongly (``"g"``, ``"mps2"``, ``"counts"``; ``"dps"``, ``"radps"``, ``"counts"``; ``"s"``, ``"ms"``,
        ``"us"``), as ``bootnav import --acc-unit ...``. An HDF5 recording declares its own units.
    check_units
        ``False`` keeps a text file whose units contradict gravity (a note instead of an error).

    Returns
    -------
    bootnav.logger.recording.Recording
        ``t_s`` (N,), ``acc_mps2`` and ``gyro_radps`` (N, 3) in SI units and the body frame, ``meta``,
        ``events``, ``saturated``.

    Raises
    ------
    bootnav.errors.InputError
        Missing or unreadable file; units that contradict gravity (the message names the keyword to give).
    """
    from bootnav.postproc.source import load_source

    units = {k: v for k, v in dict(acc_unit=acc_unit, gyro_unit=gyro_unit, time_unit=time_unit).items() if v}
    overrides = dict(units, check_units=False) if not check_units else units
    with _ApiWords():
        return load_source(path, import_overrides=overrides or None).recording


def _pandas():
    try:
        import pandas
    except ImportError:
        raise ImportError("to_dataframe() needs pandas, an optional dependency: `pip install pandas` "
                          "(every column is also a numpy array on the result)") from None
    return pandas


def _merged(base: dict, overrides: dict) -> dict:
    """``base`` with ``overrides`` applied; nested dicts are merged key by key. A section given another
    ``method`` starts from that method's defaults (``detector={"method": "shoe"}``: the base detector's
    ``params`` belong to another detector)."""
    out = dict(base)
    if "method" in overrides and overrides["method"] != out.get("method"):
        out.pop("params", None)
    for key, value in overrides.items():
        out[key] = _merged(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
    return out


def _nested_as_dicts(cls, values: dict) -> dict:
    """Settings as a user writes them, in the settings object's form: a nested setting given by its name
    (``detector="shoe"``) becomes ``{"method": name}``; a reference given as a dict or a path becomes the JSON
    text or path string that ``ProcessSettings.reference`` holds."""
    import json

    default = cls()
    out = {}
    for key, value in values.items():
        sub = getattr(default, key, None)
        if isinstance(value, str) and hasattr(sub, "__dataclass_fields__") and hasattr(sub, "method"):
            value = {"method": value}
        elif key == "reference" and isinstance(value, dict):
            value = json.dumps(value)
        elif key == "reference" and isinstance(value, Path):
            value = str(value)
        out[key] = value
    return out


def _settings(cls, settings, overrides: dict):
    """A settings object from ``settings`` (object, dict, JSON file or None) and keyword overrides."""
    if settings is None:
        base = cls()
    elif isinstance(settings, cls):
        base = settings
    elif isinstance(settings, dict):
        base = cls.from_dict(_nested_as_dicts(cls, settings))
    else:
        base = cls.from_file(settings)
    return cls.from_dict(_merged(base.to_dict(), _nested_as_dicts(cls, overrides))) if overrides else base


def _numbers(value, name: str, fn: str) -> np.ndarray:
    """``value`` as a float array, or an ``InputError`` in the API's words (strings, None, objects)."""
    from bootnav.errors import InputError

    if value is None or isinstance(value, (str, bytes)):
        raise InputError(f"{fn}: {name} must be an array of numbers, got {type(value).__name__}")
    try:
        return np.asarray(value, float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{fn}: {name} must be an array of numbers, got {type(value).__name__} ({exc})") from None


def _check_source(source, fn: str, arrays: str) -> None:
    """A file path or a ``Recording``; anything else is an ``InputError`` saying what the function takes."""
    import os

    from bootnav.errors import InputError
    from bootnav.logger.recording import Recording

    if isinstance(source, (str, os.PathLike, Recording)):
        return
    got = type(source).__name__
    hint = f" (with arrays, give {arrays} too)" if isinstance(source, (np.ndarray, list, tuple)) else ""
    raise InputError(f"{fn}: expected a file path, a Recording, or t_s with {arrays}; got {got}{hint}")


# The pipeline speaks `bootnav process`'s flags; the API says the same with its keywords. One table, applied to
# every message the API passes on (errors and warnings).
_API_PHRASES = (
    (r"--crop T0 T1", "crop_s=(t0, t1)"),
    (r"--crop (-?[0-9.]+) (-?[0-9.]+)", r"crop_s=(\1, \2)"),
    (r"--crop\b", "crop_s"),
    (r"use --force\b", "use force=True"),
    (r"--force\b", "force=True"),
    (r"--detector ([a-z_][a-z0-9_-]*) --threshold \.\.\.", r'detector={"method": "\1", "threshold": ...}'),
    (r"--detector ([a-z_][a-z0-9_-]*)", r'detector="\1"'),
    (r"--detector, --settings", "detector=, settings="),
    (r"--threshold\b", 'detector={"threshold": ...}'),
    (r"--settings\b", "settings="),
    (r"--reference/--closed-loop", "reference="),
    (r"--reference\b", "reference="),
    (r"--closed-loop\b", 'reference={"closed_loop": True}'),
    (r"--results-name NAME", 'output={"results_name": NAME}'),
    (r"--into-recording\b", "into_recording=True"),
    (r"--out ", "out_dir "),
    (r"choose another --out", "choose another out_dir"),
    (r"--(acc|gyro|time)-unit ([a-z0-9]+(?:\|[a-z0-9]+)+)", lambda m: m[1] + "_unit=" + " or ".join(
        f'"{u}"' for u in m[2].split("|"))),
    (r"--(acc|gyro|time)-unit ([a-z0-9]+)", r'\1_unit="\2"'),
    (r"--(acc|gyro|time)-unit\b", r"\1_unit="),
    (r"--trust-units\b|--no-unit-check\b", "check_units=False"),
)


def api_words(message: str) -> str:
    """``message`` with ``bootnav process``'s flags replaced by the Python API's keywords."""
    import re

    for pattern, repl in _API_PHRASES:
        message = re.sub(pattern, repl, message)
    return message


def _warn(messages) -> None:
    """Each message as a Python warning (``bootnav.errors.BootnavWarning``) at the caller's line."""
    import warnings

    from bootnav.errors import BootnavWarning

    for m in messages:
        warnings.warn(api_words(m), BootnavWarning, stacklevel=3)


class _ApiWords:
    """Re-raise an ``InputError`` from the pipeline in the API's words (``api_words``), without the traceback
    of the pipeline's internals."""

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        from bootnav.errors import InputError

        if kind is not None and issubclass(kind, InputError):
            new = api_words(str(exc))
            if new != str(exc):
                raise kind(new) from None
        return False


# Column names of a DataFrame given to process/pdr (the canonical IMU CSV's, ``bootnav.core.csvio``, and the
# same with other units in the suffix): time t_s | t_ms | t_us (or the index named so), acc ax_mps2 | ax_g, ...
_TIME_NAMES = {"t_s": "s", "t_ms": "ms", "t_us": "us"}
_ACC_SUFFIXES = {"mps2": "mps2", "g": "g"}
_GYRO_SUFFIXES = {"radps": "radps", "dps": "dps"}
FRAME_COLUMNS = ("t_s (or t_ms, t_us, or the index named so), ax_mps2 ay_mps2 az_mps2 (or ax_g ...), "
                 "gx_radps gy_radps gz_radps (or gx_dps ...)")


def _is_frame(obj) -> bool:
    return hasattr(obj, "columns") and hasattr(obj, "index") and hasattr(obj, "to_numpy")


def _frame_arrays(df, need_gyro: bool) -> tuple[tuple, dict]:
    """(t, acc, gyro) and their units from a DataFrame with the documented column names (``FRAME_COLUMNS``)."""
    from bootnav.errors import InputError

    cols = [str(c) for c in df.columns]
    units: dict = {}
    t = None
    for name, unit in _TIME_NAMES.items():
        if name in cols:
            t, units["time_unit"] = df[name].to_numpy(float), unit
            break
        if getattr(df.index, "name", None) == name:
            t, units["time_unit"] = np.asarray(df.index, float), unit
            break

    def triple(prefix: str, suffixes: dict, key: str):
        for suffix, unit in suffixes.items():
            names = [f"{prefix}{axis}_{suffix}" for axis in "xyz"]
            if all(n in cols for n in names):
                units[key] = unit
                return df[names].to_numpy(float)
        return None

    acc = triple("a", _ACC_SUFFIXES, "acc_unit")
    gyro = triple("g", _GYRO_SUFFIXES, "gyro_unit")
    if t is None or acc is None or (gyro is None and need_gyro):
        missing = [what for what, v in (("time", t), ("accelerometer", acc), ("gyroscope", gyro if need_gyro else 0))
                   if v is None]
        raise InputError(f"the DataFrame has no {' / '.join(missing)} columns; expected {FRAME_COLUMNS}; "
                         f"it has {cols[:12]}")
    return (t, acc, gyro), units


def _arrays(t_s, acc_mps2, gyro_radps, need_gyro: bool = True, *, acc_unit: str = "mps2", gyro_unit: str = "radps",
            time_unit: str = "s", check_units: bool = True, specific_force: bool = True,
            notes: list | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Arrays as SI (s, m/s², rad/s), converted from the declared units and checked against physics as
    ``bootnav import`` checks a file (``bootnav.logger.importers.checks``, in the API's words): gravity at rest
    (acc in g?), gyro peaks (deg/s?), time steps (ms?). A failed check is an ``InputError`` naming the keyword
    that fixes it (``check_units=False`` keeps the data as given, with a warning); a borderline one is appended
    to ``notes``."""
    from bootnav.errors import InputError
    from bootnav.logger.importers import checks
    from bootnav.logger.mpu6050 import STANDARD_GRAVITY

    call = "process(t_s, acc_mps2, gyro_radps)" if need_gyro else "pdr(t_s, acc_mps2[, gyro_radps])"
    t = _numbers(t_s, "t_s", call)
    acc = None if acc_mps2 is None else _numbers(acc_mps2, "acc_mps2", call)
    gyro = None if gyro_radps is None else _numbers(gyro_radps, "gyro_radps", call)
    if t.ndim == 2 and t.shape[1:] == (3,) and acc is not None and acc.shape == t.shape and gyro is None:
        raise InputError(f"{call}: the sample times are missing: the first argument is an (N, 3) array; give the "
                         "times first, t_s (N,) in s (e.g. t_s = np.arange(N) / rate_hz)")
    if gyro is None and need_gyro:
        raise InputError(f"{call}: the gyroscope is required (foot-mounted navigation integrates the rotation); "
                         "for an accelerometer alone use bootnav.pdr")
    if t.ndim != 1 or acc is None or acc.shape != (len(t), 3) or (gyro is not None and gyro.shape != (len(t), 3)):
        raise InputError(f"{call}: expected t_s (N,), acc_mps2 (N, 3), gyro_radps (N, 3); got {t.shape}, "
                         f"{None if acc is None else acc.shape}, {None if gyro is None else gyro.shape}")
    scale = {"time": {"s": 1.0, "ms": 1e-3, "us": 1e-6}, "acc": {"mps2": 1.0, "g": STANDARD_GRAVITY},
             "gyro": {"radps": 1.0, "dps": np.pi / 180.0}}
    for what, unit in (("time", time_unit), ("acc", acc_unit), ("gyro", gyro_unit)):
        if unit not in scale[what]:
            raise InputError(f"{what}_unit={unit!r} unknown: use one of {', '.join(map(repr, scale[what]))}")
    t = t * scale["time"][time_unit]
    acc = acc * scale["acc"][acc_unit]
    gyro = None if gyro is None else gyro * scale["gyro"][gyro_unit]
    words = checks.API_WORDS
    problems, borderline = [checks.time_unit_problem(t, words)], []
    if len(t) > 2 and not problems[0]:
        dt = np.diff(t)
        dt = dt[np.isfinite(dt) & (dt > 0)]
        rate = 1.0 / float(np.median(dt)) if dt.size else 1.0
        quiet = checks.quietest_second(acc, rate)
        fits_a_unit = any(abs(quiet[0] / ref - 1) <= checks.ACC_TOLERANCE for ref in (1.0, STANDARD_GRAVITY))
        if specific_force or fits_a_unit:  # a phone's linear acceleration (pdr) has no gravity to check
            problems.append(checks.acc_unit_problem(acc, 1.0, acc_unit, rate, quiet=quiet, words=words))
            if not problems[-1]:
                borderline.append(checks.acc_borderline(None, 1.0, rate, quiet=quiet, words=words))
        if gyro is not None:
            problems.append(checks.gyro_unit_problem(gyro, gyro_unit, words=words))
            if not any(problems) and specific_force:
                err, warn = checks.gyro_unit_too_small(acc, gyro, t, gyro_unit, words=words)
                problems.append(err)
                borderline.append(warn)
    problems = [p for p in problems if p]
    if problems and check_units:
        raise InputError(f"{call}: {problems[0]} (or check_units=False to use the arrays as they are)")
    if notes is not None:
        notes += [f"unit check overridden: {p}" for p in problems] + [b for b in borderline if b]
    return t, acc, gyro


def _recording_of_arrays(t_s, acc_mps2, gyro_radps, notes: list | None = None, **units):
    from bootnav.logger.recording import Recording, make_events

    t, acc, gyro = _arrays(t_s, acc_mps2, gyro_radps, notes=notes, **units)
    return Recording(path=None, t_s=t, acc_mps2=acc, gyro_radps=gyro, saturated=np.zeros(len(t), np.uint8),
                     events=make_events([]), meta={"source_file": "arrays"}, attrs={})


def _source_and_units(source, acc_mps2, gyro_radps, need_gyro: bool, units: dict):
    """(t, acc, gyro, units) of the arrays form or a DataFrame (its column names give the units), else None."""
    if _is_frame(source) and acc_mps2 is None and gyro_radps is None:
        arrays, frame_units = _frame_arrays(source, need_gyro)
        return (*arrays, {**units, **frame_units})
    if acc_mps2 is not None or gyro_radps is not None or (np.ndim(source) == 2 if isinstance(source, np.ndarray)
                                                          else False):
        return source, acc_mps2, gyro_radps, units
    return None


@dataclass
class PathResult:
    """The walked path of ``process`` (nav frame east-north-up, origin at the first processed sample).

    Attributes
    ----------
    t_s : (N,) array
        Sample times, s (the recording's clock).
    pos_n_m, vel_n_mps : (N, 3) arrays
        Position (m) and velocity (m/s) of the sensor.
    q_nb : (N, 4) array
        Attitude, scalar first, body to nav.
    stance : (N,) bool array
        Foot at rest (zero-velocity updates applied).
    steps : dict of arrays
        One row per stride (``steps.csv``): ``t_s``, footprint ``x_m y_m z_m``, ``stride_length_m``, ``dz_m``,
        ``yaw_enu_rad``, ``heading_deg_cw_from_north``, ``quality_flags``.
    summary : dict
        Everything ``summary.json`` holds (distance, closure or end - start, floors, metrics, warnings, ...).
    warnings : list of str
    metrics : dict or None
        Reference metrics when a reference was given.
    raw : bootnav.postproc.pipeline.ProcessResult
        Every intermediate (detector statistic, filter biases, calibration, ...).
    """

    t_s: np.ndarray
    pos_n_m: np.ndarray
    vel_n_mps: np.ndarray
    q_nb: np.ndarray
    stance: np.ndarray
    steps: dict
    summary: dict
    warnings: list
    metrics: dict | None
    raw: Any = field(repr=False)

    def __repr__(self) -> str:
        s = self.summary
        return (f"PathResult({len(self.t_s)} samples, {s.get('strides', 0)} strides, "
                f"{s.get('distance_m', 0.0):.2f} m, {len(self.warnings)} warnings)")

    def to_dataframe(self):
        """Per-sample table indexed by time ``t_s`` (s), the columns of ``trajectory.csv``: position ``x_m y_m
        z_m``, velocity ``vx_mps vy_mps vz_mps``, ``stance``, attitude ``qw qx qy qz`` (``q_nb``), the sensor's
        heading ``sensor_yaw_enu_rad`` / ``sensor_heading_deg_cw_from_north``.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        from bootnav.postproc.outputs import TRAJECTORY_COLUMNS, trajectory_columns

        pd = _pandas()
        cols = dict(zip(TRAJECTORY_COLUMNS, trajectory_columns(self.t_s, self.pos_n_m, self.vel_n_mps, self.stance,
                                                                self.q_nb)))
        cols["stance"] = self.stance
        return pd.DataFrame(cols, index=pd.Index(cols.pop("t_s"), name="t_s"))

    def steps_dataframe(self):
        """One row per stride indexed by its time ``t_s``, the other columns of ``steps.csv`` (pandas required,
        see ``to_dataframe``); the same name as ``StepResult.steps_dataframe``."""
        return _steps_frame(self.steps)

    def save(self, out_dir: str | Path, into_recording: bool = False, force: bool = False) -> dict[str, str]:
        """Write every output of ``bootnav process --out out_dir`` (``bootnav.postproc.outputs.write_outputs``).

        Parameters
        ----------
        out_dir
            Output directory (created).
        into_recording
            Also write ``/results`` into the input recording (atomically) instead of ``out_dir/results.h5``.
        force
            Overwrite existing files (an input is never overwritten).

        Returns
        -------
        dict
            {kind: path} of the files written.
        """
        from bootnav.postproc.outputs import write_outputs

        with _ApiWords():
            return write_outputs(self.raw, out_dir, into_recording, force)


def process(source, acc_mps2=None, gyro_radps=None, /, *, settings=None, calibration=None,
            progress: Callable[[str, float], None] | None = None, acc_unit: str = "mps2", gyro_unit: str = "radps",
            time_unit: str = "s", check_units: bool = True, **overrides) -> PathResult:
    """Reconstruct the walked 3-D path of a foot-mounted IMU (the ``bootnav process`` pipeline; writes nothing).

    Parameters
    ----------
    source
        A file path (``load``), a ``Recording``, the sample times ``t_s`` (N,) in s when ``acc_mps2``
        and ``gyro_radps`` follow, or a pandas DataFrame with the columns ``FRAME_COLUMNS`` names (``t_s``,
        ``ax_mps2`` ... ``gz_radps`` as in the canonical CSV; ``ax_g``, ``gx_dps``, ``t_ms`` declare other units).
    acc_mps2, gyro_radps : (N, 3) array_like, optional
        Specific force (m/s², gravity included) and angular rate (rad/s), body frame, for the arrays form.
    settings
        ``ProcessSettings``, a dict of it, or a JSON file; defaults when None.
    calibration
        The sensor calibration: a calibration file (``bootnav calibrate``), a
        ``bootnav.core.sensorcal.SensorCalibration``, or False for none; None (default) = the settings' choice
        (the stored calibration of the recording's device id, if any). ``summary["calibration"]`` says which ran.
    progress
        ``progress(stage, fraction)`` at stage boundaries.
    acc_unit, gyro_unit, time_unit
        Units of the arrays when not SI: ``"g"``, ``"dps"``, ``"ms"``/``"us"``.
    check_units
        Check the arrays' units against physics as ``bootnav import`` does (gravity at rest, gyro peaks, time
        step; ``bootnav.logger.importers.checks``): a mismatch is an error naming the keyword that fixes it.
        False keeps the arrays as given (a warning says what the check found).
    **overrides
        Fields of ``ProcessSettings``, applied on top of ``settings``; nested ones as dicts
        (``detector={"method": "shoe"}``) or by name (``detector="shoe"``); ``reference`` as a file, a dict
        (``{"closed_loop": True}``) or ``"truth"``.

    Returns
    -------
    PathResult
        Every warning (``warnings``) is also issued as a Python warning, category
        ``bootnav.errors.BootnavWarning``.

    Raises
    ------
    bootnav.errors.InputError
        Unknown setting, bad arrays or file, arrays in other units than declared, input that cannot be a
        walking foot (the message says why).
    """
    from bootnav.postproc.pipeline import process as run
    from bootnav.postproc.settings import ProcessSettings

    notes: list = []
    units = dict(acc_unit=acc_unit, gyro_unit=gyro_unit, time_unit=time_unit, check_units=check_units)
    with _ApiWords():
        chosen, given = _calibration_choice(_settings(ProcessSettings, settings, overrides), calibration)
        arrays = _source_and_units(source, acc_mps2, gyro_radps, True, units)
        if arrays is not None:
            source = _recording_of_arrays(*arrays[:3], notes=notes, **arrays[3])
        else:
            _check_source(source, "process(source)", "acc_mps2 and gyro_radps")
        res = _path_result(run(source, chosen, progress, calibration=given))
    res.warnings[:0] = notes
    _warn(res.warnings)
    return res


def _calibration_choice(settings, calibration):
    """(settings, calibration object or None) for ``pipeline.process``: a path goes into the settings (saved with
    the results), False disables, an object is passed through (settings say "given")."""
    from bootnav.errors import InputError

    if calibration is None:
        return settings, None
    settings = type(settings).from_dict(settings.to_dict())  # never change the caller's settings object
    cal = settings.calibration
    cal.accel_calibration_file = None
    if calibration is False:
        cal.sensor_calibration = "none"
        return settings, None
    if isinstance(calibration, (str, Path)):
        cal.sensor_calibration = str(calibration)
        return settings, None
    from bootnav.core.sensorcal import SensorCalibration

    if not isinstance(calibration, SensorCalibration):
        raise InputError(f"calibration must be a file path, a SensorCalibration or False; got "
                         f"{type(calibration).__name__}")
    cal.sensor_calibration = "given"
    return settings, calibration


def _path_result(r) -> PathResult:
    """A ``PathResult`` of a ``pipeline.ProcessResult`` (stride table with both heading columns)."""
    from bootnav.postproc.outputs import heading_columns

    steps = {**{k: np.asarray(v) for k, v in r.steps.items()}, **heading_columns(r.steps["yaw_enu_rad"])}
    return PathResult(r.t_s, r.pos_n, r.vel_n, r.q_nb, r.stance, steps, r.summary, r.warnings, r.metrics, r)


@dataclass
class TwoBootPathResult:
    """Both feet of one walker fused by ``process_two_boots`` (nav frame ENU = the left foot's, origin at the
    left sensor's start; the session clock).

    Attributes
    ----------
    left, right : PathResult
        Each fused foot as ``process`` returns one foot (path, stance, strides, summary; ``save`` writes the
        files of ``bootnav process --two-boots``'s ``left/`` or ``right/``).
    left_alone, right_alone : PathResult
        Each foot processed alone (its own frame and origin; for comparison).
    walker_t_s : (N,) array
        Times of the walker's path, s (the left foot's samples).
    walker_pos_n_m : (N, 3) array
        The walker: midpoint of the two fused feet, m.
    strides : dict of arrays
        Both feet's strides in time order (``strides.csv``): ``foot`` ("left"/"right"), ``t_s``, footprint
        ``x_m y_m z_m``, ``stride_length_m``, ``dz_m``, ``yaw_enu_rad``, ``heading_deg_cw_from_north``,
        ``step_width_m`` (NaN where undefined: ``twoboots.gaitmetrics``).
    summary : dict
        Everything ``two_boots.json`` holds (each foot alone and fused, walker distance, constraint updates,
        clock check, frame alignment, both settings objects).
    raw : bootnav.postproc.twoboots.run.TwoBootResult
    """

    left: PathResult
    right: PathResult
    left_alone: PathResult
    right_alone: PathResult
    walker_t_s: np.ndarray
    walker_pos_n_m: np.ndarray
    strides: dict
    summary: dict
    raw: Any = field(repr=False)

    def __repr__(self) -> str:
        c = self.summary["constraint"]
        return (f"TwoBootPathResult({self.summary['walker']['distance_m']:.2f} m walked, "
                f"{len(self.strides['t_s'])} strides, bound active at {c['active_updates']} of {c['checks']} checks)")

    def stride_lengths_m(self, foot: str) -> np.ndarray:
        """Stride lengths of ``"left"`` or ``"right"``, m, in time order."""
        return self.strides["stride_length_m"][self.strides["foot"] == foot]

    def to_dataframe(self):
        """The walker's path and both fused feet per sample, the columns of ``walker.csv`` (pandas required)."""
        from bootnav.postproc.twoboots.outputs import walker_columns

        header, cols = walker_columns(self.raw)
        return _pandas().DataFrame(dict(zip(header, cols)))

    def strides_dataframe(self):
        """One row per stride of either foot indexed by its time ``t_s``, the other columns of ``strides.csv``
        (pandas required)."""
        return _steps_frame(self.strides)

    def save(self, out_dir: str | Path, force: bool = False) -> dict[str, str]:
        """Write every output of ``bootnav process --two-boots --out out_dir``.

        Parameters
        ----------
        out_dir
            Output directory (created).
        force
            Overwrite existing files.

        Returns
        -------
        dict
            {kind: path} of the files written.
        """
        from bootnav.postproc.twoboots.outputs import check_outputs, write_two_boot_outputs

        with _ApiWords():
            check_outputs(self.raw.settings, out_dir, [], force)
            return write_two_boot_outputs(self.raw, out_dir, force)


def _steps_frame(columns: dict):
    """A DataFrame of per-step columns indexed by their ``t_s``."""
    pd = _pandas()
    return pd.DataFrame({k: v for k, v in columns.items() if k != "t_s"},
                        index=pd.Index(np.asarray(columns["t_s"]), name="t_s"))


def _foot_source(source, name: str):
    """A path or ``Recording`` as it is; a tuple (t_s, acc_mps2, gyro_radps) of arrays as a ``Recording``."""
    from bootnav.errors import InputError

    if isinstance(source, (tuple, list)):
        if len(source) != 3:
            raise InputError(f"process_two_boots: {name} as arrays is (t_s, acc_mps2, gyro_radps); got {len(source)} "
                             "items")
        return _recording_of_arrays(*source)
    return source


def process_two_boots(left, right=None, /, *, boots=None, settings=None, two_boot=None,
                      progress: Callable[[str, float], None] | None = None, **overrides) -> TwoBootPathResult:
    """Fuse both feet of one walker (``bootnav process --two-boots``; writes nothing).

    Each foot is processed alone, the right foot's frame is turned onto the left one, then both filters run in
    lockstep with the maximum-separation bound ‖p_L − p_R‖ ≤ γ [Skog2012] (``bootnav.postproc.twoboots``).

    Parameters
    ----------
    left, right
        Each foot: a file path, a ``Recording`` or a tuple ``(t_s, acc_mps2, gyro_radps)`` of arrays (s, m/s²
        with gravity, rad/s; both on one clock). Only ``left``: a multi-boot recording (``bootnav record
        --port A --port B``), whose boots ``boots`` (default ``left`` and ``right``, else the first two) are used.
    boots : (str, str), optional
        Labels of the left and right boot in a multi-boot recording.
    settings
        ``ProcessSettings`` of both feet, a dict of it, or a JSON file; defaults when None.
    two_boot
        ``TwoBootSettings`` or a dict of its fields (bound ``max_separation_m``, clock, start posture, ...).
    progress
        ``progress(stage, fraction)``.
    **overrides
        Fields of ``ProcessSettings`` (nested ones as dicts), applied on top of ``settings``.

    Returns
    -------
    TwoBootPathResult

    Raises
    ------
    bootnav.errors.InputError
        Unknown setting, bad arrays or file, a single-boot file without ``right``, recordings that do not
        overlap in time, the paper (riccati) mode.

    Examples
    --------
    ::

        import bootnav

        both = bootnav.process_two_boots("both.h5")         # one multi-boot recording (or LEFT, RIGHT)
        both.walker_pos_n_m[-1]                             # where the walker ended, m
        both.stride_lengths_m("left"), both.stride_lengths_m("right")
        both.strides["step_width_m"]                        # per stride, NaN where undefined
        both.left.pos_n_m, both.left_alone.pos_n_m          # a foot fused and alone
        bootnav.process_two_boots("l.h5", "r.h5", two_boot={"max_separation_m": 0.9}).save("out/")
    """
    from bootnav.errors import InputError
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.twoboots import TwoBootSettings
    from bootnav.postproc.twoboots.cli import boot_pair, is_multi_boot
    from bootnav.postproc.twoboots.outputs import fused_process_result, stride_rows
    from bootnav.postproc.twoboots.run import process_two_boots as run

    if right is None:
        if not (isinstance(left, (str, Path)) and is_multi_boot(str(left))):
            raise InputError(f"process_two_boots: give the right foot too, or one multi-boot recording (got {left!r})")
        left, right = boot_pair(left, boots)
    elif boots is not None:
        raise InputError("process_two_boots: boots= picks the boots of one multi-boot recording; drop it for two feet")
    tb = two_boot if isinstance(two_boot, TwoBootSettings) else TwoBootSettings.from_dict(two_boot)
    with _ApiWords():
        r = run(_foot_source(left, "left"), _foot_source(right, "right"),
                _settings(ProcessSettings, settings, overrides), tb, progress)
    _warn(r.summary.get("warnings", []))
    fused = {label: _path_result(fused_process_result(r, label)) for label in ("left", "right")}
    return TwoBootPathResult(fused["left"], fused["right"], _path_result(r.single["left"]),
                             _path_result(r.single["right"]), r.walker_t_s, r.walker_pos_n, stride_rows(r), r.summary,
                             r)


@dataclass
class StepResult:
    """Steps of ``pdr``: one row per detected step, positions after each step (origin at the start).

    Attributes
    ----------
    t_s, length_m, yaw_enu_rad, heading_deg_cw_from_north, x_m, y_m : (K,) arrays
        Step time (s), length (m), direction (counter-clockwise from east, rad; clockwise from north, deg)
        and position after the step (east, north, m).
    heading_source : str
        The sensor the directions come from ("none" when there was none: the directions are then
        meaningless, only the step count and lengths are).
    summary : dict
        Step count, distance, cadence, settings (``PdrResult.summary``).
    raw : bootnav.postproc.pdr.pipeline.PdrResult
        Detector events and trace, step features.
    """

    t_s: np.ndarray
    length_m: np.ndarray
    yaw_enu_rad: np.ndarray
    heading_deg_cw_from_north: np.ndarray
    x_m: np.ndarray
    y_m: np.ndarray
    heading_source: str
    summary: dict
    raw: Any = field(repr=False)

    def __repr__(self) -> str:
        return (f"StepResult({len(self.t_s)} steps, {float(np.sum(self.length_m)):.2f} m, "
                f"heading from {self.heading_source})")

    def steps_dataframe(self):
        """One row per step indexed by its time ``t_s``, the other columns of ``bootnav pdr``'s ``steps.csv``
        (pandas required); the same name as ``PathResult.steps_dataframe``.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        return _steps_frame({"t_s": self.t_s, "length_m": self.length_m, "yaw_enu_rad": self.yaw_enu_rad,
                             "heading_deg_cw_from_north": self.heading_deg_cw_from_north, "x_m": self.x_m,
                             "y_m": self.y_m})

    to_dataframe = steps_dataframe  # the name of earlier releases


def pdr(source, acc_mps2=None, gyro_radps=None, /, *, mag_b=None, settings=None, acc_unit: str = "mps2",
        gyro_unit: str = "radps", time_unit: str = "s", check_units: bool = True, **overrides) -> StepResult:
    """Step-and-heading dead reckoning (``bootnav pdr``) for sensors not on the foot: waist, hand, phone.

    Parameters
    ----------
    source
        A file path (``bootnav pdr`` reads it: recordings, canonical IMU CSV, phone exports with
        magnetometer/compass/GPS columns), a ``Recording``, the sample times ``t_s`` (N,) in s when
        ``acc_mps2`` follows, or a DataFrame (column names as for ``process``; the gyro columns optional).
    acc_mps2 : (N, 3) array_like, optional
        Specific force (or a phone's linear acceleration), m/s², sensor frame.
    gyro_radps : (N, 3) array_like, optional
        Angular rate, rad/s (gyro heading).
    mag_b : (N, 3) array_like, optional
        Magnetometer, any unit (magnetic heading), arrays form only.
    settings
        ``PdrSettings``, a dict of it, or a JSON file; defaults when None.
    acc_unit, gyro_unit, time_unit, check_units
        As for ``process`` (a phone's linear acceleration, without gravity, passes the gravity check).
    **overrides
        Fields of ``PdrSettings`` (e.g. ``detector="robust"``, ``heading="gyro"``).

    Returns
    -------
    StepResult
        Its warnings (``summary["warnings"]``) are also issued as ``bootnav.errors.BootnavWarning``.

    Raises
    ------
    bootnav.errors.InputError
        Unknown setting, bad arrays or file, a heading method whose sensor is missing.
    """
    from bootnav.logger.recording import Recording
    from bootnav.postproc.outputs import heading_columns
    from bootnav.postproc.pdr.pipeline import PdrSettings, run_pdr

    s = _settings(PdrSettings, settings, overrides)
    extra: dict = {}
    notes: list = []
    units = dict(acc_unit=acc_unit, gyro_unit=gyro_unit, time_unit=time_unit, check_units=check_units)
    arrays = _source_and_units(source, acc_mps2, gyro_radps, False, units)
    if arrays is not None:
        t, acc, gyro = _arrays(*arrays[:3], need_gyro=False, specific_force=False, notes=notes, **arrays[3])
        if mag_b is not None:
            from bootnav.errors import InputError

            mag_b = _numbers(mag_b, "mag_b", "pdr(..., mag_b=)")
            if mag_b.shape != (len(t), 3):
                raise InputError(f"pdr(..., mag_b=): expected the magnetometer as (N, 3) = ({len(t)}, 3) like "
                                 f"acc_mps2, got {mag_b.shape}")
        extra["mag_b"] = mag_b
    elif isinstance(source, Recording):
        from bootnav.postproc.pdr.io import PdrInput, calibrated

        inp, _ = calibrated(PdrInput(source.t_s, source.acc_mps2, source.gyro_radps, None, "recording", "recording",
                                     device_id=source.meta.get("device_id"), temp_degc=source.temp_degc),
                            s.sensor_calibration)
        t, acc, gyro = inp.t_s, inp.acc_b, inp.gyro_b
    else:
        from bootnav.postproc.pdr.io import calibrated, load_input

        _check_source(source, "pdr(source)", "acc_mps2")
        inp, _ = calibrated(load_input(source), s.sensor_calibration)
        t, acc, gyro = inp.t_s, inp.acc_b, inp.gyro_b
        extra = {"mag_b": inp.mag_b, "compass_deg": inp.compass_deg, "gps": inp.gps}
    with _ApiWords():
        r = run_pdr(t, acc, gyro, s, **extra)
    h = heading_columns(r.yaw_enu_rad)
    summary = r.summary()
    summary["warnings"] = notes + list(summary.get("warnings", []))
    _warn(summary["warnings"])
    return StepResult(r.t_s, r.length_m, h["yaw_enu_rad"], h["heading_deg_cw_from_north"], r.x_m, r.y_m,
                      r.heading_source, summary, r)
