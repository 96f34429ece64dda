"""Serial recorder end to end through a real pseudo-terminal: emulator process -> recorder process
-> HDF5 -> reopened in a fresh process. No mocks: the bytes go through the kernel's pty driver."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bootnav.logger import mpu6050
from bootnav.logger.recording import counts_channel, load, write_recording
from tests.conftest import REPO, reopen_in_fresh_process, sha

pytestmark = pytest.mark.timeout(60)


def bootnav(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "bootnav", *args], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def wait_for(path: Path, timeout: float = 15.0) -> None:
    end = time.monotonic() + timeout
    while not os.path.lexists(path):
        if time.monotonic() > end:
            raise AssertionError(f"{path} did not appear")
        time.sleep(0.02)


def wait_for_frames(path: Path, n: int, timeout: float = 20.0) -> None:
    """Poll the recording (SWMR read) until it holds ``n`` frames or ``timeout`` passes (the assertions that
    follow judge): a condition, not a fixed sleep, so a loaded machine only makes it slower."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if load(path).n >= n:
                return
        except Exception:  # noqa: BLE001 - not created yet / mid-creation
            pass
        time.sleep(0.05)


def finish(proc: subprocess.Popen, timeout: float = 30.0) -> str:
    _, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, f"{proc.args} exited {proc.returncode}:\n{err}"
    return err


def emulate_and_record(tmp_path: Path, emu_args: list[str], rec_args: list[str] = (), stop=signal.SIGTERM):
    """Run the emulator until it ends, recording all the while; then stop the recorder with ``stop``."""
    link, out, report = tmp_path / "tty", tmp_path / "rec.h5", tmp_path / "report.json"
    emu = bootnav("emulate", "--out-link", str(link), "--report", str(report), "--linger", "1.0", "--quiet", *emu_args)
    wait_for(link)
    rec = bootnav("record", "--port", str(link), "--out", str(out), *rec_args)
    finish(emu)
    sent = json.loads(report.read_text())
    wait_for_frames(out, len(sent["valid_seqs"]))  # the recorder's last read cycle and flush
    rec.send_signal(stop)
    err = finish(rec)
    assert_complete_in_fresh_process(out)
    return out, sent, err


def assert_complete_in_fresh_process(path: Path) -> dict:
    """A new interpreter opens the file and sees the same samples as this one."""
    fresh = reopen_in_fresh_process(path)
    here = load(path)
    assert fresh["n"] == here.n and fresh["acc_raw"] == sha(here.raw["acc"]) and fresh["gyro_raw"] == sha(here.raw["gyro"])
    return fresh


def _source(tmp_path: Path, n: int, rate: float) -> tuple[Path, np.ndarray, np.ndarray]:
    """An int16-count recording at ±8 g / ±1000 °/s with saturated stretches on two axes."""
    rng = np.random.default_rng(7)
    acc = rng.integers(-30000, 30000, size=(n, 3), dtype=np.int16)
    gyro = rng.integers(-30000, 30000, size=(n, 3), dtype=np.int16)
    acc[100:105, 0] = 32767  # 5 samples of ax at +full scale
    gyro[700:703, 2] = -32768  # 3 samples of gz at -full scale
    path = tmp_path / "source.h5"
    write_recording(path, np.arange(n) / rate, acc, gyro,
                    acc_channel=counts_channel("acc", mpu6050.accel_scale_mps2(2)),
                    gyro_channel=counts_channel("gyro", mpu6050.gyro_scale_radps(2)),
                    meta={"accel_range_g": 8, "gyro_range_dps": 1000, "rate_nominal_hz": rate})
    return path, acc, gyro


