"""Import a canonical IMU CSV block by block: the recording ``read_any`` + ``write_result`` would write, in
memory that grows by 28 bytes a sample instead of about 500.

A canonical ``imu.csv``/``acc.csv`` (``bootnav.core.csvio``: header ``t_s,ax_mps2,...``, SI units) is the
format of long recordings (a 12 h shift at 200 Hz is 600 MB of text). ``import_streaming`` reads it in blocks
of ``BLOCK_BYTES`` (gzip undone as it goes), parses each block with the one canonical line parser
(``csvio.parse_numeric_lines``) and appends its samples to the recording being written (``write_atomically``:
all or nothing). What needs the whole record is kept as one number per sample, not the text or the 7-column
table: the time (the gap rule needs the median step), the norm of acc (the gravity check's quietest second)
and of gyro (its 99.9th percentile), and the line numbers (int32, for the events). The checks then run on
those with the code ``read_any`` uses, in the same order, so the recording, its events, metadata and
messages, and every error, are those of the in-memory import.

Anything else (another format, a profile or an override other than ``mount``/``check_units``, UTF-16,
non-UTF-8 bytes, a damaged gzip stream) returns None or falls back, and the caller imports in memory.
"""

from __future__ import annotations

import hashlib
import zlib
from pathlib import Path

import numpy as np

from bootnav.core import csvio
from bootnav.core.timebase import time_events
from bootnav.logger.recording import RecordingWriter, make_events, si_channel

from . import checks, sdlog
from .core import (OverBound, build_result, check_physical, map_columns, new_source, report_skipped, Units,
                   read_any, write_atomically, write_result)
from .profiles import Profile, load_profile
from .result import ImportResult
from .text import TextTable, utf16_encoding

#: Bytes of the file read (and parsed) at a time: about 60 000 lines of a 200 Hz canonical CSV (~40 MB of
#: working memory for its text, lines and numbers).
BLOCK_BYTES = 1 << 22
#: Overrides that do not change how a canonical CSV is read.
STREAMABLE_OVERRIDES = {"mount", "check_units"}


def import_file(path, out, profile: str | Path | Profile | None = None, **overrides) -> Path:
    """Import ``path`` into the recording ``out``; returns ``out``. See ``read_any`` for the overrides.
    A canonical IMU CSV is read block by block (``import_streaming``), anything else in memory."""
    if import_streaming(path, out, profile, **overrides) is None:
        write_result(read_any(path, profile, **overrides), out)
    return Path(out)


class _NotStreamable(Exception):
    """The file turned out not to be streamable (damaged gzip, non-UTF-8 bytes): import it in memory."""


def import_streaming(path, out, profile=None, *, block_bytes: int = BLOCK_BYTES, **overrides) -> ImportResult | None:
    """Import the canonical IMU CSV ``path`` into the recording ``out`` block by block.

    Parameters
    ----------
    path, out : str or Path
        The CSV (plain or gzip) and the recording to write (crash-safe, all or nothing).
    profile : None
        Only auto-detection streams; a given profile returns None.
    block_bytes : int
        Bytes read at a time (bounds the memory besides the 28 bytes a sample).
    **overrides
        As ``read_any``; only ``mount`` and ``check_units`` stream, any other returns None.

    Returns
    -------
    ImportResult or None
        The import's events, metadata and messages with ``t_s`` (``acc``/``gyro`` None: written, not kept),
        or None when the file is not a canonical CSV that can be streamed (nothing written).

    Raises
    ------
    InputError
        As ``read_any`` (the same message for the same file).
    """
    overrides = {k: v for k, v in overrides.items() if v is not None}
    path = Path(path)
    if profile is not None or set(overrides) - STREAMABLE_OVERRIDES or not path.is_file():
        return None
    header = _canonical_first_line(path)
    if header is None:
        return None
    box: dict = {}

    def write(tmp):
        box["result"] = _stream(path, tmp, header, block_bytes, overrides)

    try:
        write_atomically(out, write)
    except _NotStreamable:
        return None
    return box["result"]


