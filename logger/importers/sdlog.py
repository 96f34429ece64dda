"""Our own SD-card text log (firmware-protocol/PROTOCOL.md §2).

    # bootnav-sd v1 accel_fs=3 gyro_fs=3 dlpf=3 smplrt_div=4 fw=0.1.0 device_id=0x0000BEEF
    t_us,seq,ax,ay,az,gx,gy,gz,temp*CRC

CRC-16/CCITT-FALSE (``bootnav.logger.crc``) over the ASCII characters before ``*``, four upper-case hex digits.
Raw counts are stored bit-exact as int16 with the scale factors of the header's full-scale codes.

Per line, in this order: a data line with a non-ASCII byte (the format is ASCII: invalid UTF-8 or a corrupted
byte), a line without ``*HHHH`` or with a CRC mismatch -> ``crc_error`` event (line number and byte offset of
the line start, counted on the file's bytes so they stay exact after any bad byte); fields not 9 integers in range -> ``skipped_line``;
the last line without a newline that fails either test -> ``skipped_line`` "truncated last line".
Then: uint32 µs clock unwrapped (``time_wrap``), backward/duplicate times, and sequence gaps
(``gap`` with the number of missing sequence numbers, seq wraps at 2**16).

CRCs are checked vectorised: lines are grouped by length and each group goes through
``crc16_ccitt_false_rows`` (one numpy table lookup per byte column).
"""

from __future__ import annotations

import gc
import hashlib
import re
import warnings
from pathlib import Path

import numpy as np

from bootnav.core.csvio import decompress
from bootnav.core.timebase import SEQ_MODULUS, time_events, timing_summary, unwrap_counter
from bootnav.errors import InputError
from bootnav.logger import mpu6050
from bootnav.logger.crc import crc16_ccitt_false, crc16_ccitt_false_rows
from bootnav.logger.recording import counts_channel

from . import checks
from .result import ImportResult
from .text import utf16_encoding

HEADER_PREFIX = "# bootnav-sd"
_HEADER_RE = re.compile(r"^#\s*bootnav-sd\s+v(\d+)\s*(.*)$")
_LINE_RE = re.compile(r"^\d+,\d+(,-?\d+){7}\*[0-9A-Fa-f]{4}$")
SAMPLE_FIELDS = ("t_us", "seq", "ax", "ay", "az", "gx", "gy", "gz", "temp")
LIMITS = {"t_us": (0, 2**32 - 1), "seq": (0, 2**16 - 1)}


def looks_like_sd_log(text: str) -> bool:
    head = text.lstrip()[:4096]
    if head.startswith(HEADER_PREFIX):
        return True
    lines = [ln.strip() for ln in head.splitlines()[:5] if ln.strip() and not ln.startswith("#")]
    return bool(lines) and all(_LINE_RE.match(ln) for ln in lines[:3])


def format_sd_line(t_us: int, seq: int, ax: int, ay: int, az: int, gx: int, gy: int, gz: int, temp: int) -> str:
    """One SD-card data line with its CRC (no newline): the firmware's ``sprintf`` in Python."""
    body = f"{t_us},{seq},{ax},{ay},{az},{gx},{gy},{gz},{temp}"
    return f"{body}*{crc16_ccitt_false(body.encode('ascii')):04X}"


def format_sd_header(accel_fs: int = 3, gyro_fs: int = 3, dlpf: int = 3, smplrt_div: int = 4, fw: str = "0.1.0",
                     device_id: int = 0xBEEF) -> str:
    return (f"# bootnav-sd v1 accel_fs={accel_fs} gyro_fs={gyro_fs} dlpf={dlpf} smplrt_div={smplrt_div} "
            f"fw={fw} device_id=0x{device_id:08X}")


def parse_header(line: str) -> dict[str, str]:
    m = _HEADER_RE.match(line.strip())
    if not m:
        raise ValueError(line)
    fields = dict(kv.split("=", 1) for kv in m.group(2).split() if "=" in kv)
    fields["version"] = m.group(1)
    return fields


