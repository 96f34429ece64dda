"""Import profiles: how to read one family of files, as small TOML files.

A profile is a TOML table (see ``profiles/*.toml`` shipped in this package, or a user's file given as
``--profile my.toml``). Keys, all optional:

``name``, ``description``, ``source``                 text
``delimiter``                                       ``","`` ``";"`` ``"\\t"`` ``"whitespace"`` (default: sniffed)
``header``                                          true / false (default: auto)
``columns``                                         roles in file order, e.g. ``["t","gx","gy","gz","ax","ay","az"]``
``column_names``                                    {"header text" = "role"} overrides for named headers
``time``                                            ``"column"`` (default), ``"rtc_seconds"`` (1-s clock), ``"rate"`` (no time column)
``time_unit``                                       ``"s"`` ``"ms"`` ``"us"``
``rate_hz``                                         nominal rate (required with time = "rate")
``acc_unit`` / ``gyro_unit``                        ``"g" "mps2" "counts"`` / ``"dps" "radps" "counts"``
``acc_range_g`` / ``gyro_range_dps``                full scale (saturation; counts scale)
``ranges_from_filename``                            regex with groups ``a`` and ``g`` = MPU6050 AFS_SEL / FS_SEL codes
``acc_quantity``                                    ``"specific_force"`` (default) or ``"linear_acceleration"``
``mount``, ``device``                               metadata
``canonical``                                       true: the canonical IMU CSV, read by ``bootnav.core.csvio``
``notes``                                           list of text, stored as ``note`` events
``[detect]``                                        ``header_contains`` (all of), ``n_fields``, ``filename_regex``,
                                                    ``delimiter``, ``trailing_delimiter``, ``first_value_min``,
                                                    ``no_header``, ``integer_fields`` (the first rows hold whole
                                                    numbers only)
``[sensor.N]``                                      overrides chosen by ``--sensor N`` (e.g. second IMU in the file)
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from bootnav.errors import InputError

PROFILE_KEYS = {
    "name", "description", "source", "delimiter", "header", "columns", "column_names", "time", "time_unit",
    "rate_hz", "acc_unit", "gyro_unit", "acc_range_g", "gyro_range_dps", "ranges_from_filename",
    "acc_quantity", "mount", "device", "notes", "detect", "sensor", "skip_lines", "canonical",
}


@dataclass
class Profile:
    name: str
    settings: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    def get(self, key: str, default=None):
        return self.settings.get(key, default)

    @property
    def detect(self) -> dict:
        return self.settings.get("detect", {})

    def for_sensor(self, sensor: int | None) -> "Profile":
        """This profile with the ``[sensor.N]`` overrides applied."""
        if sensor is None or sensor == 1 and "1" not in self.settings.get("sensor", {}):
            return self
        table = self.settings.get("sensor", {}).get(str(sensor))
        if table is None:
            raise InputError(f"profile {self.name!r} has no sensor {sensor} "
                             f"(has: {sorted(self.settings.get('sensor', {})) or 'only one'})")
        merged = {**self.settings, **table}
        return Profile(self.name, merged, self.path)


def _validate(settings: dict, where: str) -> dict:
    unknown = set(settings) - PROFILE_KEYS
    if unknown:
        raise InputError(f"{where}: unknown profile keys {sorted(unknown)} (known: {sorted(PROFILE_KEYS)})")
    return settings


def builtin_names() -> list[str]:
    return sorted(p.name[:-5] for p in resources.files(__package__).joinpath("profiles").iterdir()
                  if p.name.endswith(".toml"))


def load_profile(name_or_path: str | Path) -> Profile:
    """A shipped profile by name, or a user's TOML file by path."""
    text = str(name_or_path)
    if text.endswith(".toml") or Path(text).exists() and Path(text).is_file():
        path = Path(text)
        if not path.exists():
            raise InputError(f"profile file {path} not found")
        try:
            settings = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise InputError(f"{path}: invalid TOML ({exc})") from exc
        return Profile(settings.get("name", path.stem), _validate(settings, str(path)), path)
    res = resources.files(__package__).joinpath("profiles", f"{text}.toml")
    if not res.is_file():
        raise InputError(f"unknown profile {text!r}; shipped profiles: {', '.join(builtin_names())}")
    settings = tomllib.loads(res.read_text())
    return Profile(text, _validate(settings, f"profile {text}"), Path(str(res)))


def all_profiles() -> list[Profile]:
    return [load_profile(n) for n in builtin_names()]


def matches(profile: Profile, filename: str, header: list[str] | None, n_fields: int, delimiter: str,
            trailing: bool, first_value: float | None, integers: bool = False) -> bool:
    """True when every rule in the profile's ``[detect]`` table holds (a profile without rules never matches);
    ``integers``: every value of the file's first rows is a whole number."""
    rules = profile.detect
    if not rules:
        return False
    if "filename_regex" in rules and not re.search(rules["filename_regex"], filename):
        return False
    if "header_contains" in rules:
        hay = ",".join(header or []).lower()
        if not all(s.lower() in hay for s in rules["header_contains"]):
            return False
    if "header_lacks" in rules:
        hay = ",".join(header or []).lower()
        if any(s.lower() in hay for s in rules["header_lacks"]):
            return False
    if rules.get("no_header") and header is not None:
        return False
    if "n_fields" in rules and n_fields not in (rules["n_fields"] if isinstance(rules["n_fields"], list)
                                                  else [rules["n_fields"]]):
        return False
    if "delimiter" in rules and rules["delimiter"] != delimiter:
        return False
    if "trailing_delimiter" in rules and bool(rules["trailing_delimiter"]) != trailing:
        return False
    if "first_value_min" in rules and (first_value is None or first_value < rules["first_value_min"]):
        return False
    if "integer_fields" in rules and bool(rules["integer_fields"]) != integers:
        return False
    return True