def _chunks(path: Path, block_bytes: int, hasher):
    """Decompressed bytes of the file in pieces of about ``block_bytes``; the file bytes go to ``hasher``."""
    with open(path, "rb") as fh:
        first = fh.read(block_bytes)
        hasher.update(first)
        if first[:2] != b"\x1f\x8b":
            block = first
            while block:
                yield block
                block = fh.read(block_bytes)
                hasher.update(block)
            return
        d, pending = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS), first
        while True:
            try:
                out = d.decompress(pending, block_bytes)
                while d.unconsumed_tail and not d.eof:  # bounded output per call
                    yield out
                    out = d.decompress(d.unconsumed_tail, block_bytes)
            except zlib.error as exc:
                raise _NotStreamable from exc
            yield out
            if d.eof:
                rest = d.unused_data
                if rest[:2] != b"\x1f\x8b" and rest:  # csvio.decompress ignores what follows the gzip stream
                    break
                if not rest:
                    rest = fh.read(block_bytes)
                    hasher.update(rest)
                    if rest[:2] != b"\x1f\x8b":
                        break
                d, pending = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS), rest  # concatenated members
                continue
            pending = fh.read(block_bytes)
            hasher.update(pending)
            if not pending:
                raise _NotStreamable("gzip stream cut off")
        while True:  # hash the rest of the file, as read_any hashes all of it
            block = fh.read(block_bytes)
            if not block:
                return
            hasher.update(block)


def _canonical_first_line(path: Path) -> str | None:
    """The header line when the file starts like a canonical IMU CSV that streams, else None."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 16)
        if head[:2] == b"\x1f\x8b":
            head = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS).decompress(head, 1 << 16)
    except (OSError, zlib.error):
        return None
    if not head.strip() or utf16_encoding(head) or b"\x00" in head \
            or sum(head.count(bytes([c])) for c in range(32) if c not in (9, 10, 13)) > 0.01 * len(head):
        return None
    head = head[3:] if head[:3] == b"\xef\xbb\xbf" else head
    try:
        text = head.decode("utf-8", errors="strict") if len(head) < (1 << 16) else \
            head[:head.rfind(b"\n") + 1].decode("utf-8")
    except UnicodeDecodeError:
        return None
    first = text.partition("\n")[0]
    if sdlog.looks_like_sd_log(text) or csvio.canonical_header(first) is None:
        return None
    return first


def _stream(path: Path, tmp: Path, first_line: str, block_bytes: int, overrides: dict) -> ImportResult:
    """Parse ``path`` block by block into the recording ``tmp``; the checks of ``read_any`` at the end."""
    fields = tuple(h.strip() for h in first_line.rstrip("\r").lstrip("\ufeff").split(","))
    n_fields = len(fields)
    has_gyro = fields == csvio.IMU_HEADER
    prof = load_profile("canonical_imu_csv" if has_gyro else "canonical_acc_csv")
    stub = TextTable(path=path, delimiter=",", decimal_comma=False, header=list(fields), header_line=1, preamble=[],
                     rows=None, line_numbers=np.zeros(0, np.int64), n_fields=n_fields)
    src = new_source(path, stub, prof, True, overrides)  # its columns and units; rebuilt with the counts at the end
    map_columns(src)
    time_unit = src.overrides.get("time_unit") or src.header_units.get("t") or src.pget("time_unit")
    acc_unit = src.header_units.get("ax") or src.pget("acc_unit")
    gyro_unit = (src.header_units.get("gx") or src.pget("gyro_unit")) if has_gyro else "radps"
    if (time_unit, acc_unit, gyro_unit) != ("s", "mps2", "radps") or src.pget("acc_range_g") \
            or src.pget("gyro_range_dps") or src.pget("ranges_from_filename"):
        raise _NotStreamable("not a canonical SI file")
    acc_ch, gyro_ch = si_channel("acc", float("nan")), si_channel("gyro", float("nan"))
    over = {"acc": OverBound("acc", acc_ch), "gyro": OverBound("gyro", gyro_ch)}
    hasher = hashlib.sha256()
    parts = _Columns(path.stat().st_size)
    bad: list[tuple[int, str]] = []
    state = {"n": 0, "t0": None, "last": None, "n_rep": 0}
    writer = RecordingWriter(tmp, acc_ch, gyro_ch, meta={"start_utc": ""}, swmr=False)
    try:
        carry, line_no, n_lines, header_seen = b"", 1, 0, False
        for chunk in _chunks(path, block_bytes, hasher):
            buf = carry + chunk
            cut = buf.rfind(b"\n") + 1
            carry = buf[cut:]
            if not cut:
                continue
            lines = _decode(buf[:cut], not header_seen).split("\n")
            lines.pop()  # after the last newline
            n_lines += len(lines)
            if not header_seen:
                lines, header_seen, line_no = lines[1:], True, 2
            _parse_block(lines, line_no, fields, bad, parts, state, writer, over, has_gyro)
            line_no += len(lines)
        ends_without_newline = bool(carry)
        if carry:  # the last line has no newline: still a line
            last = _decode(carry, not header_seen)
            n_lines += 1
            if header_seen:
                _parse_block([last], line_no, fields, bad, parts, state, writer, over, has_gyro)
        return _finish(path, prof, overrides, writer, fields, n_lines, ends_without_newline, bad, parts, state,
                       over, hasher, time_unit, acc_ch, gyro_ch, has_gyro)
    except BaseException:
        writer.abort()
        raise


class _Columns:
    """The per-sample columns the whole-record checks need, in arrays grown in place (capacity first guessed
    from the file size, then doubled): no list of pieces to concatenate, no copy at the end."""

    DTYPES = {"t": np.float64, "lines": np.int32, "acc_mag": np.float64, "gyro_mag": np.float64}

    def __init__(self, file_bytes: int):
        self.cap = max(file_bytes // 40, 1024)  # a canonical line is >= ~40 bytes (7 fields of a few digits)
        self.n = 0
        self.arrays = {k: np.empty(self.cap, dt) for k, dt in self.DTYPES.items()}

    def add(self, **cols) -> None:
        k = len(cols["t"])
        if self.n + k > self.cap:  # a gzip file, or shorter lines than guessed
            self.cap = max(2 * self.cap, self.n + k)
            for name, a in self.arrays.items():
                grown = np.empty(self.cap, a.dtype)
                grown[:self.n] = a[:self.n]
                self.arrays[name] = grown
        for name, v in cols.items():
            if v is not None:
                self.arrays[name][self.n:self.n + k] = v
        self.n += k

    def pop(self, name: str) -> np.ndarray:
        """The column's ``n`` values (a view) and the column released from here."""
        return self.arrays.pop(name)[:self.n]