def _crc_ok(bodies: list[bytes], crcs: np.ndarray) -> np.ndarray:
    """Vectorised CRC check: group equal-length bodies into 2-D uint8 arrays."""
    ok = np.zeros(len(bodies), dtype=bool)
    lengths = np.fromiter((len(b) for b in bodies), dtype=np.int64, count=len(bodies))
    for length in np.unique(lengths):
        sel = np.flatnonzero(lengths == length)
        block = np.frombuffer(b"".join(bodies[i] for i in sel), dtype=np.uint8).reshape(sel.size, int(length))
        ok[sel] = crc16_ccitt_false_rows(block) == crcs[sel]
    return ok


def _parse_fields(bodies: list[str], line_idx: list[int], skip) -> tuple[np.ndarray, list[int]]:
    """9 integers per body -> (n, 9) int64. Fast path: one numpy parse of the joined text; otherwise
    line by line, reporting each bad line through ``skip``."""
    joined = "\n".join(bodies)
    if bodies and joined.count(",") == 8 * len(bodies) and ",," not in joined and ",\n" not in joined:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            flat = np.fromstring(joined.replace("\n", ","), sep=",", dtype=np.int64)
        if flat.size == 9 * len(bodies):
            return flat.reshape(-1, 9), list(line_idx)
    rows, keep = [], []
    for b, i in zip(bodies, line_idx):
        f = b.split(",")
        if len(f) != 9:
            skip(i, f"{len(f)} fields, expected 9")
            continue
        try:
            rows.append([int(x) for x in f])
            keep.append(i)
        except ValueError:
            skip(i, "non-integer field")
    return np.array(rows, dtype=np.int64).reshape(-1, 9), keep


def _lines_and_offsets(text: str, data: bytes) -> tuple[list[str], np.ndarray, dict[int, int]]:
    """Lines of the log, the byte offset of each line start in ``data``, and {line index: offset of its first
    non-ASCII byte}.

    The lines come from ``data`` read as latin-1 (one character per byte), so every offset stays exact after
    any invalid UTF-8 byte; a UTF-8 byte-order mark is removed from the first line's text (not its offsets).
    A UTF-16 file (a log saved again by a Windows editor) is split from ``text``, its offsets in UTF-16 bytes.
    """
    utf16 = utf16_encoding(data)
    if utf16:
        lines = text.split("\n")
        bom = 2 if data[:2] in (b"\xff\xfe", b"\xfe\xff") else 0
        sizes = np.fromiter((len(ln.encode("utf-16-le")) + 2 for ln in lines), dtype=np.int64, count=len(lines))
        offsets = bom + np.concatenate(([0], np.cumsum(sizes[:-1])))
        return lines, offsets, {}
    lines = data.decode("latin-1").split("\n")
    offsets = np.concatenate(([0], np.cumsum(np.fromiter((len(ln) + 1 for ln in lines[:-1]), dtype=np.int64,
                                                         count=len(lines) - 1))))
    bom = 3 if data[:3] == b"\xef\xbb\xbf" else 0
    lines[0] = lines[0][bom:]
    pos = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) >= 0x80)
    pos = pos[pos >= bom]
    line_of = np.searchsorted(offsets, pos, side="right") - 1
    first_line, first = np.unique(line_of, return_index=True)
    return lines, offsets, dict(zip(first_line.tolist(), pos[first].tolist()))


def _line_skipper(events: list, offsets: np.ndarray, ends_without_newline: bool, last: int):
    """``skip(i, why, kind)``: record line ``i`` (0-based) as skipped, a truncated last line (power loss) as such."""

    def skip(i: int, why: str, kind: str = "skipped_line"):
        trunc = ends_without_newline and i == last
        events.append(dict(kind="skipped_line" if trunc else kind, line=i + 1, byte_offset=int(offsets[i]), count=1,
                           detail=("truncated last line (power loss?): " if trunc else "") + why))

    return skip


