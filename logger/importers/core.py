"""Import a text log from any IMU into a bootnav recording (HDF5).

``read_any(path, profile=None, **overrides) -> ImportResult`` parses and checks in memory;
``import_file(path, out, profile=None, **overrides) -> Path`` also writes the recording.

Overrides (all optional; the CLI flags of ``bootnav import`` map 1:1):
``columns`` (str or list, see ``columns.parse_columns_option``), ``acc_unit`` (g|mps2|counts),
``gyro_unit`` (dps|radps|counts), ``time_unit`` (s|ms|us), ``acc_range_g``, ``gyro_range_dps``,
``rate_hz``, ``mount``, ``sensor`` (second IMU of a file), ``delimiter``, ``check_units`` (default True).

Recovery rules (documented, nothing silent):

* malformed lines (wrong field count, a non-numeric value): skipped, reported with file and line,
  stored as ``skipped_line`` events; every good line is kept;
* NaN/inf in the time or in a used sensor column: that line is skipped the same way (a NaN sample
  cannot be integrated); if more than half of the lines are bad the import fails;
* a truncated last line (no final newline and malformed): ``skipped_line`` with detail "truncated";
* a cut-off or damaged gzip file: every complete line before the damage is read, the incomplete one is a
  ``skipped_line`` and a ``note`` event says what was lost;
* duplicate / backward times, gaps (the one gap rule of ``bootnav.core.timebase``: > 1.5 nominal periods),
  counter wraps: kept as they are and recorded as events; never resampled or reordered;
* accelerometer-only files (phones): the gyro is stored as NaN (rad/s) and meta ``gyro_present`` = 0;
* units that contradict gravity or physics: an error naming the right flag (see ``checks``);
  ``check_units=False`` turns it into a ``note`` event.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bootnav.core import atomic, csvio
from bootnav.core.timebase import (TIME_SCALE, is_u32_counter, spread_coarse_seconds, time_events, timing_summary,
                                   unwrap_counter)
from bootnav.errors import DiskFullError, InputError
from bootnav.logger import mpu6050
from bootnav.logger.recording import (Channel, counts_channel, is_disk_full, make_events, si_channel, write_group,
                                      write_recording)
from bootnav.logger.recording import load_aux  # noqa: F401  (importers.load_aux; the layout's reader is recording)

from . import checks, columns as colmod, sdlog
from .profiles import Profile, all_profiles, load_profile, matches
from .result import ImportResult
from .text import TextTable, decode_text, parse_table, read_bytes, utf16_encoding

G = mpu6050.STANDARD_GRAVITY
ACC_SCALE = {"g": G, "mps2": 1.0}
GYRO_SCALE = {"dps": math.pi / 180.0, "radps": 1.0}
#: Highest sample rate a flag or profile may declare (Hz): MEMS IMUs output at most a few kHz (MPU6050: 8 kHz gyro).
MAX_RATE_HZ = 100_000.0

OVERRIDE_KEYS = {"columns", "acc_unit", "gyro_unit", "time_unit", "acc_range_g", "gyro_range_dps", "rate_hz",
                 "mount", "sensor", "delimiter", "check_units"}
MAX_BAD_FRACTION = 0.5


def _sha256(raw: bytes) -> str:
    return hashlib.sha256(raw).hexdigest()


def detect_profile(path: Path, table: TextTable) -> Profile | None:
    """The one shipped profile whose detection rules match, None if none; error if several do."""
    first = None
    if table.n_rows:
        try:
            first = float(table.cell(0, 0).replace(",", "."))
        except ValueError:
            first = None
    integers = _whole_numbers(table)
    hits = [p for p in all_profiles()
            if matches(p, path.name, table.header, table.n_fields, table.delimiter, table.trailing_delimiter, first,
                       integers)]
    if len(hits) > 1:
        raise InputError(f"{path}: several profiles match ({', '.join(p.name for p in hits)}); choose one with --profile")
    return hits[0] if hits else None


def _whole_numbers(table: TextTable, n_rows: int = 50) -> bool:
    """True when every value of the first ``n_rows`` data rows is a whole number (a log of raw counts)."""
    if not table.n_rows:
        return False
    try:
        values = [float(table.cell(r, c).replace(",", ".")) for r in range(min(n_rows, table.n_rows))
                  for c in range(table.n_fields)]
    except (ValueError, IndexError):
        return False
    return all(v.is_integer() for v in values)


def _default_roles(n_fields: int, has_rate: bool) -> list[str] | None:
    """Headerless generic files: the default column map of [Heidari2019] ``t, ax, ay, az, gx, gy, gz[, temp]``."""
    return {
        4: ["t", "ax", "ay", "az"],
        7: ["t", "ax", "ay", "az", "gx", "gy", "gz"],
        8: ["t", "ax", "ay", "az", "gx", "gy", "gz", "temp"],
        6: ["ax", "ay", "az", "gx", "gy", "gz"] if has_rate else None,
    }.get(n_fields)


def _ranges_from_filename(profile: Profile, name: str) -> tuple[float | None, float | None]:
    rx = profile.get("ranges_from_filename")
    if not rx:
        return None, None
    m = re.search(rx, name)
    if not m:
        raise InputError(f"{name}: profile {profile.name} reads the ranges from the file name ({rx}) but it does "
                         f"not match; give --acc-range and --gyro-range")
    return float(mpu6050.ACCEL_RANGE_G[int(m["a"])]), float(mpu6050.GYRO_RANGE_DPS[int(m["g"])])


def _parse_time_strings(col: list[str]) -> tuple[np.ndarray, str] | None:
    """Date-time text (``2018-10-03 17:23:55.4640`` or ``17:23:55:464``) -> (s since epoch/midnight, kind)."""
    sample = col[0].strip().strip('"')
    try:
        if re.match(r"^\d{4}-\d\d-\d\d[ T]\d\d:\d\d", sample):
            t = np.array([c.strip().strip('"').replace(" ", "T") for c in col], dtype="datetime64[us]")
            return t.astype(np.int64) * 1e-6, "utc_datetime"
        if re.match(r"^\d\d?:\d\d:\d\d[:.]\d+$", sample):
            parts = np.array([re.split(r"[:.]", c.strip().strip('"')) for c in col], dtype=np.float64)
            frac = np.array([len(re.split(r"[:.]", c.strip())[-1]) for c in col[:1]])[0]
            return parts[:, 0] * 3600 + parts[:, 1] * 60 + parts[:, 2] + parts[:, 3] / 10.0**frac, "time_of_day"
    except ValueError:
        return None
    return None


@dataclass
class _Source:
    """What the stages of ``read_any`` learn about one non-SD text file, in the order they learn it."""

    path: Path
    table: TextTable
    prof: Profile | None
    detected: bool
    overrides: dict
    messages: list[str] = field(default_factory=list)
    events: list[dict] = field(default_factory=list)
    meta: dict[str, Any] = field(default_factory=dict)
    # columns (map_columns)
    idx: dict[str, int] = field(default_factory=dict)  # role (t, ax, ..., aux:NAME) -> column index
    header_units: dict[str, str] = field(default_factory=dict)
    quantities: dict[str, str] = field(default_factory=dict)
    rate_hz: float | None = None
    time_mode: str = "column"
    has_gyro: bool = False
    # numbers (_parse_numbers)
    values: dict[str, np.ndarray] = field(default_factory=dict)
    line_numbers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    time_text_kind: str | None = None
    skipped: list[tuple[int, str]] = field(default_factory=list)

    @property
    def pname(self) -> str:
        return self.prof.name if self.prof else "generic"

    def pget(self, key: str, default=None):
        return self.prof.get(key, default) if self.prof else default

    @property
    def n(self) -> int:
        return int(self.line_numbers.shape[0])


@dataclass
class Units:
    """Output of ``_check_units``: the arrays as stored and their channels."""

    acc: np.ndarray
    gyro: np.ndarray
    acc_channel: Channel
    gyro_channel: Channel
    acc_unit: str
    gyro_unit: str
    acc_range: float | None
    gyro_range: float | None
    acc_quantity: str


def read_any(path, profile: str | Path | Profile | None = None, **overrides) -> ImportResult:
    """Parse and check any supported text log (SD-card log, CSV/TXT of another IMU, canonical csv.gz).

    The stages, in order: read the text (gzip undone, a damaged stream cut at its last complete line); our
    SD-card log goes to ``sdlog``; otherwise detect the format and profile (``_detect``), map the columns
    (``map_columns``), parse the numbers (``_parse_numbers``), build the time axis and its events
    (``_build_time``), check the units against gravity (``_check_units``), flag saturation and repeated rows
    (``_sample_events``) and assemble the result with its metadata (``build_result``).

    Parameters
    ----------
    path : str or Path
        The file.
    profile : str, Path, Profile or None
        A shipped profile name, a user's TOML file, or None to auto-detect.
    **overrides
        ``columns``, ``acc_unit``, ``gyro_unit``, ``time_unit``, ``acc_range_g``, ``gyro_range_dps``,
        ``rate_hz``, ``mount``, ``sensor``, ``delimiter``, ``check_units`` (see the module docstring).

    Returns
    -------
    ImportResult
        Samples as delivered with their channels, events, metadata and messages; nothing written.
    """
    unknown = set(overrides) - OVERRIDE_KEYS
    if unknown:
        raise TypeError(f"unknown override(s) {sorted(unknown)}; known: {sorted(OVERRIDE_KEYS)}")
    overrides = {k: v for k, v in overrides.items() if v is not None}
    from bootnav.core.limits import check_range
    from bootnav.core.paths import regular_input

    for key, flag, lo, hi, unit, why in (
            ("rate_hz", "--rate", 0.0, MAX_RATE_HZ, "Hz", "an IMU's output rate"),
            ("acc_range_g", "--acc-range", 0.0, 1000.0, "g", "an accelerometer's full scale"),
            ("gyro_range_dps", "--gyro-range", 0.0, 100000.0, "deg/s", "a gyroscope's full scale")):
        check_range(flag, overrides.get(key), lo, hi, unit, lo_open=True, why=why)
    if Path(path).exists():
        regular_input(path, "log")  # a FIFO would block forever, a device never end
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory; give the log file to import")
    data, raw, damage = read_bytes(path)
    text = decode_text(path, data, damage)
    if sdlog.looks_like_sd_log(text) and profile in (None, "bootnav_sd"):
        result = sdlog.read_sd_log(path, text, raw, data, **overrides)  # a line cut by the damage fails its CRC
    else:
        src = _detect(path, text, profile, overrides, damage)
        map_columns(src)
        _parse_numbers(src)
        t, time_unit = _build_time(src)
        units = _check_units(src, t)
        saturated = _sample_events(src, t, units)
        result = build_result(src, t, time_unit, units, saturated, _sha256(raw))
    check_physical(result, path, overrides.get("check_units", True))
    utf16 = utf16_encoding(data)
    if utf16:
        result.meta["source_encoding"] = utf16
        result.messages.append(f"note: {path.name} is UTF-16 text ({utf16}), decoded")
    if damage:
        result.events.append(dict(kind="note", detail=f"{damage}: the lines after it are lost"[:200]))
        result.messages.append(f"WARNING: {path.name}: {damage}; every complete line before it was read")
    return result


#: Physical bounds of a body-worn IMU: beyond them a value is a damaged line or a wrong unit, not motion.
MAX_ACC_MPS2 = 200.0  # ~20 g: a heel strike peaks near 10 g
MAX_GYRO_RADPS = 50.0  # ~2900 deg/s: above the ±2000 deg/s of MEMS gyros
RATE_BOUNDS_HZ = (1.0, 10_000.0)


def check_physical(result: ImportResult, path: Path, strict: bool, over: dict | None = None) -> None:
    """Refuse a result whose values are physically impossible: a non-finite time, a rate outside
    1 Hz-10 kHz, |acc| above 200 m/s^2 or |gyro| above 50 rad/s, each named with its sample index and
    the likely fix. ``strict=False`` (``--no-unit-check``) turns the value bounds into note events; a
    non-finite time is always an error. ``over`` ({"acc"/"gyro": ``OverBound``}) replaces the scan of
    ``result.acc``/``result.gyro`` (a streamed import keeps no such arrays)."""
    t = np.asarray(result.t_s, dtype=np.float64)
    bad_t = np.flatnonzero(~np.isfinite(t))
    if bad_t.size:
        raise InputError(f"{path}: time of sample {int(bad_t[0])} is not finite ({t[bad_t[0]]}); check --time-unit "
                         "and the time column")
    problems = []
    rate = timing_summary(t)["rate_measured_hz"] if t.size > 1 else float("nan")
    if math.isfinite(rate) and not RATE_BOUNDS_HZ[0] <= rate <= RATE_BOUNDS_HZ[1]:
        problems.append(f"sample rate {rate:.4g} Hz is outside {RATE_BOUNDS_HZ[0]:g} Hz-{RATE_BOUNDS_HZ[1]:g} Hz; "
                        "check --time-unit (s, ms, us) or --rate")
    for kind, arr, ch, unit, flag in (("acc", result.acc, result.acc_channel, "m/s^2", "--acc-unit"),
                                      ("gyro", result.gyro, result.gyro_channel, "rad/s", "--gyro-unit")):
        o = over[kind] if over is not None else OverBound(kind, ch).add(arr, 0)
        if o.count:
            i = o.first
            problems.append(f"{kind} of sample {i} (t = {t[i]:.6g} s) is {o.value:.4g} {unit}, beyond the "
                            f"physical bound {o.bound:g} {unit} ({o.count} samples); a damaged line or a wrong {flag}")
    for p in problems:
        if strict:
            raise InputError(f"{path}: {p}")
        result.events.append(dict(kind="note", detail=("bound check overridden: " + p)[:200]))
        result.messages.append("WARNING (bound check overridden): " + p)


class OverBound:
    """Samples of a channel beyond its physical bound (``MAX_ACC_MPS2``/``MAX_GYRO_RADPS`` on any axis, in
    SI), fed block by block (``add``): how many, the first one and its largest |value|."""

    def __init__(self, kind: str, channel: Channel):
        self.bound = MAX_ACC_MPS2 if kind == "acc" else MAX_GYRO_RADPS
        self.channel, self.count, self.first, self.value = channel, 0, -1, float("nan")

    def add(self, arr, start: int) -> "OverBound":
        """Rows ``start ..`` of the channel as stored; returns self."""
        with np.errstate(invalid="ignore", over="ignore"):
            si = np.abs(np.asarray(arr, dtype=np.float64) * self.channel.scale_to_si + self.channel.offset_to_si)
        over = np.flatnonzero(np.any(si > self.bound, axis=1)) if si.size else np.zeros(0, int)
        if over.size and not self.count:
            self.first, self.value = start + int(over[0]), float(np.max(si[over[0]]))
        self.count += int(over.size)
        return self


def _detect(path: Path, text: str, profile, overrides: dict, damage: str | None) -> _Source:
    """Stage 1: the profile (given or detected) and the table of lines, with the format messages."""
    prof: Profile | None
    if isinstance(profile, Profile):
        prof = profile
    elif profile is not None:
        prof = load_profile(profile)
    else:
        prof = None
    canonical = csvio.canonical_header(text.partition("\n")[0])
    if canonical and (prof is None or prof.get("canonical")) and "delimiter" not in overrides:
        table = _canonical_table(path, text, damage)
        prof = prof or load_profile("canonical_imu_csv" if canonical == csvio.IMU_HEADER else "canonical_acc_csv")
        detected = profile is None
    else:
        text, lost = csvio.drop_incomplete_tail(text, damage)
        skip = int(prof.get("skip_lines", 0)) if prof else 0
        delimiter = overrides.get("delimiter") or (prof.get("delimiter") if prof else None)
        table = parse_table(path, text, delimiter=delimiter, header=prof.get("header") if prof else None,
                            skip_lines=skip)
        if lost:
            table.bad_lines.append(lost)
        detected = False
        if prof is None:
            prof = detect_profile(path, table)
            detected = prof is not None
    if prof is not None:
        prof = prof.for_sensor(overrides.get("sensor"))
    elif overrides.get("sensor") not in (None, 1):
        raise InputError(f"{path}: --sensor needs a profile with several sensors")
    return new_source(path, table, prof, detected, overrides)


def new_source(path: Path, table: TextTable, prof: Profile | None, detected: bool, overrides: dict) -> _Source:
    """The ``_Source`` of a file's table, with the messages saying which profile and format were found."""
    src = _Source(path, table, prof, detected, overrides)
    src.messages.append(f"profile: {src.pname}" + (" (auto-detected)" if detected else " (given)" if prof else
                        " (no profile matched; columns and units from the header and flags)"))
    src.messages.append(f"format: delimiter {_delimiter_name(table)}, header "
                        f"{'line ' + str(table.header_line) if table.header else 'none'}"
                        + (", decimal comma" if table.decimal_comma else "")
                        + (", trailing delimiter" if table.trailing_delimiter else "")
                        + f", {table.n_fields} fields, {table.n_rows} data lines")
    return src