def _decode(data: bytes, first: bool) -> str:
    if first and data[:3] == b"\xef\xbb\xbf":
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:  # read_any decodes the whole file as cp1252 then
        raise _NotStreamable from exc


def _parse_block(lines, first_line_no, fields, bad, parts, state, writer, over, has_gyro) -> None:
    """Parse data lines (as ``csvio.parse_imu_csv``), append the kept samples, keep what the checks need."""
    if not lines:
        return
    values, line_numbers, block_bad = csvio.parse_numeric_lines(lines, first_line_no, len(fields))
    values, line_numbers = csvio.drop_nonfinite_lines(values, line_numbers, fields, block_bad)
    bad += block_bad
    if not values.shape[0]:
        return
    if state["t0"] is None:
        state["t0"] = float(values[0, 0] * 1.0)  # t_abs = t_raw * TIME_SCALE["s"]
    t = values[:, 0] * 1.0 - state["t0"]
    acc = np.ascontiguousarray(values[:, 1:4])
    gyro = np.ascontiguousarray(values[:, 4:7]) if has_gyro else np.full((values.shape[0], 3), np.nan)
    start = state["n"]
    writer.append(t, acc, gyro)
    state["n"] += t.size
    if line_numbers[-1] >= 1 << 31:
        raise _NotStreamable("more than 2**31 lines")
    with np.errstate(over="ignore", invalid="ignore"):
        parts.add(t=t, lines=line_numbers, acc_mag=np.linalg.norm(acc, axis=1),
                  gyro_mag=np.linalg.norm(gyro, axis=1) if has_gyro else None)
    over["acc"].add(acc, start)
    over["gyro"].add(gyro, start)
    rows = np.hstack((acc, gyro)) if has_gyro else acc  # repeated rows, the previous block's last one included
    if state["last"] is not None:
        rows_ext = np.vstack((state["last"], rows))
    else:
        rows_ext = rows
    state["n_rep"] += int(np.all(rows_ext[1:] == rows_ext[:-1], axis=1).sum())
    state["last"] = rows[-1:].copy()