def _scan_lines(path: Path, lines: list[str], non_ascii: dict[int, int], data: bytes, skip, truncated_last: int):
    """Sort the lines into headers and candidate data lines (body, CRC, line index); the others are skipped.

    Returns (first header or None, [(line index, header)], bodies, CRCs, candidate line indices);
    ``truncated_last`` is the index of a last line without its newline (-1: none).
    """
    header: dict[str, str] | None = None
    headers: list[tuple[int, dict]] = []
    bodies: list[bytes] = []
    crcs: list[int] = []
    cand_lines: list[int] = []  # 0-based line index of candidate data lines
    gc_was = gc.isenabled()
    gc.disable()  # hundreds of thousands of small strings: the cyclic GC would rescan them repeatedly
    try:
        for i, ln in enumerate(lines):
            s = ln.rstrip("\r").strip()
            if not s:
                continue
            if i in non_ascii:  # the format is ASCII: a comment keeps its UTF-8 text, a data line is corrupt
                if s.startswith("#"):
                    s = s.encode("latin-1").decode("utf-8", errors="replace")
                else:
                    b = non_ascii[i]
                    skip(i, f"byte 0x{data[b]:02X} at byte offset {b} is not ASCII (invalid UTF-8 or a corrupted "
                            f"byte): {s[:60]!r}", kind="crc_error")
                    continue
            if s.startswith("#"):
                if s.startswith(HEADER_PREFIX) or re.match(r"^#\s*bootnav-sd", s):
                    try:
                        h = parse_header(s)
                    except ValueError:
                        skip(i, f"unreadable header {s[:60]!r}")
                        continue
                    if header is not None and any(h.get(k) != header.get(k) for k in ("accel_fs", "gyro_fs")):
                        raise InputError(f"{path}: line {i + 1}: full-scale ranges change mid-file "
                                         f"({header} -> {h}); split the file at this line")
                    headers.append((i, h))
                    header = header or h
                continue
            body, star, crc_text = s.rpartition("*")
            try:
                crc_value = int(crc_text, 16) if len(crc_text) == 4 and crc_text.isalnum() else -1
            except ValueError:
                crc_value = -1
            if not star or crc_value < 0:
                skip(i, f"truncated line, no '*CRC' at the end: {s[:60]!r}",
                     kind="crc_error" if i != truncated_last else "skipped_line")
                continue
            bodies.append(body.encode("ascii", "replace"))
            crcs.append(crc_value)
            cand_lines.append(i)
    finally:
        if gc_was:
            gc.enable()
    return header, headers, bodies, crcs, cand_lines


def _crc_checked(bodies: list[bytes], crcs: list[int], cand_lines: list[int], offsets: np.ndarray,
                 events: list) -> tuple[list[str], list[int]]:
    """The bodies whose CRC matches and their line indices; a mismatch is a ``crc_error`` event."""
    ok = _crc_ok(bodies, np.asarray(crcs, dtype=np.uint16)) if bodies else np.zeros(0, bool)
    good_bodies: list[str] = []
    good_idx: list[int] = []
    for b, i, c_ok in zip(bodies, cand_lines, ok):
        if not c_ok:  # a complete '*HHHH' that does not match: corruption, even on the last line
            events.append(dict(kind="crc_error", line=i + 1, byte_offset=int(offsets[i]), count=1,
                               detail=f"CRC mismatch: {b[:60].decode('ascii', 'replace')!r}"))
            continue
        good_bodies.append(b.decode("ascii"))
        good_idx.append(i)
    return good_bodies, good_idx


def _register_codes(path: Path, header: dict, overrides: dict) -> tuple[int, int, int, int]:
    """(accel_fs, gyro_fs, dlpf, smplrt_div) register codes from the header (the ranges overridable; -1 for a
    dlpf or divider the header does not give), or an ``InputError`` naming the header field and the fix."""

    def code(key: str, valid, flag: str, unit: str, default=None) -> int:
        """A header field as an integer register code, or an InputError naming the header and the fix."""
        text = header.get(key, default)
        try:
            value = int(text)
        except (TypeError, ValueError):
            value = None
        if value is None or (valid is not None and value not in valid):
            choices = f" (valid: {', '.join(f'{c} = +-{r} {unit}' for c, r in valid.items())})" if valid else ""
            fix = f"; give the range with {flag}" if flag else ""
            raise InputError(f"{path}: line 1 (header): {key}={text} is not a valid MPU6050 code{choices}; the header "
                             f"is damaged or not from a bootnav logger{fix}")
        return value

    if "acc_range_g" in overrides:
        accel_fs = mpu6050.accel_code(overrides["acc_range_g"])
    else:
        accel_fs = code("accel_fs", mpu6050.ACCEL_RANGE_G, "--acc-range G", "g")
    if "gyro_range_dps" in overrides:
        gyro_fs = mpu6050.gyro_code(overrides["gyro_range_dps"])
    else:
        gyro_fs = code("gyro_fs", mpu6050.GYRO_RANGE_DPS, "--gyro-range DPS", "deg/s")
    return accel_fs, gyro_fs, code("dlpf", None, "", "", -1), code("smplrt_div", None, "", "", -1)