def test_pty_end_to_end_raw_counts_bit_exact_across_seq_and_clock_wraps(tmp_path):
    n, rate = 1500, 1000.0
    src, acc, gyro = _source(tmp_path, n, rate)
    t0 = 2**32 - 700_000  # the device clock wraps 0.7 s in; seq wraps after 536 frames
    out, report, err = emulate_and_record(tmp_path, ["--source", str(src), "--seq0", "65000", "--t0-us", str(t0)])
    assert report["frames_sent"] == n and report["valid_index"] == list(range(n))
    fresh = reopen_in_fresh_process(out)
    assert fresh["n"] == n
    assert fresh["acc_raw"] == sha(acc) and fresh["gyro_raw"] == sha(gyro)
    rec = load(out)
    assert rec.seq.tolist() == [(65000 + i) % 65536 for i in range(n)]
    # Device clock unwrapped: exactly 1 ms steps through the 2**32 µs wrap.
    np.testing.assert_array_equal(np.round(np.diff(rec.t_s) * 1e6), np.full(n - 1, 1000.0))
    assert rec.t_device[0] == t0 and rec.t_device[-1] == (t0 + (n - 1) * 1000) % 2**32
    kinds = rec.events["kind"].tolist()
    assert kinds.count(b"time_wrap") == 1 and b"gap" not in kinds and b"crc_error" not in kinds
    # Scale factors come from the header frame (±8 g, ±1000 °/s), not the ±16 g default.
    assert rec.meta["accel_range_g"] == 8 and rec.meta["gyro_range_dps"] == 1000
    assert rec.meta["config_source"] == "header frame" and rec.meta["device_id"] == "0x0000BEEF"
    np.testing.assert_allclose(rec.acc_mps2, acc * 9.80665 / 4096.0, rtol=0, atol=1e-12)
    # Saturation: bitmask per sample and one event per run with its length.
    assert np.flatnonzero(rec.saturated & 1).tolist() == list(range(100, 105))
    assert np.flatnonzero(rec.saturated & (1 << 5)).tolist() == [700, 701, 702]
    sat = rec.events_of("saturation")
    assert sorted(zip(sat["axis"].tolist(), sat["sample_index"].tolist(), sat["count"].tolist())) == [
        (0, 100, 5), (5, 700, 3)]
    assert rec.meta["stop_reason"] == "SIGTERM" and rec.meta["frames"] == n
    assert "Hz | frames" in err  # the live status line


def test_with_corruption_every_valid_frame_sent_is_in_the_file(tmp_path):
    out, report, _ = emulate_and_record(
        tmp_path, ["--duration", "2", "--rate", "1000", "--corrupt", "0.05", "--seed", "3"], stop=signal.SIGINT)
    assert report["frames_corrupted"] > 10 and report["frames_dropped"] > 10 and report["garbage_bursts"] > 10
    rec = load(out)
    assert rec.seq.tolist() == report["valid_seqs"]  # every intact frame, nothing else, in order
    # Every frame that was flipped or dropped is a missing seq, and counted as such.
    assert rec.meta["dropped"] == report["frames_dropped"] + report["frames_corrupted"]
    assert int(rec.events_of("gap")["count"].sum()) == rec.meta["dropped"]
    # A bit flip can hit the sync word (then it is a resync, not a CRC error); never more CRC errors
    # than damaged frames plus garbage bursts (a burst may contain a fake sync word).
    assert 0.7 * report["frames_corrupted"] <= rec.meta["crc_errors"] <= report["frames_corrupted"] + report["garbage_bursts"]
    assert rec.meta["resyncs"] >= report["garbage_bursts"]
    offsets = rec.events_of("crc_error")["byte_offset"]
    assert np.all(offsets >= 0) and np.all(np.diff(offsets) > 0)
    assert rec.meta["stop_reason"] == "interrupted (Ctrl-C)"


