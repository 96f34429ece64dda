#!/usr/bin/env python3
"""Regenerate the protocol-v1 test vectors (deterministic: no randomness, no clock).

    python firmware-protocol/test-vectors/generate.py [--out DIR]

Writes ``vectors.json`` and ``vectors.txt`` (same content, line-based for C). The expected results are
written down by hand here (frame offsets, event kinds/offsets/counts), NOT taken from the parser;
the script then checks that ``bootnav.logger.protocol`` agrees with every one of them and fails otherwise.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

from bootnav.logger.crc import crc16_ccitt_false  # noqa: E402
from bootnav.logger.protocol import (  # noqa: E402
    HeaderFrame,
    ProtocolError,
    SampleFrame,
    StatusFrame,
    format_sd_line,
    parse_sd_line,
    parse_stream,
)

S1 = SampleFrame(1, 1000, (1, -2, 3), (4, 5, -6), -3920)
S_REST = SampleFrame(2, 2000, (0, 0, 2048), (-3, 7, 1), -3920)  # +-16 g: 2048 LSB = 1 g up
S_EXT = SampleFrame(65535, 4294967295, (-32768, 32767, 0), (32767, -32768, -1), 32767)
H_DEF = HeaderFrame(3, 2500, 3, 3, 3, 4, (0, 1, 0), 0b11, 0x0000BEEF)
H_1K = HeaderFrame(0, 0, 3, 3, 1, 0, (1, 2, 3), 0b10, 0x12345678)
ST_OVR = StatusFrame(10, 12000, 4, 0, 7)
ST_WHO = StatusFrame(0, 300, 1, 0x72, 0)


def flip(data: bytes, byte: int, bit: int) -> bytes:
    out = bytearray(data)
    out[byte] ^= 1 << bit
    return bytes(out)


def with_version(frame, version: int) -> bytes:
    """A frame re-stamped with another version byte (CRC recomputed, so only the version is 'wrong')."""
    body = bytearray(frame.pack()[:-2])
    body[3] = version
    crc = crc16_ccitt_false(bytes(body[2:]))
    return bytes(body) + crc.to_bytes(2, "little")


def with_type(frame, ftype: int) -> bytes:
    body = bytearray(frame.pack()[:-2])
    body[2] = ftype
    crc = crc16_ccitt_false(bytes(body[2:]))
    return bytes(body) + crc.to_bytes(2, "little")


def samples(seqs, t_us, acc0=0):
    return [SampleFrame(s, t, (acc0 + i, -i, 2048), (i, 2 * i, -3 * i), -3920) for i, (s, t) in enumerate(zip(seqs, t_us))]


def frame_fields(frame, offset=None) -> dict:
    d = {"type": frame.type_code, "seq": frame.seq, "t_us": frame.t_us}
    if offset is not None:
        d = {"type": frame.type_code, "offset": offset, "seq": frame.seq, "t_us": frame.t_us}
    if isinstance(frame, SampleFrame):
        d.update(acc=list(frame.acc), gyro=list(frame.gyro), temp=frame.temp)
    elif isinstance(frame, HeaderFrame):
        d.update(accel_fs=frame.accel_fs, gyro_fs=frame.gyro_fs, dlpf=frame.dlpf, smplrt_div=frame.smplrt_div,
                 fw_version=list(frame.fw_version), flags=frame.flags, device_id=frame.device_id)
    else:
        d.update(code=frame.code, detail=frame.detail, value=frame.value)
    return d


def stream(name, description, pieces, events):
    """pieces: frames (kept) or raw bytes (skipped); events: hand-written [kind, offset, count]."""
    data, frames = b"", []
    for p in pieces:
        if isinstance(p, bytes):
            data += p
        else:
            frames.append(frame_fields(p, len(data)))
            data += p.pack()
    return {"kind": "stream", "name": name, "description": description, "hex": data.hex(),
            "expect": {"frames": frames, "events": events}}


def build() -> list[dict]:
    vectors: list[dict] = [
        {"kind": "crc", "name": "crc_check_123456789", "description": "catalogue check value",
         "hex": b"123456789".hex(), "expect": {"crc": 0x29B1}},
        {"kind": "crc", "name": "crc_empty", "description": "no bytes: the init value",
         "hex": "", "expect": {"crc": 0xFFFF}},
        {"kind": "crc", "name": "crc_sample_body", "description": "bytes 2..23 of frame_sample_basic",
         "hex": S1.pack()[2:24].hex(), "expect": {"crc": int.from_bytes(S1.pack()[24:], "little")}},
    ]
    for name, frame, desc in [
        ("frame_sample_basic", S1, "sample frame, small values"),
        ("frame_sample_rest_16g", S_REST, "sensor at rest, z up, +-16 g"),
        ("frame_sample_extremes", S_EXT, "int16 limits, seq and t_us at their maxima"),
        ("frame_header_default", H_DEF, "+-16 g, +-2000 dps, DLPF 3, div 4 (200 Hz), fw 0.1.0, SD+serial"),
        ("frame_header_1khz", H_1K, "DLPF 1, div 0 (1000 Hz)"),
        ("frame_status_overrun", ST_OVR, "code 4: 7 data-ready interrupts missed"),
        ("frame_status_sensor_missing", ST_WHO, "code 1: WHO_AM_I read 0x72"),
    ]:
        vectors.append({"kind": "frame", "name": name, "description": desc, "hex": frame.pack().hex(),
                        "expect": frame_fields(frame)})

    s3 = samples([7, 8, 9], [7000, 8000, 9000])
    a, b, c = (f.pack() for f in s3)
    L = 26
    vectors += [
        stream("stream_valid_sample", "one sample frame", [S1], []),
        stream("stream_valid_header", "one header frame", [H_DEF], []),
        stream("stream_valid_status", "one status frame", [ST_OVR], []),
        stream("stream_mixed", "header, samples, status back to back", [H_DEF, *s3, ST_OVR], []),
        stream("stream_bad_crc_field", "middle frame's CRC bytes wrong",
               [s3[0], a[:0] + b[:-2] + b"\x00\x00", s3[2]], [["crc_error", L, L], ["resync", L, L]]),
        stream("stream_bit_flip_payload", "one bit flipped in the middle frame's acc x",
               [s3[0], flip(b, 10, 3), s3[2]], [["crc_error", L, L], ["resync", L, L]]),
        stream("stream_bit_flip_sync", "first sync byte damaged: no candidate, bytes skipped silently",
               [s3[0], flip(b, 0, 0), s3[2]], [["resync", L, L]]),
        stream("stream_truncated_end", "stream ends 20 bytes into a frame",
               [s3[0], b[:20]], [["truncated", L, 20]]),
        stream("stream_truncated_then_valid", "13 bytes of a frame (power cut), then a whole frame",
               [a[:13], s3[1]], [["crc_error", 0, L], ["resync", 0, 13]]),
        stream("stream_leading_partial", "reception starts in the middle of a frame",
               [a[9:], s3[1], s3[2]], [["resync", 0, 17]]),
        stream("stream_garbage_between", "5 garbage bytes between frames",
               [s3[0], bytes.fromhex("00ff13a537"), s3[1]], [["resync", L, 5]]),
        stream("stream_garbage_fake_sync", "garbage ending in a fake sync+type+version overlapping a real frame",
               [s3[0], bytes.fromhex("a55a0101"), s3[1], s3[2]], [["crc_error", L, L], ["resync", L, 4]]),
        stream("stream_seq_wrap", "seq 65534, 65535, 0, 1 (no frame missing)",
               samples([65534, 65535, 0, 1], [1000, 2000, 3000, 4000]), []),
        stream("stream_t_us_wrap", "t_us wraps 2^32 -> 0 between frames 2 and 3",
               samples([5, 6, 7, 8], [4294965296, 4294966296, 0, 1000]), []),
        stream("stream_seq_gap", "seq 10, 11, 14: 2 frames missing (a gap, not a parse error)",
               samples([10, 11, 14], [10000, 11000, 14000]), []),
        stream("stream_unknown_version", "a version-2 frame (valid CRC) is skipped, next frame kept",
               [with_version(s3[0], 2), s3[1]], [["unknown", 0, 0], ["resync", 0, L]]),
        stream("stream_unknown_type", "type 0x7F (valid CRC) is skipped, next frame kept",
               [with_type(s3[0], 0x7F), s3[1]], [["unknown", 0, 0], ["resync", 0, L]]),
        stream("stream_only_garbage", "no sync word at all", [bytes(range(32))], [["resync", 0, 32]]),
    ]

    sd_ok = [S1, S_EXT, SampleFrame(0, 123456, (0, 0, 2048), (0, 0, 0), -3920)]
    for i, f in enumerate(sd_ok):
        vectors.append({"kind": "sdline", "name": f"sd_valid_{i}", "description": "valid data line",
                        "line": format_sd_line(f),
                        "expect": {"ok": True, "values": [f.t_us, f.seq, *f.acc, *f.gyro, f.temp]}})
    good = format_sd_line(S1)
    vectors += [
        {"kind": "sdline", "name": "sd_bad_crc", "description": "one digit changed, CRC kept",
         "line": good.replace("1000,", "1001,", 1), "expect": {"ok": False, "error": "CRC"}},
        {"kind": "sdline", "name": "sd_bad_crc_digits", "description": "CRC digits wrong",
         "line": good[:-4] + "0000", "expect": {"ok": False, "error": "CRC"}},
        {"kind": "sdline", "name": "sd_truncated", "description": "power cut mid-line (no '*CRC')",
         "line": good[:15], "expect": {"ok": False, "error": "truncated"}},
        {"kind": "sdline", "name": "sd_truncated_crc", "description": "power cut inside the CRC",
         "line": good[:-2], "expect": {"ok": False, "error": "truncated"}},
    ]
    vectors.append({"kind": "sdheader", "name": "sd_header_default", "description": "first line of an SD log",
                    "line": "# bootnav-sd v1 accel_fs=3 gyro_fs=3 dlpf=3 smplrt_div=4 fw=0.1.0 device_id=0x0000BEEF",
                    "expect": frame_fields(H_DEF) | {"seq": None, "t_us": None}})
    return vectors


def self_check(vectors: list[dict]) -> None:
    """Fail loudly if bootnav.logger.protocol disagrees with a hand-written expectation."""
    for v in vectors:
        exp = v["expect"]
        if v["kind"] == "crc":
            assert crc16_ccitt_false(bytes.fromhex(v["hex"])) == exp["crc"], v["name"]
        elif v["kind"] == "stream":
            r = parse_stream(bytes.fromhex(v["hex"]))
            got = [frame_fields(f, f.offset) for f in r.frames()]
            assert got == exp["frames"], (v["name"], got)
            ev = [[e.kind, e.byte_offset, e.count] for e in r.events]
            assert ev == exp["events"], (v["name"], ev)
        elif v["kind"] == "sdline":
            try:
                f = parse_sd_line(v["line"])
                assert exp["ok"] and [f.t_us, f.seq, *f.acc, *f.gyro, f.temp] == exp["values"], v["name"]
            except ProtocolError as err:
                assert not exp["ok"] and exp["error"] in str(err), (v["name"], err)


def _txt_value(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return ",".join(str(x) for x in value) if value else "-"
    return str(value)


def to_txt(vectors: list[dict]) -> str:
    lines = [
        "# bootnav protocol v1 test vectors (generated by generate.py; see README.md). One vector per line:",
        "#   crc    NAME HEX crc=XXXX",
        "#   frame  NAME HEX key=value ...              (decoded fields; lists comma-separated)",
        "#   stream NAME HEX frames=N types=.. offsets=.. seqs=.. events=kind@offset/count;...",
        "#   sdline NAME LINE ok=1 values=t_us,seq,ax,ay,az,gx,gy,gz,temp | ok=0 error=WORD",
        "# HEX is lower-case without separators; '-' stands for an empty list or n/a.",
    ]
    for v in vectors:
        exp = v["expect"]
        if v["kind"] == "crc":
            lines.append(f"crc {v['name']} {v['hex'] or '-'} crc={exp['crc']:04X}")
        elif v["kind"] == "frame":
            fields = " ".join(f"{k}={_txt_value(x)}" for k, x in exp.items())
            lines.append(f"frame {v['name']} {v['hex']} {fields}")
        elif v["kind"] == "stream":
            fr = exp["frames"]
            events = ";".join(f"{k}@{o}/{c}" for k, o, c in exp["events"]) or "-"
            lines.append(
                f"stream {v['name']} {v['hex']} frames={len(fr)} types={_txt_value([f['type'] for f in fr])} "
                f"offsets={_txt_value([f['offset'] for f in fr])} seqs={_txt_value([f['seq'] for f in fr])} "
                f"events={events}")
        elif v["kind"] == "sdline":
            tail = f"ok=1 values={_txt_value(exp['values'])}" if exp["ok"] else f"ok=0 error={exp['error']}"
            lines.append(f"sdline {v['name']} {v['line']} {tail}")
    return "\n".join(lines) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = ap.parse_args()
    vectors = build()
    self_check(vectors)
    args.out.mkdir(parents=True, exist_ok=True)
    doc = {"protocol_version": 1, "crc": "CRC-16/CCITT-FALSE poly 0x1021 init 0xFFFF, over bytes 2..n-3",
           "vectors": vectors}
    (args.out / "vectors.json").write_text(json.dumps(doc, indent=1) + "\n")
    (args.out / "vectors.txt").write_text(to_txt(vectors))
    print(f"{len(vectors)} vectors written to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
