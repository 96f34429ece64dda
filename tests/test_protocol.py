"""Protocol v1: CRC, frame pack/unpack, the streaming parser (fuzzed), timebase, shared test vectors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bootnav.core.timebase import StreamClock
from bootnav.logger.crc import crc16_ccitt_false, crc16_ccitt_false_rows
from bootnav.logger.protocol import (
    FRAME_SIZE,
    FrameParser,
    HeaderFrame,
    ProtocolError,
    SampleFrame,
    StatusFrame,
    format_sd_line,
    pack_samples,
    parse_sd_line,
    parse_stream,
    unpack_frame,
)

REPO = Path(__file__).resolve().parents[1]
VECTORS = REPO / "firmware-protocol" / "test-vectors"

i16 = st.integers(-32768, 32767)
sample_frames = st.builds(
    SampleFrame, st.integers(0, 65535), st.integers(0, 2**32 - 1), st.tuples(i16, i16, i16),
    st.tuples(i16, i16, i16), i16,
)
header_frames = st.builds(
    HeaderFrame, st.integers(0, 65535), st.integers(0, 2**32 - 1), st.integers(0, 3), st.integers(0, 3),
    st.integers(0, 7), st.integers(0, 255), st.tuples(*[st.integers(0, 255)] * 3), st.integers(0, 255),
    st.integers(0, 2**32 - 1),
)
status_frames = st.builds(
    StatusFrame, st.integers(0, 65535), st.integers(0, 2**32 - 1), st.integers(0, 255), st.integers(0, 255),
    st.integers(0, 65535),
)
any_frame = st.one_of(sample_frames, header_frames, status_frames)


def test_crc_check_value_and_bitwise_reference():
    assert crc16_ccitt_false(b"123456789") == 0x29B1
    assert crc16_ccitt_false(b"") == 0xFFFF

    def bitwise(data):  # textbook MSB-first shift register, independent of the table
        crc = 0xFFFF
        for byte in data:
            crc ^= byte << 8
            for _ in range(8):
                crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
        return crc

    rng = np.random.default_rng(1)
    rows = rng.integers(0, 256, size=(50, 22), dtype=np.uint8)
    batch = crc16_ccitt_false_rows(rows)
    for row, c in zip(rows, batch):
        assert bitwise(row.tobytes()) == crc16_ccitt_false(row.tobytes()) == int(c)


@settings(derandomize=True)
@given(any_frame)
def test_pack_unpack_round_trip(frame):
    data = frame.pack()
    assert len(data) == FRAME_SIZE[frame.type_code]
    assert unpack_frame(data) == frame


@settings(derandomize=True)
@given(any_frame, st.data())
def test_any_single_bit_flip_is_rejected(frame, data):
    raw = bytearray(frame.pack())
    bit = data.draw(st.integers(0, len(raw) * 8 - 1))
    raw[bit // 8] ^= 1 << (bit % 8)
    with pytest.raises(ProtocolError):
        unpack_frame(bytes(raw))
    result = parse_stream(bytes(raw))
    assert result.samples.size == 0 and not result.headers and not result.statuses


def test_vectorised_pack_matches_dataclass_pack():
    rng = np.random.default_rng(2)
    n = 64
    acc, gyro = rng.integers(-32768, 32768, (n, 3)), rng.integers(-32768, 32768, (n, 3))
    temp = rng.integers(-32768, 32768, n)
    seq, t = np.arange(65500, 65500 + n), 2**32 - 10_000 + 1000 * np.arange(n)
    packed = pack_samples(seq, t, acc, gyro, temp)
    expected = b"".join(
        SampleFrame(int(s) & 0xFFFF, int(tt) & 0xFFFFFFFF, tuple(map(int, a)), tuple(map(int, g)), int(tp)).pack()
        for s, tt, a, g, tp in zip(seq, t, acc, gyro, temp))
    assert packed == expected


def _interleave(frames, garbage):
    """Stream = garbage[0] frame[0] garbage[1] frame[1] ...; returns bytes and frame offsets."""
    out, offsets = bytearray(), []
    for frame, junk in zip(frames, garbage):
        out += junk
        offsets.append(len(out))
        out += frame.pack()
    return bytes(out), offsets


def _parse_in_pieces(data, cuts):
    parser = FrameParser()
    samples, others, events = [], [], []
    bounds = [0, *sorted(c % (len(data) + 1) for c in cuts), len(data)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        r = parser.feed(data[a:b])
        samples.append(r.samples)
        others += r.headers + r.statuses
        events += r.events
    events += parser.finish()
    return np.concatenate(samples), sorted(others, key=lambda f: f.offset), events, parser


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(
    frames=st.lists(any_frame, min_size=0, max_size=12),
    garbage=st.lists(st.binary(max_size=40), min_size=12, max_size=12),
    cuts=st.lists(st.integers(0, 10_000), max_size=8),
)
def test_parser_recovers_every_frame_around_garbage_at_any_split(frames, garbage, cuts):
    data, offsets = _interleave(frames, garbage)
    samples, others, events, parser = _parse_in_pieces(data, cuts)
    got = sorted(
        [(int(s["offset"]), SampleFrame(int(s["seq"]), int(s["t_us"]), tuple(map(int, s["acc"])),
                                        tuple(map(int, s["gyro"])), int(s["temp"]))) for s in samples]
        + [(f.offset, f) for f in others], key=lambda x: x[0])
    # Every frame we put in comes out, at its offset. (Random garbage could in principle contain a
    # complete frame with a valid CRC; then it is a real frame and may legitimately appear too.)
    got_at = dict(got)
    for off, frame in zip(offsets, frames):
        assert got_at.get(off) == frame, f"frame at offset {off} lost"
    # Nothing returned has a bad CRC, and every output frame re-packs to the exact input bytes.
    for off, frame in got:
        assert data[off: off + FRAME_SIZE[frame.type_code]] == frame.pack()
    # The split points do not change the result.
    samples1, others1, events1, _ = _parse_in_pieces(data, [])
    assert samples1.tobytes() == samples.tobytes() and others1 == others
    assert [(e.kind, e.byte_offset, e.count) for e in events1] == [(e.kind, e.byte_offset, e.count) for e in events]
    # Byte accounting: frame bytes + skipped bytes == all bytes.
    frame_bytes = sum(FRAME_SIZE[f.type_code] for _, f in got)
    assert frame_bytes + parser.stats.skipped_bytes == len(data)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.binary(max_size=600), st.lists(st.integers(0, 600), max_size=6))
def test_parser_never_crashes_and_never_returns_bad_crc_on_random_bytes(data, cuts):
    samples, others, _, _ = _parse_in_pieces(data, cuts)
    for s in samples:
        off = int(s["offset"])
        unpack_frame(data[off: off + 26])  # raises if the CRC is bad
    for f in others:
        unpack_frame(data[f.offset: f.offset + FRAME_SIZE[f.type_code]])


def test_bad_crc_frame_is_reported_with_its_offset_and_neighbours_survive():
    frames = [SampleFrame(i, 1000 * i, (i, 0, 2048), (0, 0, 0), 0) for i in range(3)]
    data = bytearray(b"".join(f.pack() for f in frames))
    data[26 + 12] ^= 0x10  # corrupt the middle frame's payload
    r = parse_stream(bytes(data), base_offset=1000)
    assert r.samples["seq"].tolist() == [0, 2]
    crc = [e for e in r.events if e.kind == "crc_error"]
    assert [(e.byte_offset, e.frame_type) for e in crc] == [(1026, 1)]
    resync = [e for e in r.events if e.kind == "resync"]
    assert [(e.byte_offset, e.count) for e in resync] == [(1026, 26)]


def test_sd_line_round_trip_and_errors():
    frame = SampleFrame(65535, 4294967295, (-32768, 0, 32767), (1, -1, 2), -3920)
    line = format_sd_line(frame)
    assert parse_sd_line(line + "\n") == frame
    with pytest.raises(ProtocolError, match="CRC"):
        parse_sd_line(line.replace("65535", "65534"))
    with pytest.raises(ProtocolError, match="truncated"):
        parse_sd_line(line[:-7])


def test_stream_clock_unwraps_t_us_and_seq_and_counts_gaps():
    tb = StreamClock(period_us=1000)
    seq = np.array([65533, 65534, 65535, 0, 3, 4])  # 1, 2 missing across the u16 wrap
    t = (np.array([-3, -2, -1, 0, 3, 4]) * 1000 + 2**32) % 2**32
    t_cont = tb.update(seq[:2], t[:2]).tolist() + tb.update(seq[2:], t[2:]).tolist()
    assert np.all(np.diff(t_cont) == np.array([1, 1, 1, 3, 1]) * 1000)
    kinds = [(e.kind, e.index, e.count) for e in tb.events]
    assert ("time_wrap", 3, 0) in kinds and ("gap", 4, 2) in kinds
    assert tb.dropped == 2


def test_stream_clock_resolves_gaps_longer_than_a_seq_wrap_with_the_device_clock():
    tb = StreamClock(period_us=1000)
    # 70_000 frames missing at 1 kHz: seq alone would say 70_000 - 65_536 = 4_464.
    tb.update([10, 11], [0, 1000])
    tb.update([(12 + 70_000) % 65536], [(12 + 70_000) * 1000])
    assert tb.dropped == 70_000


def _load_vectors():
    return json.loads((VECTORS / "vectors.json").read_text())


def test_test_vectors_are_reproduced_by_the_generator(tmp_path):
    subprocess.run([sys.executable, str(VECTORS / "generate.py"), "--out", str(tmp_path)], check=True, cwd=REPO)
    for name in ("vectors.json", "vectors.txt"):
        assert (tmp_path / name).read_bytes() == (VECTORS / name).read_bytes(), f"{name} is stale"


def test_parser_matches_every_stream_vector():
    vectors = [v for v in _load_vectors()["vectors"] if v["kind"] == "stream"]
    assert len(vectors) >= 10
    for v in vectors:
        r = parse_stream(bytes.fromhex(v["hex"]))
        exp = v["expect"]
        got_frames = [{"type": f.type_code, "offset": f.offset, "seq": f.seq, "t_us": f.t_us} for f in r.frames()]
        assert got_frames == [{k: f[k] for k in ("type", "offset", "seq", "t_us")} for f in exp["frames"]], v["name"]
        assert [[e.kind, e.byte_offset, e.count] for e in r.events] == exp["events"], v["name"]
        for frame, f in zip(r.frames(), exp["frames"]):
            if f["type"] == 1:
                assert [list(frame.acc), list(frame.gyro), frame.temp] == [f["acc"], f["gyro"], f["temp"]]


def test_encoders_reproduce_every_frame_vector_from_its_fields():
    classes = {1: SampleFrame, 2: HeaderFrame, 3: StatusFrame}
    vectors = [v for v in _load_vectors()["vectors"] if v["kind"] == "frame"]
    assert {v["expect"]["type"] for v in vectors} == {1, 2, 3}
    for v in vectors:
        fields = {k: tuple(x) if isinstance(x, list) else x for k, x in v["expect"].items() if k != "type"}
        frame = classes[v["expect"]["type"]](**fields)
        assert frame.pack().hex() == v["hex"], v["name"]
        assert unpack_frame(bytes.fromhex(v["hex"])) == frame


def test_crc_vectors():
    for v in (v for v in _load_vectors()["vectors"] if v["kind"] == "crc"):
        assert crc16_ccitt_false(bytes.fromhex(v["hex"])) == v["expect"]["crc"], v["name"]


def test_sd_line_vectors():
    for v in (v for v in _load_vectors()["vectors"] if v["kind"] == "sdline"):
        if v["expect"]["ok"]:
            f = parse_sd_line(v["line"])
            assert [f.t_us, f.seq, *f.acc, *f.gyro, f.temp] == v["expect"]["values"], v["name"]
            assert format_sd_line(f) == v["line"]
        else:
            with pytest.raises(ProtocolError, match=v["expect"]["error"]):
                parse_sd_line(v["line"])


def _frame_hiding_a_status_frame() -> tuple[bytes, bytes]:
    """(A, B): a valid sample frame A whose payload and CRC (its last 16 bytes) are themselves a valid status
    frame B. A's CRC covers P + Q (P = A[2:12], ending in B's sync word), B's covers Q alone; both are the
    same two bytes when the CRC register after P is back at its initial 0xFFFF (CRC-16/CCITT-FALSE has no
    final XOR), so P's clock bytes are searched for that (1 in 65536)."""
    rng = np.random.default_rng(14)
    t = rng.integers(0, 2**32, 400_000, dtype=np.uint64).astype("<u4").view(np.uint8).reshape(-1, 4)
    p = np.zeros((t.shape[0], 10), np.uint8)
    p[:, 0:4] = [0x01, 0x01, 0x07, 0x00]  # sample frame, version 1, seq 7
    p[:, 4:8] = t
    p[:, 8:10] = [0xA5, 0x5A]
    hit = np.flatnonzero(crc16_ccitt_false_rows(p) == 0xFFFF)
    assert hit.size, "no clock value found: widen the search"
    q = bytes([0x03, 0x01, 0x09, 0x00, 1, 2, 3, 4, 1, 0, 0, 0])  # status frame, seq 9, t_us, code 1 ...
    body = bytes(p[hit[0]]) + q
    a = b"\xA5\x5A" + body + crc16_ccitt_false(body).to_bytes(2, "little")
    b = a[10:]
    assert unpack_frame(a).seq == 7 and unpack_frame(b) == StatusFrame(9, 0x04030201, 1, 0, 0)
    return a, b


@pytest.mark.parametrize("chunk", [1, 7, 1000])
def test_a_frame_hidden_inside_an_accepted_frame_is_not_a_second_frame(chunk):
    """Greedy chain over CRC-valid candidates: the earliest wins, a candidate inside it is payload, and the
    next frame starting exactly at its end is kept."""
    a, _ = _frame_hiding_a_status_frame()
    c = SampleFrame(8, 5000, (1, 2, 3), (4, 5, 6), 7).pack()
    stream = b"\x00\x11" + a + c
    parser = FrameParser()
    results = [parser.feed(stream[i:i + chunk]) for i in range(0, len(stream), chunk)]
    seqs = [int(s) for r in results for s in r.samples["seq"]]
    assert seqs == [7, 8]
    assert [s for r in results for s in r.statuses] == []
    events = [(e.kind, e.byte_offset) for r in results for e in r.events] + parser.finish()
    assert events == [("resync", 0)]  # only the two leading garbage bytes