def test_kill_9_keeps_every_frame_up_to_the_last_flush(tmp_path):
    link, out, report_path = tmp_path / "tty", tmp_path / "rec.h5", tmp_path / "report.json"
    rate = 1000.0
    emu = bootnav("emulate", "--out-link", str(link), "--duration", "20", "--rate", str(rate),
                  "--report", str(report_path), "--quiet")
    wait_for(link)
    rec = bootnav("record", "--port", str(link), "--out", str(out), "--quiet")
    # Wait (from this process, through SWMR) until the recorder has really written 1 s of frames.
    end = time.monotonic() + 30
    while time.monotonic() < end:
        try:
            if load(out).n >= 1000:
                break
        except Exception:  # noqa: BLE001 - not created yet / mid-creation
            pass
        time.sleep(0.1)
    time.sleep(0.7)
    rec.kill()  # SIGKILL: no cleanup at all
    t_kill = time.time()
    rec.communicate(timeout=10)
    emu.send_signal(signal.SIGTERM)
    finish(emu)
    report = json.loads(report_path.read_text())
    fresh = reopen_in_fresh_process(out)  # opens although the writer never closed (SWMR flags set)
    r = load(out)
    n = r.n
    assert fresh["n"] == n > 0
    # Bit-exact prefix of what was sent, with no hole.
    assert r.seq.tolist() == report["valid_seqs"][:n]
    # At most the last second is lost (flush every 0.5 s): frames streamed before t_kill - 1 s are all there.
    streamed_until_1s_before = (t_kill - 1.0 - report["stream_start_unix"]) * rate
    assert n >= streamed_until_1s_before and n >= 1000
    assert "stop_reason" not in r.meta  # really killed: no final metadata


def test_disconnect_and_reconnect_one_file_with_the_gap_recorded(tmp_path):
    out, report, _ = emulate_and_record(
        tmp_path, ["--duration", "2.5", "--rate", "1000", "--disconnect-at", "0.8", "--disconnect-pause", "0.5"])
    assert report["disconnects"] == 1 and report["frames_unsent_disconnected"] > 400
    assert report["bytes_unread_at_close"] == 0
    rec = load(out)
    assert rec.seq.tolist() == report["valid_seqs"]
    kinds = rec.events["kind"].tolist()
    assert kinds.count(b"disconnect") >= 1 and kinds.count(b"reconnect") == 1
    assert kinds.index(b"disconnect") < kinds.index(b"reconnect")
    gaps = rec.events_of("gap")
    assert len(gaps) == 1 and gaps["count"][0] == report["frames_unsent_disconnected"]
    k = int(gaps["sample_index"][0])
    # The device clock bridges the gap exactly: (missing + 1) periods.
    assert round((rec.t_s[k] - rec.t_s[k - 1]) * 1e6) == (report["frames_unsent_disconnected"] + 1) * 1000
    assert np.all(np.diff(rec.t_s) > 0)


def test_device_that_reboots_on_reconnect_keeps_time_monotonic_in_one_file(tmp_path):
    """A Nano resets when the port is reopened: seq and t_us restart from 0 after the gap."""
    out, report, _ = emulate_and_record(
        tmp_path, ["--duration", "2.5", "--rate", "1000", "--disconnect-at", "0.8", "--disconnect-pause", "0.5",
                   "--restart-on-reconnect"])
    rec = load(out)
    assert rec.seq.tolist() == report["valid_seqs"]
    k = int(np.flatnonzero(np.diff(rec.seq.astype(int)) != 1)[0]) + 1  # first frame after the reboot
    assert rec.t_device[k] < rec.t_device[k - 1]
    assert np.all(np.diff(rec.t_s) > 0)  # bridged with the host clock
    assert 0.4 < rec.t_s[k] - rec.t_s[k - 1] < 10.0  # at least the 0.5 s the port was away
    assert len(rec.events_of("nonmonotonic_time")) == 1
    assert any(b"sequence went back" in d for d in rec.events_of("note")["detail"])
    # After the reboot, time runs on the device clock again: exact 1 ms steps.
    np.testing.assert_array_equal(np.round(np.diff(rec.t_s[k:]) * 1e6), 1000.0)


