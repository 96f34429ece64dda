"""SD-card text log (PROTOCOL.md §2) round trip: known counts in, the same counts out, every defect an event.

The log is written here with the protocol's CRC (``bootnav.logger.crc``), with a bad-CRC line, a dropped line,
a sample at full scale, a uint32 µs clock wrap, a seq wrap and a truncated last line (power loss).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.crc import crc16_ccitt_false
from bootnav.logger.importers import format_sd_header, format_sd_line, import_file, read_any
from bootnav.logger.recording import load
from tests.conftest import REPO, reopen_in_fresh_process, sha

N = 600
PERIOD_US = 5000  # accel_fs=3 gyro_fs=3 dlpf=3 smplrt_div=4 -> 1000/(1+4) = 200 Hz
BAD_CRC_K = 100  # sample index whose line gets a corrupted body
DROPPED_K = 250  # sample index never written (power glitch)
SAT_K = 300


def make_samples(seed: int = 4):
    rng = np.random.default_rng(seed)
    t0 = 2**32 - 400 * PERIOD_US + 1234  # the clock wraps at sample 400
    t_us = (t0 + PERIOD_US * np.arange(N, dtype=np.int64)) % 2**32
    seq = (65500 + np.arange(N)) % 65536  # seq wraps after sample 36
    acc = rng.integers(-800, 800, (N, 3))
    acc[:, 2] += 2048  # +1 g on z at +-16 g (2048 LSB/g)
    gyro = rng.integers(-300, 300, (N, 3))
    temp = rng.integers(-2000, 2000, N)
    acc[SAT_K, 0] = 32767
    gyro[SAT_K, 2] = -32768
    return t_us, seq, acc, gyro, temp


def write_log(path, truncated_tail=True):
    t_us, seq, acc, gyro, temp = make_samples()
    lines = [format_sd_header(accel_fs=3, gyro_fs=3, dlpf=3, smplrt_div=4, fw="0.1.0", device_id=0xBEEF)]
    line_of = {}
    for k in range(N):
        if k == DROPPED_K:
            continue
        line = format_sd_line(int(t_us[k]), int(seq[k]), *map(int, acc[k]), *map(int, gyro[k]), int(temp[k]))
        if k == BAD_CRC_K:  # one digit flipped after the CRC was computed
            body, crc = line.split("*")
            line = body.replace(",", ",9", 1) + "*" + crc
        lines.append(line)
        line_of[k] = len(lines)  # 1-based line number
    text = "\n".join(lines) + "\n"
    if truncated_tail:
        tail = format_sd_line(int(t_us[-1]) + PERIOD_US, int(seq[-1]) + 1, 1, 2, 3, 4, 5, 6, 7)
        text += tail[: len(tail) // 2]  # power lost mid-write: no newline
    path.write_text(text)
    return line_of, len(lines) + (1 if truncated_tail else 0)


def test_format_sd_line_crc_matches_protocol():
    line = format_sd_line(123, 7, 1, -2, 3, -4, 5, -6, 7)
    body, crc = line.split("*")
    assert body == "123,7,1,-2,3,-4,5,-6,7"
    assert int(crc, 16) == crc16_ccitt_false(body.encode()) and crc == crc.upper() and len(crc) == 4


def test_sd_log_round_trip_bit_exact_with_events(tmp_path):
    src = tmp_path / "boot.txt"
    line_of, last_line = write_log(src)
    out = import_file(src, tmp_path / "boot.h5")
    rec = load(out)
    t_us, seq, acc, gyro, temp = make_samples()
    kept = np.array([k for k in range(N) if k not in (BAD_CRC_K, DROPPED_K)])
    assert rec.n == kept.size
    assert rec.raw["acc"].dtype == np.int16
    assert np.array_equal(rec.raw["acc"], acc[kept].astype(np.int16))
    assert np.array_equal(rec.raw["gyro"], gyro[kept].astype(np.int16))
    assert np.array_equal(rec.t_device, t_us[kept].astype(np.uint32))
    assert np.array_equal(rec.seq, seq[kept].astype(np.uint16))
    assert rec.temp_degc == pytest.approx(temp[kept] / 340 + 36.53)
    # scale factors from the header codes: 2048 LSB/g, 16.4 LSB/(deg/s)
    assert rec.acc_mps2[0] == pytest.approx(acc[0] / 2048 * 9.80665)
    assert rec.gyro_radps[0] == pytest.approx(np.radians(gyro[0] / 16.4))
    assert rec.meta["rate_nominal_hz"] == 200 and rec.meta["accel_range_g"] == 16
    # time: unwrapped across the uint32 wrap, exactly 5 ms steps except where lines are missing
    expected_t = (kept - kept[0]) * PERIOD_US * 1e-6
    assert rec.t_s == pytest.approx(expected_t, abs=1e-9)
    wraps = rec.events_of("time_wrap")
    assert len(wraps) == 1 and wraps["line"][0] == line_of[400]
    # the corrupted line: a crc_error at its line number and byte offset
    crc = rec.events_of("crc_error")
    assert list(crc["line"]) == [line_of[BAD_CRC_K] if BAD_CRC_K in line_of else -1]
    text = src.read_bytes()
    off = int(crc["byte_offset"][0])
    assert text[off:].split(b"\n", 1)[0].endswith(format_sd_line(
        int(t_us[BAD_CRC_K]), int(seq[BAD_CRC_K]), *map(int, acc[BAD_CRC_K]), *map(int, gyro[BAD_CRC_K]),
        int(temp[BAD_CRC_K])).split("*")[1].encode())
    # truncated last line: skipped_line with its number
    skipped = rec.events_of("skipped_line")
    assert list(skipped["line"]) == [last_line] and b"truncated" in skipped["detail"][0]
    # sequence gaps: one sample missing at the bad CRC line and at the dropped line (seq wrap is no gap)
    gaps = rec.events_of("gap")
    assert sorted(gaps["line"]) == [line_of[BAD_CRC_K + 1], line_of[DROPPED_K + 1]]
    assert list(gaps["count"]) == [1, 1]
    # saturation: the two full-scale values, flagged on their axis
    i_sat = int(np.flatnonzero(kept == SAT_K)[0])
    assert rec.saturated[i_sat] == (1 << 0) | (1 << 5)
    assert int(np.count_nonzero(rec.saturated)) == 1
    assert len(rec.events_of("header")) == 1
    fresh = reopen_in_fresh_process(out)
    assert fresh["n"] == kept.size and fresh["acc_raw"] == sha(acc[kept].astype(np.int16))


def test_sd_log_cli_reports_bad_lines(tmp_path):
    src = tmp_path / "boot.txt"
    line_of, last_line = write_log(src)
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "import", str(src), "--out", str(tmp_path / "b.h5")],
                          capture_output=True, text=True, cwd=REPO, timeout=60)
    if proc.returncode != 0 and "No module named bootnav.cli.__main__" in proc.stderr:
        pytest.skip("bootnav.cli not runnable with -m")
    assert proc.returncode == 0, proc.stderr
    assert "bootnav_sd" in proc.stdout
    assert f"lines {line_of[BAD_CRC_K]}, {last_line}" in proc.stdout


def test_sd_log_wrong_header_range_is_an_error(tmp_path):
    """Counts logged at +-2 g (16384 LSB/g) under a header claiming +-16 g: gravity reads 8 g."""
    src = tmp_path / "wrong.txt"
    rng = np.random.default_rng(1)
    lines = [format_sd_header(accel_fs=3, gyro_fs=3)]
    for k in range(400):
        a = rng.integers(-50, 50, 3) + [0, 0, 16384]
        lines.append(format_sd_line(k * 5000, k, *map(int, a), 1, 2, 3, 0))
    src.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match="--acc-range 2"):
        read_any(src)
    r = read_any(src, acc_range_g=2)
    assert r.acc_mps2[:, 2].mean() == pytest.approx(9.80665, rel=0.01)


def test_firmware_protocol_sd_vectors(tmp_path):
    """The shared SD-line test vectors (firmware-protocol/test-vectors/vectors.json), one file with all of them."""
    import json

    vectors = json.loads((REPO / "firmware-protocol" / "test-vectors" / "vectors.json").read_text())["vectors"]
    header = next(v for v in vectors if v["kind"] == "sdheader")
    sd = [v for v in vectors if v["kind"] == "sdline"]
    assert len(sd) >= 5
    lines = [header["line"]] + [v["line"] for v in sd]
    (tmp_path / "v.txt").write_text("\n".join(lines) + "\n")
    r = read_any(tmp_path / "v.txt", check_units=False)
    assert r.meta["accel_range_g"] == 16 and r.meta["dlpf_cfg"] == header["expect"]["dlpf"]
    problems = {e["line"]: e for e in r.events if e["kind"] in ("crc_error", "skipped_line")}
    values = np.column_stack([r.optional["t_device"], r.optional["seq"], r.acc, r.gyro, r.optional["temp"]])
    got = [list(map(int, row)) for row in values]
    for k, v in enumerate(sd):
        line_no = k + 2
        if v["expect"]["ok"]:
            assert v["expect"]["values"] in got, v["name"]
            assert line_no not in problems
        else:
            assert v["expect"]["error"].lower() in problems[line_no]["detail"].lower(), v["name"]


def test_simulated_walk_sd_log_imports_bit_exact(tmp_path):
    """The simulator's SD-card writer (an independent implementation of §2) -> importer: counts identical."""
    from bootnav import simulator as sim
    res = sim.simulate("paper-straight", seed=2)
    path = sim.write_sd_txt(res, tmp_path / "walk.txt")
    rec = load(import_file(path, tmp_path / "walk.h5"))
    assert rec.n == res.n
    assert np.array_equal(rec.raw["acc"], res.acc) and np.array_equal(rec.raw["gyro"], res.gyro)
    assert np.array_equal(rec.t_device, res.t_device) and np.array_equal(rec.seq, res.seq)
    assert len(rec.events_of("crc_error")) == 0