def _canonical_table(path: Path, text: str, damage: str | None) -> TextTable:
    """A canonical ``imu*.csv`` / ``acc.csv`` through the one canonical reader, ``bootnav.core.csvio``."""
    imu = csvio.parse_imu_csv(text, path, max_bad_fraction=1.0, damage=damage)  # _parse_numbers judges the share
    cols = [imu.t_s[:, None], imu.acc_mps2] + ([imu.gyro_radps] if imu.gyro_radps is not None else [])
    return TextTable(path=path, delimiter=",", decimal_comma=False, header=list(imu.header), header_line=1,
                     preamble=[], rows=None, line_numbers=imu.line_numbers, n_fields=len(imu.header),
                     bad_lines=list(imu.bad_lines), ends_without_newline=damage is None and not text.endswith("\n"),
                     n_lines=imu.n_lines, matrix=np.hstack(cols))


def _delimiter_name(table: TextTable) -> str:
    return {"\t": "tab", "whitespace": "whitespace"}.get(table.delimiter, repr(table.delimiter))


def map_columns(src: _Source) -> None:
    """Stage 2: the role of each column (``--columns``, the profile, the header names or the default order)."""
    table, path, pget = src.table, src.path, src.pget
    header_units: dict[str, str] = {}
    quantities: dict[str, str] = {}
    rate_hz = src.overrides.get("rate_hz", pget("rate_hz"))
    try:
        if "columns" in src.overrides:
            roles = colmod.parse_columns_option(src.overrides["columns"], table.header, table.n_fields)
        elif pget("columns"):
            roles = list(pget("columns"))
            if len(roles) != table.n_fields:
                raise InputError(f"{path}: profile {src.pname} expects {len(roles)} columns, the file has "
                                 f"{table.n_fields} (line {table.line_numbers[0] if len(table.line_numbers) else '?'})")
            if table.header:
                _, header_units, quantities = colmod.map_header(table.header)
                header_units = {roles[i]: header_units.get(r) for i, r in enumerate(colmod.map_header(table.header)[0])
                                if header_units.get(r)}
        elif table.header:
            roles, header_units, quantities = colmod.map_header(table.header)
            for name, role in (pget("column_names") or {}).items():
                if name in table.header:
                    i = table.header.index(name)
                    old = roles[i]
                    roles[i] = role
                    header_units[role] = colmod.unit_of(name) or header_units.pop(old, None)
                    header_units = {k: v for k, v in header_units.items() if v}
        else:
            roles = _default_roles(table.n_fields, rate_hz is not None)
            if roles is None:
                raise InputError(f"{path}: {table.n_fields} columns without a header and no profile matches; "
                                 f"give --columns (e.g. t,ax,ay,az,gx,gy,gz) or --profile"
                                 + (" and --rate (no time column)" if table.n_fields == 6 else ""))
            src.messages.append("columns: no header; assumed the default order " + ",".join(roles))
    except ValueError as exc:
        raise InputError(f"{path}: {exc}") from exc
    idx = {r: i for i, r in enumerate(roles) if r != "-"}
    if not all(r in idx for r in ("ax", "ay", "az")):
        lin = [r for r, q in quantities.items() if q == "linear"]
        if lin and src.pname != "purestreams_phyphox":
            raise InputError(f"{path}: the file holds LINEAR acceleration ({', '.join(table.header[roles.index(r)] for r in lin)}),"
                             f" i.e. gravity removed, not specific force; use --profile purestreams_phyphox or "
                             f"--columns to import it explicitly as linear acceleration")
        raise InputError(f"{path}: no accelerometer x/y/z columns found (columns: {table.header or roles}); use --columns")
    time_mode = pget("time", "column")
    if "t" not in idx and time_mode == "column":
        time_mode = "rate"
    if time_mode == "rate" and not rate_hz:
        raise InputError(f"{path}: no time column; give the sample rate with --rate HZ")
    src.messages.append("columns: " + ", ".join(f"{r}={table.header[i] if table.header else i}"
                                            for r, i in idx.items()))
    src.idx, src.header_units, src.quantities = idx, header_units, quantities
    src.rate_hz, src.time_mode = rate_hz, time_mode
    src.has_gyro = all(r in idx for r in ("gx", "gy", "gz"))