def test_missing_port_is_a_clear_error(tmp_path):
    proc = bootnav("record", "--port", str(tmp_path / "nope"), "--out", str(tmp_path / "x.h5"),
                   "--connect-timeout", "0.3", "--quiet")
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 1
    assert "cannot open serial port" in err and "nope" in err
    assert not (tmp_path / "x.h5").exists()
    # An existing recording is never overwritten by accident.
    (tmp_path / "old.h5").write_bytes(b"precious")
    proc = bootnav("record", "--port", str(tmp_path / "nope"), "--out", str(tmp_path / "old.h5"), "--quiet")
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 1 and "--force" in err and (tmp_path / "old.h5").read_bytes() == b"precious"


@pytest.mark.parametrize("late_header", [False, True])
def test_without_a_header_frame_the_recorder_assumes_16g_2000dps_and_says_so(tmp_path, late_header):
    """A device that never (or only late) sends a header: frames written straight onto a pty here."""
    import tty

    from bootnav.logger.protocol import HeaderFrame, pack_samples

    master, slave = os.openpty()
    tty.setraw(slave)
    link = tmp_path / "tty"
    os.symlink(os.ttyname(slave), link)
    out = tmp_path / "rec.h5"
    rec = bootnav("record", "--port", str(link), "--out", str(out), "--header-wait", "0.3", "--quiet")
    n = 400
    acc = np.tile(np.array([[0, 0, 2048]], np.int16), (n, 1))
    data = pack_samples(np.arange(n), np.arange(n) * 5000, acc, np.zeros((n, 3)), np.zeros(n))
    try:
        assert os.read(master, 1) == b"H"  # the recorder asks for the header as soon as it connects
        for k in range(0, len(data), 26 * 40):  # 200 Hz in blocks of 40 frames
            if late_header and k == 26 * 200:  # 1 s in, long after the 0.3 s wait: ±4 g, ±500 °/s
                os.write(master, HeaderFrame(200, 1_000_000, accel_fs=1, gyro_fs=1).pack())
            os.write(master, data[k:k + 26 * 40])
            time.sleep(0.2)  # pacing: 40 frames per 0.2 s is the device's 200 Hz
        wait_for_frames(out, n)
        rec.send_signal(signal.SIGTERM)
        finish(rec)
    finally:
        os.close(master)
        os.close(slave)
    assert_complete_in_fresh_process(out)
    r = load(out)
    assert r.n == n
    assert any(b"scale factors assumed" in d for d in r.events_of("note")["detail"])
    if not late_header:
        assert r.meta["accel_range_g"] == 16 and r.meta["gyro_range_dps"] == 2000
        assert "no header frame" in r.meta["config_source"]
        np.testing.assert_allclose(r.acc_mps2[:, 2], 9.80665)  # 2048 LSB = 1 g at ±16 g
    else:  # raw counts are kept, so the late header's factor applies to the whole file
        assert r.meta["accel_range_g"] == 4 and r.meta["gyro_range_dps"] == 500
        assert "corrected" in r.meta["config_source"]
        assert b"arrived after" in r.events_of("header")["detail"][0]
        np.testing.assert_allclose(r.acc_mps2[:, 2], 2048 * 9.80665 / 8192)


def test_saturation_runs_are_counted_whole_across_read_blocks():
    """Runs of full-scale samples split over arbitrary read blocks give one event each, exact length."""
    from bootnav.logger.serial_recorder import RecorderSettings, SerialRecorder

    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(1, 60))
        sat = rng.random((n, 6)) < 0.3
        rec = SerialRecorder(RecorderSettings(port="unused", out="unused"))
        cuts = sorted({0, n, *rng.integers(0, n, int(rng.integers(0, 5))).tolist()})
        for a, b in zip(cuts[:-1], cuts[1:]):
            rec._update_saturation_runs(sat[a:b], np.zeros(b - a))
            rec._n += b - a
        for axis in range(6):
            if rec._open_runs[axis] is not None:
                rec._close_run(axis, rec._n)
        got = sorted((e["axis"], e["sample_index"], e["count"]) for e in rec._pending_events)
        expected = []
        for axis in range(6):
            d = np.diff(np.r_[0, sat[:, axis].astype(int), 0])
            expected += [(axis, int(s), int(e - s)) for s, e in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1))]
        assert got == sorted(expected)
        assert rec.stats.saturated_samples == sat.sum(axis=0).tolist()


