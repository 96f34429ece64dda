"""bootnav boot-sensor protocol v1: frame pack/unpack and a streaming, resynchronising parser.

The byte layout is defined in ``firmware-protocol/PROTOCOL.md`` (the contract with the firmware);
this module is its Python implementation. Every frame is

    sync 0xA5 0x5A | type u8 | version u8 | seq u16 | t_us u32 | payload | crc u16     (little-endian)

with ``crc = CRC-16/CCITT-FALSE(bytes[2 : -2])``.

``FrameParser`` turns an arbitrary byte stream (split anywhere into ``feed`` calls) into frames.
Decisions only depend on complete bytes, so the result does not depend on where the stream was
split. It never returns a frame whose CRC fails, and a bad-CRC candidate consumes nothing: the search
for the next sync word restarts two bytes later, so a real frame hidden behind a spurious
``A5 5A`` in garbage is still found. Work per ``feed`` is vectorised with numpy (sync search, CRC of
all candidates, batch decode through a structured dtype), so throughput is far above the
1000 frames/s a boot sensor produces.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

from bootnav.logger.crc import crc16_ccitt_false, crc16_ccitt_false_rows

SYNC = b"\xA5\x5A"
SYNC0, SYNC1 = 0xA5, 0x5A
PROTOCOL_VERSION = 1
TYPE_SAMPLE, TYPE_HEADER, TYPE_STATUS = 0x01, 0x02, 0x03
FRAME_SIZE = {TYPE_SAMPLE: 26, TYPE_HEADER: 24, TYPE_STATUS: 16}
MAX_FRAME_SIZE = max(FRAME_SIZE.values())
PREFIX_SIZE = 4  # sync + type + version: enough to know a candidate's length
CMD_RESEND_HEADER = b"H"  # host -> device: send a header frame now

STATUS_CODES = {
    1: "sensor missing (WHO_AM_I != 0x68)",
    2: "SD card absent",
    3: "SD card full / write error",
    4: "sample overrun (data-ready missed)",
    5: "I2C error",
}

# Structured views of the frames (packed, little-endian). Used for batch decoding.
SAMPLE_DTYPE = np.dtype(
    [("sync", "<u2"), ("type", "u1"), ("version", "u1"), ("seq", "<u2"), ("t_us", "<u4"),
     ("acc", "<i2", (3,)), ("gyro", "<i2", (3,)), ("temp", "<i2"), ("crc", "<u2")]
)
assert SAMPLE_DTYPE.itemsize == FRAME_SIZE[TYPE_SAMPLE]

#: What ``FrameParser`` returns for sample frames: decoded fields + absolute stream offset.
SAMPLES_DTYPE = np.dtype(
    [("offset", "<i8"), ("seq", "<u2"), ("t_us", "<u4"), ("acc", "<i2", (3,)), ("gyro", "<i2", (3,)),
     ("temp", "<i2")]
)

_HEAD = struct.Struct("<2sBBHI")  # sync, type, version, seq, t_us (10 bytes)
_SAMPLE_BODY = struct.Struct("<7h")
_HEADER_BODY = struct.Struct("<BBBB3BBI")
_STATUS_BODY = struct.Struct("<BBH")
_CRC = struct.Struct("<H")


class ProtocolError(ValueError):
    """A byte string that is not a valid v1 frame (message says why)."""


def _finish(body: bytes) -> bytes:
    return body + _CRC.pack(crc16_ccitt_false(body[2:]))


def _check(buf: bytes, ftype: int) -> bytes:
    buf = bytes(buf)
    size = FRAME_SIZE[ftype]
    if len(buf) != size:
        raise ProtocolError(f"frame type {ftype:#04x} must be {size} bytes, got {len(buf)}")
    if buf[:2] != SYNC:
        raise ProtocolError(f"bad sync word {buf[:2].hex()} (expected a55a)")
    if buf[2] != ftype:
        raise ProtocolError(f"type byte {buf[2]:#04x}, expected {ftype:#04x}")
    if buf[3] != PROTOCOL_VERSION:
        raise ProtocolError(f"unsupported protocol version {buf[3]} (this receiver knows {PROTOCOL_VERSION})")
    crc_rx = _CRC.unpack_from(buf, size - 2)[0]
    crc = crc16_ccitt_false(buf[2 : size - 2])
    if crc != crc_rx:
        raise ProtocolError(f"CRC mismatch: frame says {crc_rx:#06x}, bytes give {crc:#06x}")
    return buf


@dataclass(frozen=True)
class SampleFrame:
    """Type 0x01: one MPU6050 sample, raw int16 counts."""

    seq: int
    t_us: int
    acc: tuple[int, int, int]
    gyro: tuple[int, int, int]
    temp: int
    offset: int = field(default=-1, compare=False)  # absolute byte offset in the stream, -1 if n/a

    type_code = TYPE_SAMPLE

    def pack(self) -> bytes:
        return _finish(_HEAD.pack(SYNC, TYPE_SAMPLE, PROTOCOL_VERSION, self.seq & 0xFFFF, self.t_us & 0xFFFFFFFF)
                       + _SAMPLE_BODY.pack(*self.acc, *self.gyro, self.temp))

    @classmethod
    def unpack(cls, buf: bytes, offset: int = -1) -> "SampleFrame":
        buf = _check(buf, TYPE_SAMPLE)
        _, _, _, seq, t_us = _HEAD.unpack_from(buf)
        v = _SAMPLE_BODY.unpack_from(buf, 10)
        return cls(seq, t_us, tuple(v[0:3]), tuple(v[3:6]), v[6], offset)


@dataclass(frozen=True)
class HeaderFrame:
    """Type 0x02: sensor configuration (full-scale codes, DLPF, divider, firmware, device id)."""

    seq: int  # seq of the next sample frame
    t_us: int
    accel_fs: int = 3  # AFS_SEL 0..3 = +-2/4/8/16 g
    gyro_fs: int = 3  # FS_SEL 0..3 = +-250/500/1000/2000 deg/s
    dlpf: int = 3
    smplrt_div: int = 4
    fw_version: tuple[int, int, int] = (0, 1, 0)
    flags: int = 0b10  # bit0 SD logging, bit1 serial streaming
    device_id: int = 0
    offset: int = field(default=-1, compare=False)

    type_code = TYPE_HEADER

    @property
    def rate_hz(self) -> float:
        """Nominal output data rate: gyro rate (1 kHz with DLPF 1..6, else 8 kHz) / (1 + SMPLRT_DIV)."""
        return (1000.0 if 1 <= self.dlpf <= 6 else 8000.0) / (1 + self.smplrt_div)

    @property
    def fw_string(self) -> str:
        return ".".join(str(v) for v in self.fw_version)

    def config(self) -> dict:
        """The fields that describe the sensor set-up (seq/t_us/offset excluded)."""
        return {"accel_fs": self.accel_fs, "gyro_fs": self.gyro_fs, "dlpf": self.dlpf,
                "smplrt_div": self.smplrt_div, "fw_version": self.fw_string, "flags": self.flags,
                "device_id": self.device_id}

    def pack(self) -> bytes:
        return _finish(_HEAD.pack(SYNC, TYPE_HEADER, PROTOCOL_VERSION, self.seq & 0xFFFF, self.t_us & 0xFFFFFFFF)
                       + _HEADER_BODY.pack(self.accel_fs, self.gyro_fs, self.dlpf, self.smplrt_div,
                                           *self.fw_version, self.flags, self.device_id))

    @classmethod
    def unpack(cls, buf: bytes, offset: int = -1) -> "HeaderFrame":
        buf = _check(buf, TYPE_HEADER)
        _, _, _, seq, t_us = _HEAD.unpack_from(buf)
        a, g, d, div, f0, f1, f2, flags, dev = _HEADER_BODY.unpack_from(buf, 10)
        return cls(seq, t_us, a, g, d, div, (f0, f1, f2), flags, dev, offset)


@dataclass(frozen=True)
class StatusFrame:
    """Type 0x03: device status / error report (see ``STATUS_CODES``)."""

    seq: int
    t_us: int
    code: int
    detail: int = 0
    value: int = 0
    offset: int = field(default=-1, compare=False)

    type_code = TYPE_STATUS

    @property
    def meaning(self) -> str:
        return STATUS_CODES.get(self.code, f"unknown status code {self.code}")

    def pack(self) -> bytes:
        return _finish(_HEAD.pack(SYNC, TYPE_STATUS, PROTOCOL_VERSION, self.seq & 0xFFFF, self.t_us & 0xFFFFFFFF)
                       + _STATUS_BODY.pack(self.code, self.detail, self.value))

    @classmethod
    def unpack(cls, buf: bytes, offset: int = -1) -> "StatusFrame":
        buf = _check(buf, TYPE_STATUS)
        _, _, _, seq, t_us = _HEAD.unpack_from(buf)
        code, detail, value = _STATUS_BODY.unpack_from(buf, 10)
        return cls(seq, t_us, code, detail, value, offset)


Frame = SampleFrame | HeaderFrame | StatusFrame
_CLASSES = {TYPE_SAMPLE: SampleFrame, TYPE_HEADER: HeaderFrame, TYPE_STATUS: StatusFrame}


def unpack_frame(buf: bytes, offset: int = -1) -> Frame:
    """Decode exactly one frame of any type; raise ``ProtocolError`` saying what is wrong."""
    buf = bytes(buf)
    if len(buf) < PREFIX_SIZE:
        raise ProtocolError(f"truncated frame: {len(buf)} bytes")
    if buf[:2] != SYNC:
        raise ProtocolError(f"bad sync word {buf[:2].hex()} (expected a55a)")
    cls = _CLASSES.get(buf[2])
    if cls is None:
        raise ProtocolError(f"unknown frame type {buf[2]:#04x}")
    return cls.unpack(buf, offset)


def pack_samples(seq, t_us, acc, gyro, temp) -> bytes:
    """Pack many sample frames at once (vectorised; used by the emulator and benchmarks)."""
    seq = np.asarray(seq)
    n = seq.shape[0]
    rows = np.zeros(n, dtype=SAMPLE_DTYPE)
    rows["sync"] = SYNC0 | (SYNC1 << 8)
    rows["type"] = TYPE_SAMPLE
    rows["version"] = PROTOCOL_VERSION
    rows["seq"] = seq.astype(np.int64) & 0xFFFF
    rows["t_us"] = np.asarray(t_us).astype(np.int64) & 0xFFFFFFFF
    rows["acc"] = acc
    rows["gyro"] = gyro
    rows["temp"] = temp
    raw = rows.view(np.uint8).reshape(n, SAMPLE_DTYPE.itemsize)
    rows["crc"] = crc16_ccitt_false_rows(raw[:, 2:-2])
    return rows.tobytes()


# --------------------------------------------------------------------------- SD-card text lines

def format_sd_line(frame: SampleFrame) -> str:
    """``t_us,seq,ax,ay,az,gx,gy,gz,temp*CRC`` (no line end); CRC over the text before ``*``."""
    text = ",".join(str(v) for v in (frame.t_us, frame.seq, *frame.acc, *frame.gyro, frame.temp))
    return f"{text}*{crc16_ccitt_false(text.encode('ascii')):04X}"


def format_sd_header(header: HeaderFrame) -> str:
    return (f"# bootnav-sd v{PROTOCOL_VERSION} accel_fs={header.accel_fs} gyro_fs={header.gyro_fs} "
            f"dlpf={header.dlpf} smplrt_div={header.smplrt_div} fw={header.fw_string} "
            f"device_id=0x{header.device_id:08X}")


def parse_sd_line(line: str) -> SampleFrame:
    """Parse one SD data line; raise ``ProtocolError`` (truncated / bad CRC / bad field)."""
    line = line.rstrip("\r\n")
    text, star, crc_text = line.partition("*")
    if not star or len(crc_text) != 4:
        raise ProtocolError("truncated line (no '*CRC' suffix)")
    try:
        crc_rx = int(crc_text, 16)
    except ValueError:
        raise ProtocolError(f"bad CRC field {crc_text!r}") from None
    crc = crc16_ccitt_false(text.encode("ascii", "replace"))
    if crc != crc_rx:
        raise ProtocolError(f"CRC mismatch: line says {crc_rx:04X}, text gives {crc:04X}")
    parts = text.split(",")
    if len(parts) != 9:
        raise ProtocolError(f"expected 9 fields, got {len(parts)}")
    v = [int(p) for p in parts]
    return SampleFrame(v[1], v[0], tuple(v[2:5]), tuple(v[5:8]), v[8])


# --------------------------------------------------------------------------- streaming parser

@dataclass(frozen=True)
class ParserEvent:
    """Something the parser skipped. ``byte_offset`` is absolute in the stream.

    kinds: ``resync`` (``count`` bytes skipped before the next good frame), ``crc_error`` (a complete
    known-type candidate whose CRC failed; ``frame_type`` says which), ``unknown`` (sync word followed by
    an unknown type or version), ``truncated`` (stream ended inside a frame, from ``finish``).
    """

    kind: str
    byte_offset: int
    count: int = 0
    frame_type: int = -1
    detail: str = ""


@dataclass
class ParseResult:
    samples: np.ndarray  # SAMPLES_DTYPE, in stream order
    headers: list[HeaderFrame]
    statuses: list[StatusFrame]
    events: list[ParserEvent]

    def frames(self) -> list[Frame]:
        """Every frame as a dataclass, in stream order (convenient, slower than ``samples``)."""
        out: list[Frame] = [
            SampleFrame(int(s["seq"]), int(s["t_us"]), tuple(int(v) for v in s["acc"]),
                        tuple(int(v) for v in s["gyro"]), int(s["temp"]), int(s["offset"]))
            for s in self.samples
        ]
        out += self.headers + self.statuses
        return sorted(out, key=lambda f: f.offset)


@dataclass
class ParserStats:
    bytes_in: int = 0
    samples: int = 0
    headers: int = 0
    statuses: int = 0
    crc_errors: int = 0
    resyncs: int = 0
    skipped_bytes: int = 0
    unknown: int = 0


_LENGTH_BY_TYPE = np.zeros(256, dtype=np.int64)
for _t, _n in FRAME_SIZE.items():
    _LENGTH_BY_TYPE[_t] = _n


def _covered(positions: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """True where a position lies inside one of the sorted, non-overlapping [start, end) frames."""
    if starts.size == 0:
        return np.zeros(positions.size, dtype=bool)
    k = np.searchsorted(starts, positions, side="right") - 1
    return (k >= 0) & (positions < ends[np.maximum(k, 0)])


class FrameParser:
    """Streaming v1 frame parser: ``feed(bytes) -> ParseResult``; ``finish()`` at end of stream.

    ``base_offset`` is the absolute stream offset of the first byte fed (a recorder that reconnects
    continues its byte count, so offsets stay unique within one recording).
    """

    def __init__(self, base_offset: int = 0):
        self._buf = b""
        self._buf_offset = base_offset  # absolute offset of self._buf[0]
        self._pos = base_offset  # absolute end of the last accepted frame (= start of skipped bytes)
        self.stats = ParserStats()

    @property
    def offset(self) -> int:
        """Absolute offset just past the last byte fed."""
        return self._buf_offset + len(self._buf)

    def feed(self, data: bytes) -> ParseResult:
        self.stats.bytes_in += len(data)
        buf = self._buf + bytes(data)
        base = self._buf_offset
        b = np.frombuffer(buf, dtype=np.uint8)
        n = b.size
        cand = np.flatnonzero((b[:-1] == SYNC0) & (b[1:] == SYNC1)) if n >= 2 else np.zeros(0, np.int64)
        # Length of each candidate: 0 = unknown type/version, -1 = prefix not yet complete.
        has_prefix = cand + PREFIX_SIZE <= n
        ftype = np.full(cand.size, -1, dtype=np.int64)
        ftype[has_prefix] = b[cand[has_prefix] + 2]
        version_ok = np.zeros(cand.size, dtype=bool)
        version_ok[has_prefix] = b[cand[has_prefix] + 3] == PROTOCOL_VERSION
        length = np.where(has_prefix, np.where(version_ok, _LENGTH_BY_TYPE[np.maximum(ftype, 0)], 0), -1)
        complete = (length > 0) & (cand + length <= n)
        incomplete = (length < 0) | ((length > 0) & ~complete)
        valid = np.zeros(cand.size, dtype=bool)
        for t, size in FRAME_SIZE.items():
            sel = np.flatnonzero(complete & (ftype == t))
            if sel.size:
                rows = b[cand[sel, None] + np.arange(size)]
                crc_rx = rows[:, size - 2].astype(np.uint16) | (rows[:, size - 1].astype(np.uint16) << 8)
                valid[sel] = crc16_ccitt_false_rows(rows[:, 2 : size - 2]) == crc_rx

        # Greedy chain over good frames (earliest first, no overlap), starting at the last accepted end.
        pos_rel = self._pos - base
        good = np.flatnonzero(valid & (cand >= pos_rel))
        starts, ends = cand[good], cand[good] + length[good]
        if starts.size > 1 and np.any(starts[1:] < ends[:-1]):
            keep, end = [], pos_rel
            for i, (s, e) in enumerate(zip(starts.tolist(), ends.tolist())):
                if s >= end:
                    keep.append(i)
                    end = e
            good, starts, ends = good[keep], starts[keep], ends[keep]
        # Stop at the first incomplete candidate not covered by an accepted frame that starts before it.
        stop = n
        inc = cand[incomplete & (cand >= pos_rel)]
        if inc.size:
            covered = _covered(inc, starts, ends)
            if np.any(~covered):
                stop = int(inc[~covered][0])
        accept = starts < stop
        good, starts, ends = good[accept], starts[accept], ends[accept]

        events: list[ParserEvent] = []
        # Bad-CRC and unknown candidates that were not inside an accepted frame.
        bad = np.flatnonzero(((complete & ~valid) | (length == 0)) & (cand >= pos_rel) & (cand < stop))
        if bad.size:
            inside = _covered(cand[bad], starts, ends)
            for i in bad[~inside].tolist():
                if length[i] == 0:
                    self.stats.unknown += 1
                    events.append(ParserEvent("unknown", base + int(cand[i]), 0, int(ftype[i]),
                                              f"type {int(ftype[i]):#04x} version {int(b[cand[i] + 3])}"))
                else:
                    self.stats.crc_errors += 1
                    events.append(ParserEvent("crc_error", base + int(cand[i]), int(length[i]), int(ftype[i])))
        # Skipped bytes before each accepted frame.
        prev_end = np.concatenate(([pos_rel], ends[:-1]))
        for i in np.flatnonzero(starts > prev_end).tolist():
            gap = int(starts[i] - prev_end[i])
            self.stats.resyncs += 1
            self.stats.skipped_bytes += gap
            events.append(ParserEvent("resync", base + int(prev_end[i]), gap))
        events.sort(key=lambda e: e.byte_offset)

        samples, headers, statuses = self._decode(b, starts, ftype[good], base)
        if ends.size:
            self._pos = base + int(ends[-1])
        # Keep only bytes that may still start a frame: from the stop point, or a trailing 0xA5.
        keep_from = stop if stop < n else (n - 1 if n and b[n - 1] == SYNC0 else n)
        keep_from = max(keep_from, self._pos - base)
        self._buf = buf[keep_from:]
        self._buf_offset = base + keep_from
        return ParseResult(samples, headers, statuses, events)

    def _decode(self, b: np.ndarray, starts: np.ndarray, ftypes: np.ndarray, base: int):
        is_sample = ftypes == TYPE_SAMPLE
        s0 = starts[is_sample]
        samples = np.zeros(s0.size, dtype=SAMPLES_DTYPE)
        if s0.size:
            rows = np.ascontiguousarray(b[s0[:, None] + np.arange(SAMPLE_DTYPE.itemsize)])
            dec = rows.view(SAMPLE_DTYPE).reshape(-1)
            samples["offset"] = s0 + base
            for name in ("seq", "t_us", "acc", "gyro", "temp"):
                samples[name] = dec[name]
        headers: list[HeaderFrame] = []
        statuses: list[StatusFrame] = []
        for s, t in zip(starts[~is_sample].tolist(), ftypes[~is_sample].tolist()):
            frame = _CLASSES[t].unpack(b[s : s + FRAME_SIZE[t]].tobytes(), base + s)
            (headers if t == TYPE_HEADER else statuses).append(frame)
        self.stats.samples += s0.size
        self.stats.headers += len(headers)
        self.stats.statuses += len(statuses)
        return samples, headers, statuses

    def finish(self) -> list[ParserEvent]:
        """End of stream: report bytes left over (a truncated frame or trailing garbage)."""
        events = []
        end = self.offset
        if end > self._pos:
            has_sync = self._buf.find(SYNC) >= 0 or self._buf[:1] == SYNC[:1]
            kind = "truncated" if has_sync else "resync"
            events.append(ParserEvent(kind, self._pos, end - self._pos, -1,
                                      "stream ended inside a frame" if has_sync else "trailing bytes"))
            self.stats.skipped_bytes += end - self._pos
        self._buf = b""
        self._buf_offset = end
        self._pos = end
        return events


def parse_stream(data: bytes, base_offset: int = 0) -> ParseResult:
    """Parse a complete byte string (feed + finish)."""
    parser = FrameParser(base_offset)
    result = parser.feed(data)
    result.events.extend(parser.finish())
    return result