def _parse_numbers(src: _Source) -> None:
    """Stage 3: the numbers of every used column; malformed and NaN/inf lines are skipped and reported."""
    table, path = src.table, src.path
    bad: dict[int, str] = {}  # row index -> reason
    values: dict[str, np.ndarray] = {}
    for role, i in src.idx.items():
        if role == "t":
            arr, bad_rows = table.numeric(i)
            if len(bad_rows) > 0.5 * len(arr):
                parsed = _parse_time_strings(table.column(i))
                if parsed is None:
                    raise InputError(f"{path}: time column {i} ({table.header[i] if table.header else ''}) is not "
                                     f"numeric (line {table.line_numbers[bad_rows[0]]}: {table.cell(bad_rows[0], i)!r})")
                arr, src.time_text_kind = parsed
                bad_rows = []
        else:
            arr, bad_rows = table.numeric(i)
        for r in bad_rows:
            bad.setdefault(r, f"column {i + 1} ({role}) is not a number: {table.cell(r, i)[:30]!r}")
        if role in ("t", "ax", "ay", "az", "gx", "gy", "gz"):
            for r in np.flatnonzero(~np.isfinite(arr)):
                bad.setdefault(int(r), f"column {i + 1} ({role}) is {table.cell(r, i).strip()[:20]!r} "
                                       "(NaN/inf: line skipped)")
        values[role] = arr
    skipped = [(ln, reason) for ln, reason in table.bad_lines]
    skipped += [(int(table.line_numbers[r]), reason) for r, reason in bad.items()]
    skipped.sort()
    report_skipped(src, skipped, table.n_rows - len(bad))
    keep = np.ones(table.n_rows, dtype=bool)
    keep[list(bad)] = False
    src.line_numbers = table.line_numbers[keep]
    src.values = {k: v[keep] for k, v in values.items()}


