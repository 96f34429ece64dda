"""Every tunable of ``bootnav process`` in one tree of dataclasses, saved with every result.

One settings object per run, written into ``summary.json`` and the HDF5 results group, so a result always
says how it was made (OpenShoe keeps all its parameters in one settings file for the same reason
[Nilsson2012]). ``ProcessSettings`` composes the stage settings (calibration, stance detector, filter) and the
pipeline's own options. ``to_dict``/``from_dict``/``to_json``/``from_json`` round-trip exactly; ``from_dict``
rejects unknown keys with the dotted path of the offending key, so a typo in a settings file never goes
unnoticed. A partial dict only overrides what it names (everything else keeps its default).

The experiments behind the defaults are in ``docs/tuning-log.md``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bootnav.core import atomic
from bootnav.core.validate import check_value
from bootnav.errors import InputError

from .calibration import CalibrationSettings
from .detectors import DetectorSettings
from .ins import FilterSettings
from .selftune import SelfTuneSettings
from .strides import FloorSettings


@dataclass
class InputChecks:
    """Limits that turn implausible input or results into a clear message (``checks``) instead of a garbage path.

    Attributes
    ----------
    min_duration_s : float, s
        Shortest input worth processing: an initial still period for the alignment plus a few strides
        (a walking stride takes about 1 s [Perry2010]).
    min_stance_phases : int
        Fewer stance phases mean no stride at all (a stride goes from one stance phase to the next), so no
        zero-velocity update bounds the drift [Foxlin2005].
    min_stance_fraction, max_stance_fraction : float, fraction of samples
        Plausible share of stance samples. The stance phase is about 60 % of a walking gait cycle [Perry2010]
        and the detected foot-flat part less (running: about 20 %); the bounds are wide, so only a mis-tuned
        detector or a sensor that is not on a foot falls outside.
    max_stance_gyro_radps : float, rad/s
        A median ``|ω|`` over the stance samples above this means the "stance" is not a resting foot: a foot
        flat on the ground turns at < 0.1 rad/s and MEMS gyro noise is about 0.01 rad/s, so 0.5 leaves a
        5x margin.
    max_stride_length_m : float, m (3-D)
        No foot moves further than this between two stance phases (elite sprint strides are about 5 m);
        a longer "stride" means missed stance phases, i.e. unaided INS drift in between [Foxlin2005].
    max_long_stride_fraction : float
        More than this share of such strides is an error (the detector misses stance systematically);
        fewer are a warning (an isolated jump or kick).
    max_gap_s : float, s
        A longer gap is an error: it can hide a whole stride (about 1 s [Perry2010]), which no strapdown
        integration recovers.
    """

    min_duration_s: float = 3.0
    min_stance_phases: int = 2
    min_stance_fraction: float = 0.05
    max_stance_fraction: float = 0.98
    max_stance_gyro_radps: float = 0.5
    max_stride_length_m: float = 6.0
    max_long_stride_fraction: float = 0.1
    max_gap_s: float = 1.0


@dataclass
class OutputSettings:
    """What ``bootnav process --out DIR`` writes (``outputs``).

    Attributes
    ----------
    results_name : str
        Name of the ``/results/<name>`` group in the HDF5 recording (several runs can live side by side).
    write_hdf5 : bool
        Write the results group into ``OUT/results.h5`` (a copy of the recording plus ``/results/<name>``;
        into the input recording itself only with ``bootnav process --into-recording``, atomically).
    plots : bool
        Write the PNG charts 1-7 [Heidari2019, Charts 1-7] and ``path.html``.
    geojson : bool
        Write ``path.geojson`` (only with a ``geo_anchor``: GIS tools read GeoJSON as WGS-84).
    geo_anchor : tuple of float or None, (deg, deg[, m])
        WGS-84 latitude, longitude (and ellipsoidal height) of the nav-frame origin; with it GeoJSON is
        in WGS-84 through a local tangent plane [Groves2013, ch. 2]; without it no GeoJSON is written.
    plot_max_points : int
        Most points of a path line (charts 4-6 and path.html); longer paths keep, per time column, the samples at
        each coordinate's extremes (``decimate.PathExtremes``; 20000 points are more than a chart has pixels, so
        the thinning is invisible). The time charts always draw min/max per pixel column (``decimate``).
    """

    results_name: str = "default"
    write_hdf5: bool = True
    plots: bool = True
    geojson: bool = True
    geo_anchor: tuple[float, ...] | None = None
    plot_max_points: int = 20000


@dataclass
class ProcessSettings:
    """All settings of one ``process`` run.

    Attributes
    ----------
    calibration, detector, filter : CalibrationSettings, DetectorSettings, FilterSettings
        The stage settings (``calibration``, ``detectors``, ``ins``), documented there.
    checks : InputChecks
        Plausibility limits.
    selftune : SelfTuneSettings
        The stance fallback, stride quality flags, the minimum stride and the vertical timing calibration
        (``selftune``, the passes of ``pipeline``).
    output : OutputSettings
        What is written.
    crop_s : tuple of float or None, (s, s)
        Window ``(t0, t1)`` in recording seconds to process, or None for all (the paper processes 103-176 s
        of its stairs recording [Heidari2019]).
    floor_height_m : float, m
        Storey height for counting floors (``strides.FloorSettings``); 3 m is a typical storey, set it per
        building.
    floor_hysteresis_m : float, m
        Height beyond the half-storey boundary before a level change counts: a landing halfway or a few
        centimetres of drift never toggle the count.
    floor_stair_min_dz_m : float or None, m
        Count floors from stair strides only (``|Δz| >=`` this per stride), or None to count from the
        footprint height. A stair stride climbs two risers (about 0.3 m) while the vertical drift of a ZUPT
        INS adds millimetres per flat stride, so 0.1 m removes the drift and keeps every flight; the price
        is that a gentle ramp never counts. Used only with ``floor_storeys`` off: the storeys hold the heights
        on floors already.
    floor_storeys : bool
        Keep the height on discrete storeys where the stairs say so (``floors``): flights counted in risers,
        a landing set to the storey estimate only when the riser count and the climbed height agree, and to
        the height of a level visited before when it is within half a riser. On by default; False = the
        filter's heights as they are.
    floor_riser_min_m, floor_riser_max_m : float, m
        Range of a riser's height: 0.15–0.20 m (issue 24; building codes allow about 0.14–0.20 m).
    ellipse_scale_sigma, ellipse_cross_axis_rad : float
        1σ of the sensor's scale error (relative) and horizontal cross-axis angle (rad) added to every stride's
        uncertainty ellipse (``ellipses``: the filter does not model them) when no sensor calibration is
        applied: the MPU-6050 datasheet's ±3 % scale and ±2 % cross-axis tolerances read as limits of a
        rectangular distribution, a/√3 [GUM2008, 4.3.7]. 0 = the filter's covariance alone.
    ellipse_calibrated_sigma : float
        The same (both terms) when a sensor calibration is applied: ≈ 0.1 % left after ``bootnav calibrate``.
    reference : str or None
        Reference for the accuracy metrics (``reference_path``): a file, an inline JSON object, or ``"truth"``
        (a simulated recording's ``/truth``).
    block_s : float, s
        Seconds of samples ``bootnav process`` holds in memory at once (``pipeline.process_to``): the memory
        budget. A recording up to this long is one block, processed whole; a longer one runs as passes over
        blocks of this length, memory bounded by the block (``docs/long-recordings.md``). The whole-record
        stages need about 300 MB + 530 B per sample (``docs/tuning-log.md``, "Long recordings"): 900 s at
        200 Hz is about 400 MB whole, and the block passes of a recording of many hours use 410-440 MB in blocks
        of 900 s (at 1 and 3 h at 200 Hz; 300 s blocks: 310 MB), under the 500 MB budget. A quarter of an hour
        keeps every short walk (and the whole development datasets, at most 227 s) in one piece, where the
        stance fallback runs (``docs/long-recordings.md``).
    """

    calibration: CalibrationSettings = field(default_factory=CalibrationSettings)
    detector: DetectorSettings = field(default_factory=DetectorSettings)
    filter: FilterSettings = field(default_factory=FilterSettings)
    checks: InputChecks = field(default_factory=InputChecks)
    selftune: SelfTuneSettings = field(default_factory=SelfTuneSettings)
    output: OutputSettings = field(default_factory=OutputSettings)
    crop_s: tuple[float, float] | None = None
    floor_height_m: float = FloorSettings.floor_height_m  # the defaults' one home: strides.FloorSettings
    floor_hysteresis_m: float = FloorSettings.hysteresis_m
    floor_stair_min_dz_m: float | None = FloorSettings.stair_min_dz_m
    floor_storeys: bool = FloorSettings.storeys
    floor_riser_min_m: float = FloorSettings.riser_min_m
    floor_riser_max_m: float = FloorSettings.riser_max_m
    ellipse_scale_sigma: float = 0.03 / math.sqrt(3.0)
    ellipse_cross_axis_rad: float = 0.02 / math.sqrt(3.0)
    ellipse_calibrated_sigma: float = 0.001
    reference: str | None = None
    block_s: float = 900.0

    def validate(self) -> None:
        """Raise InputError naming the first bad setting (before any work is done)."""
        checks = [
            ("floor_height_m / floor_hysteresis_m / floor_riser_*", lambda: self.floor_settings()),
            ("calibration (latitude_deg, height_m, gravity_mps2)", self._check_gravity),
            ("filter", lambda: getattr(self.filter, "validate", lambda: None)()),
            ("crop_s", self._check_crop),
            ("block_s", self._check_block),
            ("ellipse_scale_sigma / ellipse_cross_axis_rad / ellipse_calibrated_sigma", self._check_ellipse),
            ("output.geo_anchor", self._check_anchor),
            ("output.results_name", self._check_results_name),
        ]
        for what, check in checks:
            try:
                check()
            except (ValueError, TypeError) as exc:
                raise InputError(f"settings {what}: {exc}") from None

    def floor_settings(self):
        """The floor-counting settings as ``strides.FloorSettings`` (validates them)."""
        return FloorSettings(self.floor_height_m, self.floor_hysteresis_m, self.floor_stair_min_dz_m, self.floor_storeys,
                             self.floor_riser_min_m, self.floor_riser_max_m)

    def _check_gravity(self):
        g = self.calibration.gravity()
        if not 9.0 < g < 10.5:
            raise ValueError(f"gravity {g} m/s^2 is not an Earth value (9.78-9.84 at sea level)")

    def _check_block(self):
        if not (isinstance(self.block_s, (int, float)) and math.isfinite(self.block_s) and self.block_s > 0):
            raise ValueError(f"expected a positive number of seconds, got {self.block_s!r}")

    def _check_ellipse(self):
        for v in (self.ellipse_scale_sigma, self.ellipse_cross_axis_rad, self.ellipse_calibrated_sigma):
            if not (math.isfinite(float(v)) and 0.0 <= float(v) < 0.5):
                raise ValueError(f"expected a relative error in [0, 0.5), got {v}")

    def _check_crop(self):
        if self.crop_s is not None and not (len(self.crop_s) == 2 and float(self.crop_s[1]) > float(self.crop_s[0])):
            raise ValueError(f"expected (t0, t1) with t1 > t0, got {self.crop_s}")

    def _check_anchor(self):
        a = self.output.geo_anchor
        if a is not None and not (len(a) in (2, 3) and all(math.isfinite(float(v)) for v in a)
                                  and -90 < float(a[0]) < 90 and -180 <= float(a[1]) <= 180
                                  and (len(a) == 2 or -500.0 <= float(a[2]) <= 10000.0)):
            raise ValueError(f"expected (lat, lon[, h]) with lat in (-90, 90) deg, lon in [-180, 180] deg and h in "
                             f"[-500, 10000] m (finite numbers), got {a}")

    def _check_results_name(self):
        # an HDF5 group name, and a folder-like name in outputs: no path separators, no '.'/'..'
        name = self.output.results_name
        if not (isinstance(name, str) and re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}", name)):
            raise ValueError(f"{name!r} is not a plain name (letters, digits, _ . -, up to 64, no '/' or '..')")

    def to_dict(self) -> dict:
        """Plain JSON-able dict of every setting (tuples as lists)."""
        return _to_plain(self)

    def to_json(self, indent: int | None = 1) -> str:
        """``to_dict`` as JSON text."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=True)

    @classmethod
    def from_dict(cls, data: dict | None) -> "ProcessSettings":
        """Settings from a full or partial dict (missing keys keep their defaults).

        Parameters
        ----------
        data
            As ``to_dict`` writes it, or any subset; None = defaults.

        Returns
        -------
        ProcessSettings

        Raises
        ------
        InputError
            An unknown key (named with its dotted path) or a value the dataclass refuses.
        """
        return from_plain(cls, data or {}, "")

    @classmethod
    def from_json(cls, text: str) -> "ProcessSettings":
        """``from_dict`` of JSON text."""
        return cls.from_dict(json.loads(text))

    @classmethod
    def from_file(cls, path: str | Path) -> "ProcessSettings":
        """``from_dict`` of a JSON file; errors name the file (and the line of a JSON syntax error)."""
        return settings_from_file(cls, path, "settings file")

    def save(self, path: str | Path) -> Path:
        """Write ``to_json`` to ``path``; returns the path."""
        path = Path(path)
        atomic.write_text(path, self.to_json() + "\n")  # crash-safe
        return path


def _to_plain(obj: Any) -> Any:
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _to_plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [_to_plain(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): _to_plain(v) for k, v in obj.items()}
    if hasattr(obj, "tolist"):  # numpy scalars / arrays
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    return obj


# Keys of settings files written by earlier versions whose setting no longer exists: ignored when read, so
# every saved summary.json still loads (the one gap rule of ``bootnav.core.timebase`` replaced both).
RETIRED_KEYS = {".filter.gap_factor", ".checks.gap_factor"}


def from_plain(cls, data: Any, where: str):
    if not isinstance(data, dict):
        raise InputError(f"settings{where}: expected an object for {cls.__name__}, got {type(data).__name__}")
    upgrade = getattr(cls, "upgrade_saved", None)  # a section whose layout changed reads its older form
    if upgrade is not None:
        data = upgrade(data)
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    data = {k: v for k, v in data.items() if f"{where}.{k}" not in RETIRED_KEYS}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise InputError(f"settings{where}: unknown key(s) {unknown} for {cls.__name__}; known: {sorted(fields)}")
    kwargs = {}
    for name, value in data.items():
        hint = hints.get(name)
        if dataclasses.is_dataclass(hint):
            kwargs[name] = from_plain(hint, value, f"{where}.{name}")
        elif isinstance(value, list) and _is_tuple_hint(hint):
            kwargs[name] = tuple(value)
        else:
            check_value(hint, value, f"{where}.{name}")
            kwargs[name] = value
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        raise InputError(f"settings{where}: {exc}") from None


def _is_tuple_hint(hint) -> bool:
    if hint is None:
        return False
    if typing.get_origin(hint) is tuple:
        return True
    return any(typing.get_origin(a) is tuple or a is tuple for a in typing.get_args(hint))


def settings_from_file(cls, path: str | Path, what: str):
    """``cls.from_dict`` of a JSON settings file; every error is one line naming the file (``what`` says which
    kind of settings it holds)."""
    from bootnav.core.jsonio import read_json_file

    path = Path(path)
    try:
        data = read_json_file(path, what)
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: {what} is not UTF-8 text (byte {exc.start}: "
                         f"{exc.object[exc.start:exc.start + 1]!r}); save it as UTF-8 JSON") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, expected a settings JSON file") from None
    try:
        return cls.from_dict(data)
    except InputError as exc:
        raise InputError(f"{path}: {exc}") from None
