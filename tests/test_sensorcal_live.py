"""``bootnav calibrate --port P``: guided live mode end to end through ``bootnav emulate`` on a real pty.

The emulator streams an exact synthetic session (``postproc.sensorcal.synthetic``). It has no speed option,
so its process runs with ``time.monotonic`` scaled by SPEED: the frames leave SPEED times faster, stamped
with the device's own time (``t_us`` counts frames, not the wall clock), so the session the calibrator sees
is the real one, only delivered sooner. The guide works in sensor time, so it must count every pose anyway.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from bootnav.core.sensorcal import SensorCalibration, find_calibration
from bootnav.logger.recording import load
from bootnav.postproc.sensorcal import synthetic as sy
from tests.conftest import REPO
from tests.test_serial_record import wait_for

pytestmark = pytest.mark.timeout(120)
SPEED = 8.0
FAST_EMULATOR = ("import sys, time\n"
                 "_m = time.monotonic\n_t0 = _m()\n"
                 f"time.monotonic = lambda: _t0 + (_m() - _t0) * {SPEED}\n"
                 "from bootnav.cli import main\nsys.exit(main(sys.argv[1:]))\n")


def test_guided_live_calibration_through_the_emulator(tmp_path, monkeypatch):
    truth = sy.draw_truth(301, with_temp=False)
    source = tmp_path / "session.h5"
    session = sy.make_session(truth, 302, sy.PROCEDURE_MOTIONS, rate_hz=200.0, name="session.h5")
    sy.write_session(session, source)
    link, record, out = tmp_path / "tty", tmp_path / "live.h5", tmp_path / "cal.json"
    monkeypatch.setenv("BOOTNAV_CALIBRATION_DIR", str(tmp_path / "store"))
    env = dict(os.environ)
    emu = subprocess.Popen([sys.executable, "-c", FAST_EMULATOR, "emulate", "--source", str(source),
                            "--out-link", str(link), "--quiet", "--host-timeout", "400", "--write-timeout", "200",
                            "--linger", "8"], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(link, timeout=20.0)
        cal = subprocess.run([sys.executable, "-m", "bootnav", "calibrate", "--port", str(link), "--record",
                              str(record), "--out", str(out), "--hold", "2", "--goal-scale", "0.2",
                              "--goal-misalignment", "0.2", "--gravity", "9.80665"],
                             cwd=REPO, env=env, capture_output=True, text=True, timeout=100)
    finally:
        emu.kill()
        emu.communicate(timeout=10)
    assert cal.returncode == 0, cal.stderr
    lines = cal.stdout.splitlines()
    # it guided: the first pose, a hold countdown or completion, the next pose by name, the parameters
    assert any(line.startswith("pose 1") for line in lines)
    assert any("done. now roll it halfway onto its left side" in line for line in lines)
    assert any("undetermined" in line or "short of the goals" in line for line in lines)
    assert "every parameter is determined to the goals: done" in cal.stdout
    assert "every parameter determined to the goals" in cal.stderr
    # it stopped at the goals, before the person's 20 poses were through
    got = SensorCalibration.load(out)
    n_poses = len(got.fit["accelerometer_pose_residuals_mps2"])
    assert 9 <= n_poses < 20, cal.stdout
    # the session went through the recorder into the file, and the calibration into the store by device id
    rec = load(record)
    # the board id the session was recorded with travels through the emulator's header frames into the store
    board = load(source, with_truth=False).meta["device_id"]
    assert rec.meta["device_id"] == board and got.device_id == board
    assert find_calibration(board) is not None
    # and it is the right calibration: the truth within 5σ (quantised to the boot's int16 counts on the way)
    sd = np.array([[got.gyro.sigma[f"C_{a}{b}"] for b in "xyz"] for a in "xyz"])
    assert np.all(np.abs(got.gyro.matrix - truth.c_gyro) <= 5 * sd)
    sd = np.array([[got.acc.sigma.get(f"C_{a}{b}", 0.0) for b in "xyz"] for a in "xyz"])
    assert np.all(np.abs(got.acc.matrix - truth.c_acc) <= 5 * sd + 1e-12)
    # the table of the fit was printed too
    assert "scale correction x" in cal.stdout


def test_live_mode_refuses_to_overwrite_a_recording(tmp_path):
    record = tmp_path / "live.h5"
    record.write_bytes(b"precious")
    proc = subprocess.run([sys.executable, "-m", "bootnav", "calibrate", "--port", str(tmp_path / "none"),
                           "--record", str(record), "--out", str(tmp_path / "c.json")], cwd=REPO,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and "never overwritten" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and record.read_bytes() == b"precious"