def report_skipped(src: _Source, skipped: list[tuple[int, str]], n_kept: int) -> None:
    """The skipped lines (sorted (line, reason)) as events and messages; an error when more than
    ``MAX_BAD_FRACTION`` of the data lines (``n_kept`` + skipped) are bad."""
    path, table = src.path, src.table
    n_lines_data = n_kept + len(skipped)
    if n_lines_data == 0 or len(skipped) > MAX_BAD_FRACTION * n_lines_data:
        first = "; ".join(f"line {ln}: {why}" for ln, why in skipped[:3])
        raise InputError(f"{path}: {len(skipped)} of {n_lines_data} data lines are malformed ({first}); "
                         f"wrong profile, columns or delimiter?")
    src.skipped = skipped
    for ln, reason in skipped:
        truncated = table.ends_without_newline and ln == table.n_lines
        src.events.append(dict(kind="skipped_line", line=ln, count=1,
                               detail=("truncated last line (no newline): " if truncated else "") + reason))
    if skipped:
        src.messages.append(f"skipped {len(skipped)} malformed line(s) of {path.name}: "
                            + ", ".join(str(ln) for ln, _ in skipped[:10]) + (" ..." if len(skipped) > 10 else ""))
        src.messages += [f"  {path.name}:{ln}: {why}" for ln, why in skipped[:10]]


