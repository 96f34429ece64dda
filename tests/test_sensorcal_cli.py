"""``bootnav calibrate SESSION.h5 ...``: table, --out, store by device id, refusals as one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from bootnav.cli import main
from bootnav.core.sensorcal import SensorCalibration, find_calibration
from bootnav.postproc.sensorcal import synthetic as sy


@pytest.fixture(scope="module")
def session_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("calcli")
    truth = sy.draw_truth(101, with_temp=False)
    path = d / "cal.h5"
    sy.write_session(sy.make_session(truth, 102, name="cal.h5"), path)
    return path, truth


def test_calibrate_writes_out_and_store_and_prints_the_table(session_file, tmp_path, monkeypatch, capsys):
    path, truth = session_file
    monkeypatch.setenv("BOOTNAV_CALIBRATION_DIR", str(tmp_path / "store"))
    before = path.read_bytes()
    out = tmp_path / "cal.json"
    assert main(["calibrate", str(path), "--out", str(out), "--gravity", "9.80665"]) == 0
    cap = capsys.readouterr()
    assert "scale correction x" in cap.out and "misalignment C_xy" in cap.out and "residuals:" in cap.out
    assert "1σ" in cap.out
    cal = SensorCalibration.load(out)
    assert cal.device_id == "0x0000CA11" and cal.fit and "accelerometer_pose_residuals_mps2" in cal.fit
    # the file is the one in the store, and the store finds it by the recording's device id
    stored = find_calibration("0x0000CA11")
    assert stored is not None and json.loads(out.read_text()) == json.loads(open(stored.source).read())
    assert np.abs(np.diag(cal.gyro.matrix) - np.diag(truth.c_gyro)).max() < 5 * max(
        cal.gyro.sigma[f"C_{a}{a}"] for a in "xyz")
    assert path.read_bytes() == before  # the input is never modified
    # again: --out exists -> refused before any work, the store keeps both calibrations
    assert main(["calibrate", str(path), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0] and "--force" in err[0]
    assert main(["calibrate", str(path), "--quiet"]) == 0
    assert len(list((tmp_path / "store").glob("0x0000CA11_*.json"))) == 2


def test_no_store_needs_out_and_a_recording_without_device_id_needs_one(session_file, tmp_path, monkeypatch,
                                                                        capsys):
    monkeypatch.setenv("BOOTNAV_CALIBRATION_DIR", str(tmp_path / "store"))
    path, truth = session_file
    assert main(["calibrate", str(path), "--no-store"]) == 1
    assert "--no-store without --out" in capsys.readouterr().err
    anon = tmp_path / "anon.h5"
    sy.write_session(sy.make_session(truth, 103, device_id=None, name="anon.h5"), anon, counts=False)
    assert main(["calibrate", str(anon)]) == 1
    err = capsys.readouterr().err
    assert "no device_id" in err and "--device-id" in err and len(err.strip().splitlines()) == 1
    assert main(["calibrate", str(anon), "--device-id", "0xbeef", "--json", "--quiet"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["device_id"] == "0x0000BEEF" and doc["format"] == "bootnav-sensor-calibration"
    assert find_calibration(0xBEEF) is not None
    assert not (tmp_path / "store").joinpath("anon.h5").exists()


@pytest.mark.parametrize("args, words", [
    (["--device-id", "zz"], "--device-id"),
    (["--gravity", "3"], "--gravity"),
    (["--latitude", "100"], "--latitude"),
])
def test_bad_options_are_one_line_errors(session_file, tmp_path, monkeypatch, capsys, args, words):
    monkeypatch.setenv("BOOTNAV_CALIBRATION_DIR", str(tmp_path / "store"))
    assert main(["calibrate", str(session_file[0]), *args]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]


def test_missing_or_damaged_session_is_a_one_line_error(tmp_path, capsys):
    assert main(["calibrate", str(tmp_path / "missing.h5"), "--out", str(tmp_path / "c.json")]) == 1
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5 at all")
    assert main(["calibrate", str(bad), "--out", str(tmp_path / "c.json")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.h5" in err[0]
    assert not (tmp_path / "c.json").exists()


def test_help_lists_units_and_defaults():
    proc = subprocess.run([sys.executable, "-m", "bootnav", "calibrate", "--help"], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0
    text = " ".join(proc.stdout.split())
    for words in ("--out FILE.json", "--no-store", "--device-id", "--port", "--record FILE.h5", "m/s^2",
                  "default 45", "default 3", "default 0.05", "~/.local/share/bootnav/calibrations"):
        assert words in text, words