def _finish(path, prof, overrides, writer, fields, n_lines, ends_without_newline, bad, parts, state, over, hasher,
            time_unit, acc_ch, gyro_ch, has_gyro) -> ImportResult:
    """The whole-record stages of ``read_any`` on the kept columns, then events and metadata written."""
    from bootnav.errors import InputError

    n = state["n"]
    bad.sort()
    if not bad and n == 0:
        raise InputError(f"{path}: line 2: no data line after the header")
    t, line_numbers = parts.pop("t"), parts.pop("lines")
    table = TextTable(path=path, delimiter=",", decimal_comma=False, header=list(fields), header_line=1,
                      preamble=[], rows=None, line_numbers=line_numbers, n_fields=len(fields), bad_lines=bad,
                      ends_without_newline=ends_without_newline, n_lines=n_lines)
    src = new_source(path, table, prof, True, overrides)
    map_columns(src)
    src.line_numbers = line_numbers
    report_skipped(src, bad, n)
    # the magnitudes first, so they are freed before the time base's temporaries; the rate from the writer's
    # exact count of the steps (timing_summary's median, without its copies of t)
    rate = 1.0 / writer.stats.steps.median() if n > 1 else 1.0
    acc_mag = parts.pop("acc_mag")
    quiet = checks.quietest_magnitude(acc_mag, rate)
    flat = checks.quietest_magnitude(acc_mag, rate, checks.FOOT_FLAT_S)  # a foot that never rests a second
    del acc_mag
    gyro_problem = checks.gyro_unit_problem(None, "radps", mag=parts.pop("gyro_mag")) if has_gyro and n else None
    # _build_time of a column of seconds
    t0 = state["t0"] if n else 0.0
    src.meta["t0_source_s"] = t0
    if t0 > 1e9 and "start_utc" not in src.meta:  # a UNIX epoch clock
        import datetime as _dt

        src.meta["start_utc"] = _dt.datetime.fromtimestamp(t0, _dt.timezone.utc).isoformat()
    src.events += time_events(t, line_numbers)
    for e in src.events:
        if e.get("sample_index", -1) >= 0 and "t_s" not in e:
            e["t_s"] = float(t[e["sample_index"]])
    # _check_units with declared SI units
    problems = [p for p in (checks.acc_unit_problem(None, 1.0, "mps2", rate, quiet=quiet, flat=flat), gyro_problem) if p]
    if not problems:
        w = checks.acc_borderline(None, 1.0, rate, quiet=quiet)
        if w:
            src.events.append(dict(kind="note", detail=w[:200]))
            src.messages.append("WARNING: " + w)
            src.meta["unit_check"] = (src.meta.get("unit_check", "") + "; " + w).lstrip("; ")
    for p in problems:
        if src.overrides.get("check_units", True):
            raise InputError(f"{path}: {p}")
        src.events.append(dict(kind="note", detail=("unit check overridden: " + p)[:200]))
        src.messages.append("WARNING (unit check overridden): " + p)
        src.meta["unit_check"] = (src.meta.get("unit_check", "") + "; overridden: " + p).lstrip("; ")
    # _sample_events: no range, so no saturation; repeated rows
    n_rep = state["n_rep"]
    if n > 1 and n_rep > 0.01 * n:
        src.events.append(dict(kind="note", count=n_rep, detail=f"{n_rep} rows repeat the previous row's sensor "
                               "values exactly (app/logger re-sent a stale sample); kept"))
        src.messages.append(f"note: {n_rep} rows repeat the previous row's values (kept)")
    for note in src.pget("notes", []) or []:
        src.events.append(dict(kind="note", detail=note))
    units = Units(None, None, acc_ch, gyro_ch, "mps2", "radps", None, None, "specific_force")
    result = build_result(src, t, time_unit, units, np.zeros(n, np.uint8), hasher.hexdigest())
    check_physical(result, path, src.overrides.get("check_units", True), over)
    events = sorted(result.events, key=lambda e: (e.get("sample_index", -1), e.get("line", -1)))
    writer.add_events(make_events(events))
    writer.close(final_meta=result.meta)  # holds timing_summary(t), which write_recording writes again
    return result