def _build_time(src: _Source) -> tuple[np.ndarray, str]:
    """Stage 4: sample times in s from the first sample (unit, counter wraps, coarse clocks) and time events.
    Returns (t_s, the file's time unit)."""
    n, meta, events, path = src.n, src.meta, src.events, src.path
    time_unit = src.overrides.get("time_unit") or src.header_units.get("t") or src.pget("time_unit")
    if src.time_mode == "rate":
        t = np.arange(n, dtype=np.float64) / float(src.rate_hz)
        time_unit = "s"
        src.messages.append(f"time: no time column, t = i / {src.rate_hz} Hz")
        meta["time_source"] = f"sample index / {src.rate_hz} Hz"
    else:
        t_raw = src.values["t"]
        if src.time_text_kind:
            time_unit = "s"
            meta["time_source"] = src.time_text_kind
            if src.time_text_kind == "utc_datetime" and n:
                meta["start_utc"] = _dt.datetime.fromtimestamp(t_raw[0], _dt.timezone.utc).isoformat()
        if time_unit is None:
            time_unit, med = checks.guess_time_unit(t_raw)
            src.messages.append(f"time unit: not declared, guessed {time_unit!r} from the median step {med:g} "
                                f"(override with --time-unit)")
            meta["time_unit_source"] = "guessed from the median time step"
        if time_unit not in TIME_SCALE:
            raise InputError(f"{path}: time unit {time_unit!r} unknown (use s, ms or us)")
        if time_unit in ("ms", "us") and is_u32_counter(t_raw):
            t_raw, wraps = unwrap_counter(t_raw)
            for i in wraps:
                events.append(dict(kind="time_wrap", sample_index=int(i), line=int(src.line_numbers[i]), count=1,
                                   detail=f"32-bit {time_unit} counter wrapped (2**32 added)"))
        if src.time_mode == "rtc_seconds":
            t_abs, per_s = spread_coarse_seconds(t_raw * TIME_SCALE[time_unit])
            events.append(dict(kind="note", count=n, detail=f"1-s clock: rows spread evenly inside each second "
                               f"(median {per_s:g} rows/s)"))
            src.messages.append(f"time: 1-s RTC clock, {per_s:g} rows/s spread evenly inside each second")
            meta["time_source"] = "1-s RTC, rows spread within each second"
            meta["rows_per_second_median"] = per_s
        else:
            t_abs = t_raw * TIME_SCALE[time_unit]
        t0 = float(t_abs[0]) if n else 0.0
        meta["t0_source_s"] = t0
        if t0 > 1e9 and "start_utc" not in meta and src.time_text_kind is None:  # a UNIX epoch clock
            meta["start_utc"] = _dt.datetime.fromtimestamp(t0, _dt.timezone.utc).isoformat()
        t = t_abs - t0
    if src.time_mode == "column" and src.rate_hz and n > 2:
        dt = np.diff(t)
        dt = dt[np.isfinite(dt) & (dt > 0)]
        measured = 1.0 / float(np.median(dt)) if dt.size else float("nan")
        if np.isfinite(measured) and not 0.5 <= float(src.rate_hz) / measured <= 2.0:
            raise InputError(f"{path}: --rate {float(src.rate_hz):g} Hz contradicts the time column, whose median step "
                             f"gives {measured:.4g} Hz; drop --rate (the time column gives the times) or fix "
                             "--time-unit")
    if src.time_mode == "column":
        events += time_events(t, src.line_numbers, nominal_dt=1.0 / float(src.rate_hz) if src.rate_hz else None)
    for e in events:
        if e.get("sample_index", -1) >= 0 and "t_s" not in e:
            e["t_s"] = float(t[e["sample_index"]])
    return t, time_unit


