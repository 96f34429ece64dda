"""Byte offsets stay exact after invalid UTF-8; UTF-16 files are decoded, never called binary."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.logger.importers import format_sd_header, format_sd_line, read_any

N = 400


def _sd_lines(n: int = N) -> list[bytes]:
    """A 200 Hz SD-card log at rest (+1 g on z at +-16 g), one bytes object per line, no newline."""
    rng = np.random.default_rng(7)
    lines = [format_sd_header(accel_fs=3, gyro_fs=3, dlpf=3, smplrt_div=4).encode()]
    for k in range(n):
        ax, ay = rng.integers(-20, 20, 2)
        lines.append(format_sd_line(5000 * k, k, int(ax), int(ay), 2048, 1, -2, 3, 100).encode())
    return lines


def _corrupt_crc(line: bytes) -> bytes:
    body, crc = line.split(b"*")
    return body + b"*" + (b"0000" if crc != b"0000" else b"FFFF")


def _offsets(lines: list[bytes], start: int = 0) -> list[int]:
    """Byte offset of each line start, counted on the bytes written (independent of the importer)."""
    return [start + sum(len(x) + 1 for x in lines[:i]) for i in range(len(lines))]


def test_sd_log_offsets_stay_exact_after_invalid_utf8(tmp_path):
    lines = _sd_lines()
    lines.insert(1, "# note: boot strapped on, 20 °C".encode())  # valid UTF-8 comment (2-byte character)
    lines[10] = lines[10][:8] + b"\xff\xfe\x80" + lines[10][8:]  # a data line with invalid UTF-8 bytes
    lines[20] = b"# \xe9t\xe9"  # a latin-1 comment: invalid UTF-8, still a comment
    for i in (30, 200, 390):
        lines[i] = _corrupt_crc(lines[i])
    bom = b"\xef\xbb\xbf"
    path = tmp_path / "LOG.TXT"
    path.write_bytes(bom + b"\n".join(lines) + b"\n")
    offsets = _offsets(lines, start=len(bom))
    r = read_any(path)
    bad = {e["line"]: e for e in r.events if e["kind"] == "crc_error"}
    assert sorted(bad) == [11, 31, 201, 391]
    for line_no, e in bad.items():
        assert e["byte_offset"] == offsets[line_no - 1], line_no
    assert f"byte 0xFF at byte offset {offsets[10] + 8} is not ASCII" in bad[11]["detail"]
    header = [e for e in r.events if e["kind"] == "header"]
    assert [(e["line"], e["byte_offset"]) for e in header] == [(1, 0)]
    assert r.n == N - 1 - 3 - 1  # 400 samples - 1 (line 11) - 3 CRC errors - 1 (line 21 became a comment)


@pytest.mark.parametrize("encoding, bom", [("utf-16-le", b"\xff\xfe"), ("utf-16-be", b"\xfe\xff"),
                                           ("utf-16-le", b"")])
def test_utf16_sd_log_is_decoded_with_utf16_offsets(tmp_path, encoding, bom):
    lines = _sd_lines()
    lines[50] = _corrupt_crc(lines[50])
    text = "\n".join(ln.decode() for ln in lines) + "\n"
    path = tmp_path / "LOG.TXT"
    path.write_bytes(bom + text.encode(encoding))
    r = read_any(path)
    assert r.n == N - 1 and r.meta["source_encoding"] == encoding
    (e,) = [e for e in r.events if e["kind"] == "crc_error"]
    assert e["line"] == 51 and e["byte_offset"] == len(bom) + 2 * _offsets(lines)[50]
    assert any("UTF-16" in m for m in r.messages)


@pytest.mark.parametrize("encoding, bom", [("utf-16-le", b"\xff\xfe"), ("utf-16-be", b""),
                                           ("utf-8", b"")])
def test_utf16_csv_reads_like_the_utf8_file(tmp_path, encoding, bom):
    rows = ["time (s),acc x (m/s²),acc y (m/s²),acc z (m/s²),gyro x (°/s),gyro y (°/s),gyro z (°/s)"]
    rows += [f"{i / 100:.2f},0.01,-0.02,9.81,0.5,0,-0.25" for i in range(N)]
    path = tmp_path / "walk.csv"
    path.write_bytes(bom + ("\r\n".join(rows) + "\r\n").encode(encoding))
    r = read_any(path)
    assert r.n == N and r.t_s[-1] == pytest.approx((N - 1) / 100)
    assert np.allclose(r.acc_mps2[0], [0.01, -0.02, 9.81]) and np.allclose(r.gyro_radps[0], np.radians([0.5, 0, -0.25]))
    assert r.meta.get("source_encoding", "utf-8") == encoding
