"""Every tunable of ``bootnav process`` in one tree of dataclasses, saved with every result (OpenShoe style).

``ProcessSettings`` composes the stage settings (calibration, stance detector, filter) and the pipeline's
own options. ``to_dict``/``from_dict``/``to_json``/``from_json`` round-trip exactly; ``from_dict`` rejects
unknown keys with the dotted path of the offending key, so a typo in a settings file never goes unnoticed.
A partial dict only overrides what it names (everything else keeps its default).
"""

from __future__ import annotations

import dataclasses
import json
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bootnav.errors import InputError

from .calibration import CalibrationSettings
from .detectors import DetectorSettings
from .ins import FilterSettings


@dataclass
class InputChecks:
    """Sanity limits that turn bad input into a clear error instead of a garbage path.

    min_duration_s: shortest recording worth processing (s): an initial still period plus a few strides.
    min_stance_phases: fewer stance phases than this means the detector found no walking (no ZUPT, no path).
    min_stance_fraction / max_stance_fraction: a walking foot rests ~25-60 % of the time (running ~20 %);
        outside these bounds the detector is mis-tuned or the sensor is not on a foot.
    max_stance_gyro_radps: median |ω| over the stance samples above this means "stance" is not a resting
        foot (a foot flat on the ground turns at < 0.1 rad/s; the sensor noise is ~0.01 rad/s).
    max_stride_length_m: a foot cannot move further than this between two stance phases (sprint strides
        are ~5 m); longer "strides" mean missed stance phases, i.e. unbounded INS drift in between.
    max_long_stride_fraction: more than this fraction of such strides is an error (fewer: a warning).
    gap_factor: an interval longer than ``gap_factor`` × median interval is reported as a gap.
    max_gap_s: a gap longer than this is an error (the strapdown integration cannot bridge it).
    """

    min_duration_s: float = 3.0
    min_stance_phases: int = 2
    min_stance_fraction: float = 0.05
    max_stance_fraction: float = 0.98
    max_stance_gyro_radps: float = 0.5
    max_stride_length_m: float = 6.0
    max_long_stride_fraction: float = 0.1
    gap_factor: float = 3.0
    max_gap_s: float = 1.0


@dataclass
class OutputSettings:
    """What ``bootnav process --out DIR`` writes.

    results_name: name of the ``/results/<name>`` group in the HDF5 recording.
    write_hdf5: write the results group (into the input recording, or DIR/results.h5 for a CSV input).
    plots: write the PNG charts 1-7.
    geojson: write ``path.geojson`` (local metres, or WGS-84 with ``geo_anchor``).
    geo_anchor: (lat_deg, lon_deg[, height_m]) of the nav-frame origin for WGS-84 GeoJSON, or None.
    plot_max_points: longest line drawn per chart (longer signals are decimated for plotting only).
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

    crop_s: (t0, t1) window in recording seconds to process (the paper processes 103-176 s), or None.
    floor_height_m: storey height for floor counting (m); floor_hysteresis_m, floor_stair_min_dz_m: see
        ``strides.FloorSettings`` (None = floors from the footprint height; a value = from stair strides
        only, default 0.1 m: on a simulated 1 h walk the z drift of -16 m counted 8 floors up and 13 down from
        the height, 0/0 (the truth) from the stair strides; the three-floor climb counts 3 either way).
    reference: reference file for Table 1 metrics (``bootnav.postproc.reference``), or None.
    """

    calibration: CalibrationSettings = field(default_factory=CalibrationSettings)
    detector: DetectorSettings = field(default_factory=DetectorSettings)
    filter: FilterSettings = field(default_factory=FilterSettings)
    checks: InputChecks = field(default_factory=InputChecks)
    output: OutputSettings = field(default_factory=OutputSettings)
    crop_s: tuple[float, float] | None = None
    floor_height_m: float = 3.0
    floor_hysteresis_m: float = 0.5
    floor_stair_min_dz_m: float | None = 0.1
    reference: str | None = None

    def validate(self) -> None:
        """Raise InputError naming the first bad setting (before any work is done)."""
        checks = [
            ("floor_height_m / floor_hysteresis_m", lambda: self.floor_settings()),
            ("calibration (latitude_deg, height_m, gravity_mps2)", self._check_gravity),
            ("filter", lambda: getattr(self.filter, "validate", lambda: None)()),
            ("crop_s", self._check_crop),
            ("output.geo_anchor", self._check_anchor),
        ]
        for what, check in checks:
            try:
                check()
            except (ValueError, TypeError) as exc:
                raise InputError(f"settings {what}: {exc}") from None

    def floor_settings(self):
        from .strides import FloorSettings

        return FloorSettings(self.floor_height_m, self.floor_hysteresis_m, self.floor_stair_min_dz_m)

    def _check_gravity(self):
        g = self.calibration.gravity()
        if not 9.0 < g < 10.5:
            raise ValueError(f"gravity {g} m/s^2 is not an Earth value (9.78-9.84 at sea level)")

    def _check_crop(self):
        if self.crop_s is not None and not (len(self.crop_s) == 2 and float(self.crop_s[1]) > float(self.crop_s[0])):
            raise ValueError(f"expected (t0, t1) with t1 > t0, got {self.crop_s}")

    def _check_anchor(self):
        a = self.output.geo_anchor
        if a is not None and not (len(a) in (2, 3) and -90 < float(a[0]) < 90 and -180 <= float(a[1]) <= 180):
            raise ValueError(f"expected (lat, lon[, h]) with lat in (-90, 90), lon in [-180, 180], got {a}")

    def to_dict(self) -> dict:
        return _to_plain(self)

    def to_json(self, indent: int | None = 1) -> str:
        return json.dumps(self.to_dict(), indent=indent, allow_nan=True)

    @classmethod
    def from_dict(cls, data: dict | None) -> "ProcessSettings":
        return _from_plain(cls, data or {}, "")

    @classmethod
    def from_json(cls, text: str) -> "ProcessSettings":
        return cls.from_dict(json.loads(text))

    @classmethod
    def from_file(cls, path: str | Path) -> "ProcessSettings":
        from bootnav.jsonfile import read_json_file

        path = Path(path)
        data = read_json_file(path, "settings file")
        try:
            return cls.from_dict(data)
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from None

    def save(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(self.to_json() + "\n")
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


def _from_plain(cls, data: Any, where: str):
    if not isinstance(data, dict):
        raise InputError(f"settings{where}: expected an object for {cls.__name__}, got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise InputError(f"settings{where}: unknown key(s) {unknown} for {cls.__name__}; known: {sorted(fields)}")
    kwargs = {}
    for name, value in data.items():
        hint = hints.get(name)
        if dataclasses.is_dataclass(hint):
            kwargs[name] = _from_plain(hint, value, f"{where}.{name}")
        elif isinstance(value, list) and _is_tuple_hint(hint):
            kwargs[name] = tuple(value)
        else:
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