def _check_units(src: _Source, t: np.ndarray) -> Units:
    """Stage 5: accelerometer/gyro units and ranges (declared, from the header, or from gravity), checked
    against gravity and physics; a contradiction is an error naming the flag (or a note with
    ``check_units=False``)."""
    n, path, overrides, pget = src.n, src.path, src.overrides, src.pget
    acc_raw = np.column_stack([src.values[r] for r in ("ax", "ay", "az")])
    gyro_raw = (np.column_stack([src.values[r] for r in ("gx", "gy", "gz")]) if src.has_gyro
                else np.full((n, 3), np.nan))
    acc_unit = overrides.get("acc_unit") or src.header_units.get("ax") or pget("acc_unit")
    gyro_unit = overrides.get("gyro_unit") or src.header_units.get("gx") or pget("gyro_unit")
    acc_quantity = pget("acc_quantity", "specific_force")
    if src.quantities.get("ax") == "acc_g" and not overrides.get("acc_unit"):
        acc_unit = "g"
    fr_acc, fr_gyro = _ranges_from_filename(src.prof, path.name) if src.prof else (None, None)
    acc_range = overrides.get("acc_range_g") or fr_acc or pget("acc_range_g")
    gyro_range = overrides.get("gyro_range_dps") or fr_gyro or pget("gyro_range_dps")
    rate = float(src.rate_hz) if src.rate_hz else (timing_summary(t)["rate_measured_hz"] if n > 1 else 1.0)
    if acc_unit is None:
        raw_mag, _ = checks.quietest_second(acc_raw, rate)
        for unit, ref in (("g", 1.0), ("mps2", G)):
            if abs(raw_mag / ref - 1) <= checks.ACC_TOLERANCE:
                acc_unit = unit
        if acc_unit is None:
            hint = (" - gravity seems removed (linear acceleration?), which is not specific force"
                    if raw_mag < 0.3 else "")
            raise InputError(f"{path}: accelerometer unit not declared and not recognisable (median |acc| at rest "
                             f"{raw_mag:.4g}{hint}); give --acc-unit g|mps2|counts")
        src.messages.append(f"acc unit: not declared, {acc_unit!r} from the gravity magnitude at rest ({raw_mag:.4g})")
        src.meta["acc_unit_source"] = "gravity magnitude at rest"
    if acc_unit not in ("g", "mps2", "counts"):
        raise InputError(f"acc unit {acc_unit!r} unknown (use g, mps2 or counts)")
    if src.has_gyro and gyro_unit is None:
        if acc_unit == "counts":
            gyro_unit = "counts"
        else:
            raise InputError(f"{path}: gyro unit not declared in the header or profile; give --gyro-unit dps|radps")
    if not src.has_gyro:
        gyro_unit = "radps"
    if gyro_unit not in ("dps", "radps", "counts"):
        raise InputError(f"gyro unit {gyro_unit!r} unknown (use dps, radps or counts)")

    acc_arr, acc_ch = _channel("acc", acc_raw, acc_unit, acc_range, path)
    gyro_arr, gyro_ch = _channel("gyro", gyro_raw, gyro_unit, gyro_range, path)
    problems = []
    if acc_quantity == "specific_force":
        p = checks.acc_unit_problem(acc_arr, acc_ch.scale_to_si, acc_unit, rate)
        if p:
            problems.append(p)
    if src.has_gyro:
        p = checks.gyro_unit_problem(gyro_arr.astype(np.float64) * gyro_ch.scale_to_si, gyro_unit)
        if p:
            problems.append(p)
    borderline = []
    if acc_quantity == "specific_force" and not problems:
        borderline.append(checks.acc_borderline(acc_arr, acc_ch.scale_to_si, rate))
    if src.has_gyro and acc_quantity == "specific_force" and not problems:
        err, warn = checks.gyro_unit_too_small(acc_arr.astype(np.float64) * acc_ch.scale_to_si,
                                               gyro_arr.astype(np.float64) * gyro_ch.scale_to_si, t, gyro_unit)
        problems += [err] if err else []
        borderline.append(warn)
    for w in filter(None, borderline):  # borderline: kept, said, and recorded in the file's /meta
        src.events.append(dict(kind="note", detail=w[:200]))
        src.messages.append("WARNING: " + w)
        src.meta["unit_check"] = (src.meta.get("unit_check", "") + "; " + w).lstrip("; ")
    for p in problems:
        if overrides.get("check_units", True):
            raise InputError(f"{path}: {p}")
        src.events.append(dict(kind="note", detail=("unit check overridden: " + p)[:200]))
        src.messages.append("WARNING (unit check overridden): " + p)
        src.meta["unit_check"] = (src.meta.get("unit_check", "") + "; overridden: " + p).lstrip("; ")
    if acc_quantity != "specific_force":
        src.events.append(dict(kind="note", detail=f"acc is {acc_quantity} (gravity removed), NOT specific force"))
        src.messages.append(f"WARNING: acc is {acc_quantity.upper()} (gravity removed), NOT specific force: fine for "
                            f"step counting, wrong for strapdown/ZUPT (meta acc_quantity)")
    return Units(acc_arr, gyro_arr, acc_ch, gyro_ch, acc_unit, gyro_unit, acc_range, gyro_range, acc_quantity)


