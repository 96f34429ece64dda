"""The Python API, for notebooks and scripts: ``bootnav.load``, ``bootnav.process``, ``bootnav.pdr``.

::

    import bootnav

    rec = bootnav.load("walk.h5")                     # a recording, or any file `bootnav import` reads
    res = bootnav.process(rec, reference='{"closed_loop": true}')
    res.pos_n_m, res.stance, res.steps["stride_length_m"], res.summary["distance_m"]
    res = bootnav.process(t_s, acc_mps2, gyro_radps)  # or straight from arrays (SI units, body frame)
    df = res.to_dataframe()                           # pandas (optional), columns as trajectory.csv
    res.save("out/")                                  # every file `bootnav process --out out/` writes
    steps = bootnav.pdr(t_s, acc_mps2, gyro_radps)    # step-and-heading for waist / phone sensors
    both = bootnav.process_two_boots("left.h5", "right.h5")  # two feet of one walker, fused (or one multi-boot file)
    both.left.pos_n_m, both.walker_pos_n_m, both.strides["step_width_m"], both.save("out/")

Settings are given as keywords: any field of ``bootnav.postproc.settings.ProcessSettings`` (``PdrSettings``
for ``pdr``), nested ones as dicts, e.g. ``process(rec, crop_s=(0, 60), detector={"method": "shoe", "params": {"threshold":
2e5}})`` (a detector's parameters are the fields of its class, validated as a settings file's are); or a
whole object / dict / JSON file as ``settings=``. Frames and units: ``bootnav.CONVENTIONS``.

``import bootnav`` imports none of this (nor numpy): the package resolves these names on first use.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

__all__ = ["load", "process", "process_two_boots", "pdr", "PathResult", "StepResult", "TwoBootPathResult"]


def load(path: str | Path):
    """Read a recording: a bootnav HDF5 file or any file ``bootnav import`` reads (CSV, SD-card log, ...).

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    bootnav.logger.recording.Recording
        ``t_s`` (N,), ``acc_mps2`` and ``gyro_radps`` (N, 3) in SI units and the body frame, ``meta``,
        ``events``, ``saturated``.

    Raises
    ------
    bootnav.errors.InputError
        Missing or unreadable file.
    """
    from bootnav.postproc.source import load_source

    return load_source(path).recording


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


def _settings(cls, settings, overrides: dict):
    """A settings object from ``settings`` (object, dict, JSON file or None) and keyword overrides."""
    if settings is None:
        base = cls()
    elif isinstance(settings, cls):
        base = settings
    elif isinstance(settings, dict):
        base = cls.from_dict(settings)
    else:
        base = cls.from_file(settings)
    return cls.from_dict(_merged(base.to_dict(), overrides)) if overrides else base


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


def _arrays(t_s, acc_mps2, gyro_radps, need_gyro: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    from bootnav.errors import InputError

    fn = "process(t_s, acc_mps2, gyro_radps)" if need_gyro else "pdr(t_s, acc_mps2, gyro_radps)"
    t = _numbers(t_s, "t_s", fn)
    acc = _numbers(acc_mps2, "acc_mps2", fn)
    gyro = None if gyro_radps is None else _numbers(gyro_radps, "gyro_radps", fn)
    if gyro is None and need_gyro:
        raise InputError("process(t_s, acc_mps2, gyro_radps): the gyroscope is required")
    if t.ndim != 1 or acc.shape != (len(t), 3) or (gyro is not None and gyro.shape != (len(t), 3)):
        raise InputError(f"expected t_s (N,), acc_mps2 (N, 3), gyro_radps (N, 3); got {t.shape}, {acc.shape}, "
                         f"{None if gyro is None else gyro.shape}")
    return t, acc, gyro


def _recording_of_arrays(t_s, acc_mps2, gyro_radps):
    from bootnav.logger.recording import Recording, make_events

    t, acc, gyro = _arrays(t_s, acc_mps2, gyro_radps)
    return Recording(path=None, t_s=t, acc_mps2=acc, gyro_radps=gyro, saturated=np.zeros(len(t), np.uint8),
                     events=make_events([]), meta={"source_file": "arrays"}, attrs={})


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
        """Per-sample table, the columns of ``trajectory.csv`` (``t_s, x_m ... vz_mps, stance``).

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        pd = _pandas()
        p, v = self.pos_n_m, self.vel_n_mps
        return pd.DataFrame({"t_s": self.t_s, "x_m": p[:, 0], "y_m": p[:, 1], "z_m": p[:, 2], "vx_mps": v[:, 0],
                             "vy_mps": v[:, 1], "vz_mps": v[:, 2], "stance": self.stance})

    def steps_dataframe(self):
        """One row per stride, the columns of ``steps.csv`` (pandas required, see ``to_dataframe``)."""
        return _pandas().DataFrame(self.steps)

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

        return write_outputs(self.raw, out_dir, into_recording, force)