def test_any_pyserial_url_works_socket_transport(tmp_path):
    """`--port` goes through serial_for_url: a device on a TCP bridge (socket://) records the same way."""
    import socket
    import threading

    from bootnav.logger.protocol import HeaderFrame, pack_samples

    n = 500
    payload = HeaderFrame(0, 0, accel_fs=1, gyro_fs=2).pack() + pack_samples(
        np.arange(n), np.arange(n) * 5000, np.tile([[1, -2, 8192]], (n, 1)), np.tile([[3, 4, 5]], (n, 1)), np.zeros(n))
    server = socket.create_server(("127.0.0.1", 0))
    got = {}

    def serve():
        conn, _ = server.accept()
        got["cmd"] = conn.recv(1)
        for k in range(0, len(payload), 1300):  # 50 frames per 50 ms
            conn.sendall(payload[k:k + 1300])
            time.sleep(0.05)
        time.sleep(0.3)
        conn.close()
        server.close()
        got["done"] = True

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    out = tmp_path / "rec.h5"
    rec = bootnav("record", "--port", f"socket://127.0.0.1:{server.getsockname()[1]}", "--out", str(out), "--quiet")
    thread.join(timeout=30)
    rec.send_signal(signal.SIGTERM)
    finish(rec)
    assert_complete_in_fresh_process(out)
    r = load(out)
    assert got == {"cmd": b"H", "done": True}
    assert r.n == n and r.seq.tolist() == list(range(n))
    assert r.meta["accel_range_g"] == 4 and r.meta["gyro_range_dps"] == 1000
    np.testing.assert_allclose(r.acc_mps2[:, 2], 9.80665)  # 8192 LSB = 1 g at ±4 g
    assert b"disconnect" in r.events["kind"].tolist()  # the bridge went away


def test_replayed_timing_gaps_and_jitter_arrive_exactly(tmp_path):
    """--replay-timing sends the source's own seq and device clock (with its drops, jitter and a wrap)."""
    rng = np.random.default_rng(11)
    n_all, period = 500, 5000  # 200 Hz, 2.5 s
    keep = np.ones(n_all, bool)
    keep[[100, 101, 102, 340]] = False  # 4 frames lost on the source device: 2 gaps
    seq = (np.arange(n_all) + 65400)[keep] % 65536
    t_dev = ((2**32 - 1_000_000) + np.arange(n_all) * period + rng.integers(-40, 41, n_all))[keep] % 2**32
    n = int(keep.sum())
    acc = rng.integers(-2000, 2000, (n, 3)).astype(np.int16)
    src = tmp_path / "src.h5"
    write_recording(src, np.arange(n) / 200.0, acc, np.zeros((n, 3), np.int16),
                    acc_channel=counts_channel("acc", mpu6050.accel_scale_mps2(3)),
                    gyro_channel=counts_channel("gyro", mpu6050.gyro_scale_radps(3)),
                    seq=seq.astype(np.uint16), t_device=t_dev.astype(np.uint32),
                    meta={"accel_range_g": 16, "gyro_range_dps": 2000, "rate_nominal_hz": 200.0})
    out, report, _ = emulate_and_record(tmp_path, ["--source", str(src), "--replay-timing"])
    rec = load(out)
    assert rec.n == n and rec.seq.tolist() == seq.tolist() and rec.t_device.tolist() == t_dev.tolist()
    assert sha(rec.raw["acc"]) == sha(acc)
    gaps = rec.events_of("gap")
    assert gaps["count"].tolist() == [3, 1] and gaps["sample_index"].tolist() == [100, 337]
    assert len(rec.events_of("time_wrap")) == 1
    unwrapped = np.cumsum(np.r_[0, (np.diff(t_dev.astype(np.int64)) % 2**32)]) / 1e6
    np.testing.assert_allclose(rec.t_s, unwrapped, rtol=0, atol=1e-9)