def _sample_events(src: _Source, t: np.ndarray, u: Units) -> np.ndarray:
    """Stage 6: saturation bits and events, repeated rows, the profile's notes. Returns the saturation mask."""
    n = src.n
    sat_a, ev_a = checks.saturation(u.acc, u.acc_channel.full_scale, u.acc_unit == "counts", 0)
    if src.has_gyro:
        sat_g, ev_g = checks.saturation(u.gyro, u.gyro_channel.full_scale, u.gyro_unit == "counts", 3)
    else:
        sat_g, ev_g = np.zeros(n, np.uint8), []
    for e in ev_a + ev_g:
        e["t_s"] = float(t[e["sample_index"]])
        e["line"] = int(src.line_numbers[e["sample_index"]])
    src.events += ev_a + ev_g
    # Physics Toolbox and similar apps repeat rows when no sensor updated: keep, but say how many.
    if n > 1:
        same = np.all(u.acc[1:] == u.acc[:-1], axis=1)
        if src.has_gyro:
            same &= np.all(u.gyro[1:] == u.gyro[:-1], axis=1)
        n_rep = int(same.sum())
        if n_rep > 0.01 * n:
            src.events.append(dict(kind="note", count=n_rep, detail=f"{n_rep} rows repeat the previous row's sensor "
                                   "values exactly (app/logger re-sent a stale sample); kept"))
            src.messages.append(f"note: {n_rep} rows repeat the previous row's values (kept)")
    for note in src.pget("notes", []) or []:
        src.events.append(dict(kind="note", detail=note))
    return (sat_a | sat_g).astype(np.uint8)


def build_result(src: _Source, t: np.ndarray, time_unit: str, u: Units, saturated: np.ndarray,
                  sha256: str) -> ImportResult:
    """Stage 7: extra columns, metadata and the summary messages, as an ``ImportResult``."""
    path, table, prof, n, meta = src.path, src.table, src.prof, src.n, src.meta
    aux, aux_units = {}, {}
    for role, i in src.idx.items():
        if role.startswith("aux:") or role == "temp":
            name = role[4:] if role.startswith("aux:") else "temp"
            aux[name] = src.values[role]
            aux_units[name] = src.header_units.get(role) or "as in file"
    summary = timing_summary(t)
    meta.update(
        source_file=str(path.resolve()), source_sha256=sha256, importer_profile=src.pname,
        importer_profile_file=str(prof.path) if prof and prof.path else "",
        detected=dict(delimiter=_delimiter_name(table), header=table.header or [], decimal_comma=table.decimal_comma,
                      columns={r: (table.header[i] if table.header else i) for r, i in src.idx.items()},
                      profile_auto_detected=src.detected),
        acc_unit_source_file=u.acc_unit, gyro_unit_source_file=u.gyro_unit if src.has_gyro else "absent",
        time_unit_source_file=time_unit, acc_quantity=u.acc_quantity, gyro_present=int(src.has_gyro),
        accel_range_g=float(u.acc_range) if u.acc_range else float("nan"),
        gyro_range_dps=float(u.gyro_range) if u.gyro_range else float("nan"),
        rate_nominal_hz=float(src.rate_hz) if src.rate_hz else float("nan"),
        mount=src.overrides.get("mount") or src.pget("mount", "unknown"), device=src.pget("device", "unknown"),
        lines_total=table.n_lines, lines_skipped=len(src.skipped), **summary,
    )
    if src.pname in ("purestreams_phyphox", "phyphox_csv"):
        meta.update(_phyphox_meta(path))
        if "phyphox_start_unix_s" in meta and n:
            meta["start_utc"] = _dt.datetime.fromtimestamp(meta["phyphox_start_unix_s"] + meta.get("t0_source_s", 0.0),
                                                           _dt.timezone.utc).isoformat()
    meta.setdefault("start_utc", "")  # unknown: the source has no absolute clock (never the import time)
    if table.preamble:
        meta["source_preamble"] = "\n".join(ln for _, ln in table.preamble)[:2000]
    messages = src.messages
    if not src.has_gyro:
        messages.append("gyro: absent in this file -> stored as NaN (meta gyro_present = 0)")
    messages.append(f"units: acc {u.acc_unit}, gyro {u.gyro_unit if src.has_gyro else 'absent'}, time {time_unit}; "
                    f"ranges acc {u.acc_range or '?'} g, gyro {u.gyro_range or '?'} deg/s")
    messages.append(f"samples: {n}, {summary['rate_measured_hz']:.4g} Hz measured"
                    + (f" ({src.rate_hz} nominal)" if src.rate_hz else "") + f", {t[-1] if n else 0:.3f} s")
    return ImportResult(source=path, profile=src.pname, t_s=t, acc=u.acc, gyro=u.gyro, acc_channel=u.acc_channel,
                        gyro_channel=u.gyro_channel, saturated=saturated, events=src.events, meta=meta,
                        aux=aux, aux_units=aux_units, messages=messages)


