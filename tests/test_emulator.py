"""The emulator: speaks protocol v1 on a real pty, answers 'H', quantises SI sources, reports honestly."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
import serial

from bootnav.logger import mpu6050
from bootnav.logger.emulator import load_source, synthetic_signal
from bootnav.logger.protocol import FrameParser, HeaderFrame
from bootnav.logger.recording import si_channel, write_recording
from tests.test_serial_record import bootnav, finish, wait_for

pytestmark = pytest.mark.timeout(60)


def test_emulator_streams_header_then_samples_at_the_rate_and_answers_H(tmp_path):
    link, report_path = tmp_path / "tty", tmp_path / "rep.json"
    rate = 200.0
    emu = bootnav("emulate", "--out-link", str(link), "--rate", str(rate), "--duration", "1.5",
                  "--accel-fs", "2", "--gyro-fs", "1", "--report", str(report_path), "--linger", "0.3", "--quiet")
    wait_for(link)
    port = serial.serial_for_url(str(link), baudrate=115200, timeout=0.05)
    port.write(b"H")  # the host connects: streaming starts
    parser, samples, headers = FrameParser(), [], []
    t0 = time.monotonic()
    asked_again = False
    while True:
        try:
            data = port.read(4096)
        except serial.SerialException:
            break  # the emulator closed the port after lingering
        r = parser.feed(data)
        samples.append(r.samples)
        headers += r.headers
        assert not r.events, r.events  # a clean link: no resync, no CRC error
        if not asked_again and time.monotonic() - t0 > 0.7:
            port.write(b"H")
            asked_again = True
    port.close()
    wall = time.monotonic() - t0
    finish(emu)
    report = json.loads(report_path.read_text())
    s = np.concatenate(samples)
    assert s.size == report["frames_sent"] == int(1.5 * rate)
    assert headers[0].offset == 0 and headers[0].accel_fs == 2 and headers[0].gyro_fs == 1
    assert isinstance(headers[0], HeaderFrame) and headers[0].rate_hz == rate  # DLPF 3, SMPLRT_DIV 4
    assert len(headers) >= 2 and report["headers_sent"] == len(headers)  # the 'H' was answered
    assert np.all(np.diff(s["seq"].astype(int)) == 1)
    assert np.all(np.diff(s["t_us"].astype(np.int64)) == 5000)
    # Streamed in real time, not as fast as possible.
    assert 1.4 < wall < 10.0


def test_synthetic_signal_is_deterministic_and_physically_plausible():
    a = synthetic_signal(3.0, 100.0, seed=1)
    b = synthetic_signal(3.0, 100.0, seed=1)
    assert np.array_equal(a.acc, b.acc) and np.array_equal(a.gyro, b.gyro)
    acc_g = a.acc / mpu6050.ACCEL_LSB_PER_G[3]
    stance = np.r_[0:30]  # first 0.3 s of each second is at rest
    np.testing.assert_allclose(np.linalg.norm(acc_g[stance], axis=1), 1.0, atol=0.02)
    assert np.abs(a.gyro / mpu6050.GYRO_LSB_PER_DPS[3]).max() < 2000  # within ±2000 °/s, no clipping


def test_si_source_is_quantised_with_its_declared_ranges(tmp_path):
    n = 50
    t = np.arange(n) / 100.0
    acc = np.zeros((n, 3))
    acc[:, 2] = 9.80665
    acc[10, 0] = 100.0  # beyond ±8 g: must clip to full scale (what the real sensor would do)
    gyro = np.full((n, 3), np.deg2rad(100.0))
    path = tmp_path / "si.h5"
    write_recording(path, t, acc, gyro, acc_channel=si_channel("acc"), gyro_channel=si_channel("gyro"),
                    meta={"accel_range_g": 8, "gyro_range_dps": 500, "rate_nominal_hz": 100})
    src = load_source(path)
    assert (src.accel_fs, src.gyro_fs, src.rate_hz) == (2, 1, 100.0)
    assert src.acc[0].tolist() == [0, 0, 4096]  # 1 g at 4096 LSB/g
    assert src.acc[10, 0] == 32767
    assert np.all(src.gyro == 6550)  # 100 °/s at 65.5 LSB/(°/s)


def test_a_recorded_board_id_is_sent_in_the_header_frames(tmp_path):
    """A recording of board 0x0000002A replays as board 0x0000002A (the calibration store is keyed by it)."""
    from bootnav.logger.emulator import Emulator, EmulatorSettings

    n = 20
    t = np.arange(n) / 100.0
    acc = np.tile([0.0, 0.0, 9.80665], (n, 1))
    gyro = np.zeros((n, 3))
    path = tmp_path / "board.h5"
    write_recording(path, t, acc, gyro, acc_channel=si_channel("acc"), gyro_channel=si_channel("gyro"),
                    meta={"accel_range_g": 16, "gyro_range_dps": 2000, "rate_nominal_hz": 100,
                          "device_id": "0x0000002A"})
    src = load_source(path)
    assert src.device_id == 0x2A
    emu = Emulator(EmulatorSettings(out_link=str(tmp_path / "tty"), source=str(path)), signal=src)
    assert emu.header(0, 0).device_id == 0x2A
    # No id recorded: the emulator's own default board id.
    path2 = tmp_path / "noid.h5"
    write_recording(path2, t, acc, gyro, acc_channel=si_channel("acc"), gyro_channel=si_channel("gyro"),
                    meta={"accel_range_g": 16, "gyro_range_dps": 2000, "rate_nominal_hz": 100})
    src2 = load_source(path2)
    assert src2.device_id is None
    emu2 = Emulator(EmulatorSettings(out_link=str(tmp_path / "tty2"), source=str(path2)), signal=src2)
    assert emu2.header(0, 0).device_id == EmulatorSettings.device_id