def process(source, acc_mps2=None, gyro_radps=None, /, *, settings=None,
            progress: Callable[[str, float], None] | None = None, **overrides) -> PathResult:
    """Reconstruct the walked 3-D path of a foot-mounted IMU (the ``bootnav process`` pipeline; writes nothing).

    Parameters
    ----------
    source
        A file path (``load``), a ``Recording``, or the sample times ``t_s`` (N,) in s when ``acc_mps2``
        and ``gyro_radps`` follow.
    acc_mps2, gyro_radps : (N, 3) array_like, optional
        Specific force (m/s², gravity included) and angular rate (rad/s), body frame, for the arrays form.
    settings
        ``ProcessSettings``, a dict of it, or a JSON file; defaults when None.
    progress
        ``progress(stage, fraction)`` at stage boundaries.
    **overrides
        Fields of ``ProcessSettings`` (nested ones as dicts), applied on top of ``settings``.

    Returns
    -------
    PathResult

    Raises
    ------
    bootnav.errors.InputError
        Unknown setting, bad arrays or file, input that cannot be a walking foot (the message says why).
    """
    from bootnav.postproc.pipeline import process as run
    from bootnav.postproc.settings import ProcessSettings

    if acc_mps2 is not None or gyro_radps is not None:
        source = _recording_of_arrays(source, acc_mps2, gyro_radps)
    _check_source(source, "process(source)", "acc_mps2 and gyro_radps")
    return _path_result(run(source, _settings(ProcessSettings, settings, overrides), progress))


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
        """One row per stride of either foot, the columns of ``strides.csv`` (pandas required)."""
        return _pandas().DataFrame(self.strides)

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

        check_outputs(self.raw.settings, out_dir, [], force)
        return write_two_boot_outputs(self.raw, out_dir, force)


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
    r = run(_foot_source(left, "left"), _foot_source(right, "right"), _settings(ProcessSettings, settings, overrides),
            tb, progress)
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

    def to_dataframe(self):
        """One row per step, the columns of ``bootnav pdr``'s ``steps.csv`` (pandas required).

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        ImportError
            pandas is not installed.
        """
        return _pandas().DataFrame({"t_s": self.t_s, "length_m": self.length_m, "yaw_enu_rad": self.yaw_enu_rad,
                                    "heading_deg_cw_from_north": self.heading_deg_cw_from_north,
                                    "x_m": self.x_m, "y_m": self.y_m})


def pdr(source, acc_mps2=None, gyro_radps=None, /, *, mag_b=None, settings=None, **overrides) -> StepResult:
    """Step-and-heading dead reckoning (``bootnav pdr``) for sensors not on the foot: waist, hand, phone.

    Parameters
    ----------
    source
        A file path (``bootnav pdr`` reads it: recordings, canonical IMU CSV, phone exports with
        magnetometer/compass/GPS columns), a ``Recording``, or the sample times ``t_s`` (N,) in s when
        ``acc_mps2`` follows.
    acc_mps2 : (N, 3) array_like, optional
        Specific force (or a phone's linear acceleration), m/s², sensor frame.
    gyro_radps : (N, 3) array_like, optional
        Angular rate, rad/s (gyro heading).
    mag_b : (N, 3) array_like, optional
        Magnetometer, any unit (magnetic heading), arrays form only.
    settings
        ``PdrSettings``, a dict of it, or a JSON file; defaults when None.
    **overrides
        Fields of ``PdrSettings`` (e.g. ``detector="robust"``, ``heading="gyro"``).

    Returns
    -------
    StepResult

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
    if acc_mps2 is not None:
        t, acc, gyro = _arrays(source, acc_mps2, gyro_radps, need_gyro=False)
        if mag_b is not None:
            from bootnav.errors import InputError

            mag_b = _numbers(mag_b, "mag_b", "pdr(..., mag_b=)")
            if mag_b.shape != (len(t), 3):
                raise InputError(f"pdr(..., mag_b=): expected the magnetometer as (N, 3) = ({len(t)}, 3) like acc_mps2, "
                                 f"got {mag_b.shape}")
        extra["mag_b"] = mag_b
    elif isinstance(source, Recording):
        t, acc, gyro = source.t_s, source.acc_mps2, source.gyro_radps
    else:
        from bootnav.postproc.pdr.io import load_input

        _check_source(source, "pdr(source)", "acc_mps2")

        inp = load_input(source)
        t, acc, gyro = inp.t_s, inp.acc_b, inp.gyro_b
        extra = {"mag_b": inp.mag_b, "compass_deg": inp.compass_deg, "gps": inp.gps}
    r = run_pdr(t, acc, gyro, s, **extra)
    h = heading_columns(r.yaw_enu_rad)
    return StepResult(r.t_s, r.length_m, h["yaw_enu_rad"], h["heading_deg_cw_from_north"], r.x_m, r.y_m,
                      r.heading_source, r.summary(), r)