def _phyphox_meta(path: Path) -> dict[str, Any]:
    """phyphox exports carry ``meta/time.csv`` (START event: experiment time and UNIX system time) and
    ``meta/device.csv`` next to the data: absolute start time and phone model."""
    import csv

    out: dict[str, Any] = {}
    time_csv, device_csv = path.parent / "meta" / "time.csv", path.parent / "meta" / "device.csv"
    try:
        if time_csv.is_file():
            for row in csv.DictReader(time_csv.read_text().splitlines()):
                if row.get("event") == "START":
                    # system time of experiment time 0; our t_s = 0 is the first sample (t0_source_s)
                    out["phyphox_start_unix_s"] = float(row["system time"])
                    out["phyphox_start_text"] = row.get("system time text", "")
                    break
        if device_csv.is_file():
            props = {r["property"]: r["value"] for r in csv.DictReader(device_csv.read_text().splitlines())}
            out["device"] = f"{props.get('deviceBrand', '')} {props.get('deviceModel', '')}".strip() or "phone"
            out["phyphox_version"] = props.get("version", "")
    except (OSError, KeyError, ValueError):
        pass  # the side files are optional; the data file alone is complete
    return out


def _channel(kind: str, raw: np.ndarray, unit: str, range_: float | None, path: Path) -> tuple[np.ndarray, Channel]:
    """Stored array and channel description: counts stay int16 (bit-exact), floats stay in the file's unit."""
    if unit == "counts":
        if range_ is None:
            flag = "--acc-range G" if kind == "acc" else "--gyro-range DPS"
            raise InputError(f"{path}: {kind} in counts needs its full-scale range ({flag})")
        if np.any(raw != np.round(raw)) or raw.min() < -32768 or raw.max() > 32767:
            raise InputError(f"{path}: {kind} declared as int16 counts but has non-integer or out-of-range values")
        code = mpu6050.accel_code(range_) if kind == "acc" else mpu6050.gyro_code(range_)
        scale = mpu6050.accel_scale_mps2(code) if kind == "acc" else mpu6050.gyro_scale_radps(code)
        return raw.astype(np.int16), counts_channel(kind, scale)
    if kind == "acc":
        fs = float(range_) * (1.0 if unit == "g" else G) if range_ else float("nan")
        if unit == "mps2":
            return raw.astype(np.float64), si_channel("acc", fs)
        return raw.astype(np.float64), Channel("g", "m/s^2", G, 0.0, fs)
    fs = float(range_) * (1.0 if unit == "dps" else math.pi / 180.0) if range_ else float("nan")
    if unit == "radps":
        return raw.astype(np.float64), si_channel("gyro", fs)
    return raw.astype(np.float64), Channel("deg/s", "rad/s", math.pi / 180.0, 0.0, fs)


def write_aux(path, group: str, result: ImportResult) -> None:
    """Write the extra input columns of ``result`` (if any) as ``group`` (e.g. ``aux``) of the file ``path``."""
    if result.aux:
        write_group(path, group, result.aux, attrs={"description": "extra input columns, one per dataset, "
                    "row-aligned with imu/t_s"}, units=result.aux_units)


def write_atomically(out, write) -> Path:
    """Call ``write(tmp)`` on a file beside ``out``, sync it and rename it over ``out``; returns ``out``.

    Crash-safe: a crash or a full disk leaves either the old file or the complete new one, never a
    half-written recording (an import writes all or nothing). Errors become one line naming ``out``.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        atomic.replace_with(out, write)
    except (DiskFullError, OSError) as exc:
        if isinstance(exc, DiskFullError) or is_disk_full(exc):
            state = "left as it was" if out.exists() else "not created"
            raise DiskFullError(f"disk full at {out}: 0 frames written ({state}; an import writes all or nothing)") \
                from exc
        # not writable, vanished directory, I/O error: h5py's long text cut to its reason
        reason = re.search(r"error message = '([^']*)'", str(exc))
        raise InputError(f"{out}: cannot write ({reason.group(1) if reason else exc}); choose a writable place") \
            from exc
    return out


def write_result(result: ImportResult, out) -> Path:
    """Write an ``ImportResult`` as a bootnav recording (``/aux`` holds the extra columns), crash-safe."""
    return write_atomically(out, lambda tmp: write_result_into(result, tmp))


def write_result_into(result: ImportResult, path) -> None:
    """Write an ``ImportResult`` into ``path`` as it is (not crash-safe on its own: for a file that is itself a
    temporary, e.g. the one ``results.h5`` is built in, whose rename is the caller's)."""
    events = sorted(result.events, key=lambda e: (e.get("sample_index", -1), e.get("line", -1)))
    write_recording(path, result.t_s, result.acc, result.gyro, acc_channel=result.acc_channel,
                    gyro_channel=result.gyro_channel, events=make_events(events), meta=result.meta,
                    saturated=result.saturated, **result.optional)
    write_aux(path, "aux", result)