def _sequence_events(seq_counts: np.ndarray, line_numbers: np.ndarray) -> list[dict]:
    """A repeated sequence number is a note, a jump a ``gap`` event with the number of missing samples."""
    events = []
    seq = seq_counts.astype(np.uint16)
    dseq = np.diff(seq_counts) % SEQ_MODULUS
    for j in np.flatnonzero(dseq != 1):
        i = j + 1
        if dseq[j] == 0:
            events.append(dict(kind="note", sample_index=int(i), line=int(line_numbers[i]),
                               detail=f"sequence number {seq[i]} repeated"))
        else:
            events.append(dict(kind="gap", sample_index=int(i), line=int(line_numbers[i]), count=int(dseq[j] - 1),
                               detail=f"seq {seq[i - 1]} -> {seq[i]}: {dseq[j] - 1} sample(s) missing"))
    return events


def read_sd_log(path: Path, text: str, raw: bytes, data: bytes | None = None, **overrides) -> ImportResult:
    """Parse and check our SD-card log (module docstring).

    ``text`` is the decoded file, ``raw`` the file's bytes (for its hash) and ``data`` the decompressed
    bytes (``raw`` undone from gzip when None): byte offsets are counted in ``data``.
    """
    data = decompress(raw)[0] if data is None else data
    lines, offsets, non_ascii = _lines_and_offsets(text, data)
    ends_without_newline = not text.endswith("\n")
    if not ends_without_newline:
        lines.pop()
        offsets = offsets[:-1]
    events: list[dict] = []
    last = len(lines) - 1
    messages = []
    skip = _line_skipper(events, offsets, ends_without_newline, last)
    header, headers, bodies, crcs, cand_lines = _scan_lines(path, lines, non_ascii, data, skip,
                                                            last if ends_without_newline else -1)
    if header is None:
        if "acc_range_g" not in overrides or "gyro_range_dps" not in overrides:
            raise InputError(f"{path}: SD-card log without a '# bootnav-sd v1 ...' header line; "
                             f"give --acc-range and --gyro-range")
        header = {"accel_fs": str(mpu6050.accel_code(overrides["acc_range_g"])),
                  "gyro_fs": str(mpu6050.gyro_code(overrides["gyro_range_dps"])), "version": "1"}
    good_bodies, good_idx = _crc_checked(bodies, crcs, cand_lines, offsets, events)
    # fields: 9 integers within range
    arr, row_lines = _parse_fields(good_bodies, good_idx, skip)
    lim = np.array([LIMITS.get(k, (mpu6050.INT16_MIN, mpu6050.INT16_MAX)) for k in SAMPLE_FIELDS])
    in_range = np.all((arr >= lim[:, 0]) & (arr <= lim[:, 1]), axis=1)
    for j in np.flatnonzero(~in_range):
        skip(row_lines[j], "value out of range for its type (u32 t_us, u16 seq, i16 counts)")
    arr = arr[in_range]
    line_numbers = np.asarray(row_lines, dtype=np.int64)[in_range] + 1
    n = arr.shape[0]
    if n == 0:
        raise InputError(f"{path}: no valid data line (of {len(lines)} lines)")

    t_dev = arr[:, 0].astype(np.uint32)
    t_unwrapped, wraps = unwrap_counter(arr[:, 0])
    for i in wraps:
        events.append(dict(kind="time_wrap", sample_index=int(i), line=int(line_numbers[i]), count=1,
                           detail="uint32 microsecond clock wrapped (71.6 min); 2**32 us added"))
    t = (t_unwrapped - t_unwrapped[0]) * 1e-6
    accel_fs, gyro_fs, dlpf, div = _register_codes(path, header, overrides)
    rate_nominal = (1000.0 if 1 <= dlpf <= 6 else 8000.0) / (1 + div) if div >= 0 and dlpf >= 0 else float("nan")
    events += time_events(t, line_numbers, nominal_dt=1 / rate_nominal if np.isfinite(rate_nominal) else None,
                          with_gaps=False)  # the frame counter reports the gaps (the one gap rule)
    seq = arr[:, 1].astype(np.uint16)
    events += _sequence_events(arr[:, 1], line_numbers)
    for h_line, h in headers:
        events.append(dict(kind="header", line=h_line + 1, byte_offset=int(offsets[h_line]),
                           detail=" ".join(f"{k}={v}" for k, v in h.items())))
    for e in events:
        if e.get("sample_index", -1) >= 0:
            e["t_s"] = float(t[e["sample_index"]])

    acc = arr[:, 2:5].astype(np.int16)
    gyro = arr[:, 5:8].astype(np.int16)
    temp = arr[:, 8].astype(np.int16)
    acc_ch = counts_channel("acc", mpu6050.accel_scale_mps2(accel_fs))
    gyro_ch = counts_channel("gyro", mpu6050.gyro_scale_radps(gyro_fs))
    rate_check = rate_nominal if np.isfinite(rate_nominal) else timing_summary(t)["rate_measured_hz"]
    if overrides.get("check_units", True):
        for p in (checks.acc_unit_problem(acc, acc_ch.scale_to_si, f"counts at +-{mpu6050.ACCEL_RANGE_G[accel_fs]} g",
                                          rate_check),
                  checks.gyro_unit_problem(gyro * gyro_ch.scale_to_si, "counts")):
            if p:
                raise InputError(f"{path}: {p} (header says accel_fs={accel_fs}; override with --acc-range)")
    sat_a, ev_a = checks.saturation(acc, 32767.0, True, 0)
    sat_g, ev_g = checks.saturation(gyro, 32767.0, True, 3)
    for e in ev_a + ev_g:
        e["t_s"] = float(t[e["sample_index"]])
        e["line"] = int(line_numbers[e["sample_index"]])
    events += ev_a + ev_g
    n_bad = sum(1 for e in events if e["kind"] in ("crc_error", "skipped_line"))
    if n_bad:
        bad = sorted((e["line"], e["detail"]) for e in events if e["kind"] in ("crc_error", "skipped_line"))
        messages.append(f"{n_bad} bad line(s) in {path.name} (CRC or format), skipped: lines "
                        + ", ".join(str(ln) for ln, _ in bad[:10]) + (" ..." if len(bad) > 10 else ""))
        messages += [f"  {path.name}:{ln}: {why}" for ln, why in bad[:10]]
    summary = timing_summary(t)
    meta = dict(
        source_file=str(path.resolve()), source_sha256=hashlib.sha256(raw).hexdigest(), importer_profile="bootnav_sd",
        device="MPU6050", device_id=header.get("device_id", ""), firmware_version=header.get("fw", ""),
        accel_range_g=float(mpu6050.ACCEL_RANGE_G[accel_fs]), gyro_range_dps=float(mpu6050.GYRO_RANGE_DPS[gyro_fs]),
        dlpf_cfg=dlpf, smplrt_div=div, rate_nominal_hz=rate_nominal, mount=overrides.get("mount", "unknown"),
        detected=dict(format="bootnav-sd v" + header.get("version", "?"), header=header),
        acc_unit_source_file="counts", gyro_unit_source_file="counts", time_unit_source_file="us",
        acc_quantity="specific_force", gyro_present=1, lines_total=len(lines),
        lines_skipped=n_bad, crc_errors=sum(1 for e in events if e["kind"] == "crc_error"), **summary,
    )
    messages.insert(0, f"profile: bootnav_sd (auto-detected: '# bootnav-sd' header), accel_fs={accel_fs} "
                       f"gyro_fs={gyro_fs}, {rate_nominal:g} Hz nominal")
    messages.append(f"samples: {n}, {summary['rate_measured_hz']:.4g} Hz measured, {t[-1]:.3f} s; "
                    f"{len(wraps)} clock wrap(s), {sum(1 for e in events if e['kind'] == 'gap')} seq gap(s)")
    return ImportResult(source=path, profile="bootnav_sd", t_s=t, acc=acc, gyro=gyro, acc_channel=acc_ch,
                        gyro_channel=gyro_ch, saturated=(sat_a | sat_g).astype(np.uint8), events=events, meta=meta,
                        optional=dict(temp=temp, temp_channel=counts_channel("temp", 1.0 / mpu6050.TEMP_LSB_PER_DEGC),
                                      t_device=t_dev, seq=seq), messages=messages)
