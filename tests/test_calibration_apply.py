"""The sensor calibration is applied by every command (issue 23, point 3): which one applies
(``calibration.resolve_calibration``: --calibration FILE > store match by device id > none; --no-calibration),
that applying the exact inverse of a distortion gives back the undistorted path, that an identity calibration
changes no `bootnav eval` figure, and what summary.json, results.h5, `bootnav info` and the live view say."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bootnav
from bootnav.core.sensorcal import SensorCalibration, TriadCalibration, store_calibration
from bootnav.errors import InputError
from bootnav.logger.recording import Recording, make_events
from bootnav.postproc.calibration import CalibrationSettings, resolve_calibration

DEV = "0x0000BEEF"


@pytest.fixture
def store(tmp_path, monkeypatch):
    d = tmp_path / "store"
    monkeypatch.setenv("BOOTNAV_CALIBRATION_DIR", str(d))
    return d


def _cal(device_id=DEV, scale=1.01, bias=0.05, temp_range=None) -> SensorCalibration:
    m = np.eye(3) * scale
    return SensorCalibration(device_id=device_id, acc=TriadCalibration(m, np.full(3, bias)),
                             gyro=TriadCalibration(m, np.full(3, bias / 10)), temp_ref_degc=25.0,
                             temp_range_degc=temp_range, created_utc="2026-12-01T10:00:00Z")


@pytest.fixture(scope="module")
def walk():
    """A short ideal walk (exact signals): t, specific force, rate, truth positions."""
    from bootnav.simulator import simulate

    res = simulate("paper-straight", seed=3, profile="ideal")
    return res.t_s, np.asarray(res.acc_mps2, float), np.asarray(res.gyro_radps, float)


def _recording(t, acc, gyro, device_id=DEV, temp=None) -> Recording:
    return Recording(path=None, t_s=t, acc_mps2=acc, gyro_radps=gyro, saturated=np.zeros(len(t), np.uint8),
                     events=make_events([]), meta={"device_id": device_id} if device_id else {}, attrs={},
                     temp_degc=temp)


# ------------------------------------------------------------------------------------------------ precedence

def test_precedence_file_over_store_over_none(tmp_path, store):
    stored = store_calibration(_cal(scale=1.02))
    explicit = _cal(scale=1.03).save(tmp_path / "explicit.json")
    auto = CalibrationSettings()
    r = resolve_calibration(auto, DEV)
    assert r.provenance["how"] == "store" and r.provenance["file"] == str(stored)
    assert r.calibration.acc.matrix[0, 0] == 1.02
    r = resolve_calibration(CalibrationSettings(sensor_calibration=str(explicit)), DEV)
    assert r.provenance["how"] == "file" and r.calibration.acc.matrix[0, 0] == 1.03 and not r.warnings
    r = resolve_calibration(CalibrationSettings(sensor_calibration="none"), DEV)
    assert r.calibration is None and "disabled" in r.provenance["reason"]
    r = resolve_calibration(auto, "0x00000001")  # another device: nothing stored for it
    assert r.calibration is None and "no calibration of device 0x00000001" in r.provenance["reason"]
    r = resolve_calibration(auto, None)
    assert r.calibration is None and "no device id" in r.provenance["reason"]
    given = _cal(scale=1.04)
    r = resolve_calibration(CalibrationSettings(sensor_calibration=str(explicit)), DEV, given)
    assert r.provenance["how"] == "given" and r.calibration is given
    assert resolve_calibration(auto, DEV, False).calibration is None


def test_a_file_of_another_device_warns_and_two_files_are_refused(tmp_path, store):
    other = _cal(device_id="0x00000002").save(tmp_path / "other.json")
    r = resolve_calibration(CalibrationSettings(sensor_calibration=str(other)), DEV)
    assert r.calibration is not None and any("0x00000002" in w and DEV in w for w in r.warnings)
    with pytest.raises(InputError, match="both"):
        resolve_calibration(CalibrationSettings(sensor_calibration=str(other),
                                                accel_calibration_file=str(tmp_path / "acc.json")), DEV)
    with pytest.raises(InputError, match="not found"):
        resolve_calibration(CalibrationSettings(sensor_calibration=str(tmp_path / "missing.json")), DEV)


# ------------------------------------------------------------------------------------------------ applying

def test_exact_inverse_of_a_distortion_gives_back_the_undistorted_path(walk, store):
    """y = S x + b + k (T - T_ref): processed with C = S^-1, b, k the path equals the undistorted one (to
    rounding: C (S x) differs from x by ~1e-16 relative, far below any threshold the pipeline decides on)."""
    t, acc, gyro = walk
    rng = np.random.default_rng(7)
    s_a = np.eye(3) + np.diag([0.02, -0.015, 0.01]) + rng.normal(0, 0.005, (3, 3)) * (1 - np.eye(3))
    s_g = np.eye(3) + np.diag([-0.01, 0.02, 0.015]) + rng.normal(0, 0.005, (3, 3)) * (1 - np.eye(3))
    b_a, b_g = np.array([0.3, -0.4, 0.5]), np.array([0.1, -0.2, 0.15])
    k_a, k_g = np.array([0.01, 0.0, -0.02]), np.array([0.001, 0.002, 0.0])
    temp = 25.0 + 10.0 * t / t[-1]  # warming by 10 degC over the walk
    dtemp = (temp - 25.0)[:, None]
    acc_d = acc @ s_a.T + b_a + k_a * dtemp
    gyro_d = gyro @ s_g.T + b_g + k_g * dtemp
    cal = SensorCalibration(device_id=DEV, acc=TriadCalibration(np.linalg.inv(s_a), b_a, k_a),
                            gyro=TriadCalibration(np.linalg.inv(s_g), b_g, k_g), temp_ref_degc=25.0,
                            temp_range_degc=(20.0, 40.0))
    ref = bootnav.process(_recording(t, acc, gyro), calibration=False)
    out = bootnav.process(_recording(t, acc_d, gyro_d, temp=temp), calibration=cal)
    assert out.summary["calibration"]["status"] == "applied" and out.summary["calibration"]["how"] == "given"
    assert out.summary["calibration"]["temperature_applied"] is True
    np.testing.assert_array_equal(out.stance, ref.stance)
    np.testing.assert_allclose(out.pos_n_m, ref.pos_n_m, rtol=0, atol=1e-6)
    # the distortion itself does change the path (so the comparison above can fail)
    raw = bootnav.process(_recording(t, acc_d, gyro_d, temp=temp), calibration=False)
    assert np.abs(raw.pos_n_m[-1] - ref.pos_n_m[-1]).max() > 0.05
    # the same calibration from the store, matched by the recording's device id
    store_calibration(cal)
    auto = bootnav.process(_recording(t, acc_d, gyro_d, temp=temp))
    assert auto.summary["calibration"]["how"] == "store"
    np.testing.assert_allclose(auto.pos_n_m, ref.pos_n_m, rtol=0, atol=1e-6)


def test_temperature_outside_the_calibrated_range_warns(walk, store):
    t, acc, gyro = walk
    cal = _cal(scale=1.0, bias=0.0, temp_range=(20.0, 30.0))
    out = bootnav.process(_recording(t, acc, gyro, temp=np.full(len(t), 45.0)), calibration=cal)
    assert any("45.0" in w and "20.0..30.0" in w for w in out.warnings)
    assert out.summary["calibration"]["recording_temp_range_degc"] == [45.0, 45.0]
    quiet = bootnav.process(_recording(t, acc, gyro, temp=np.full(len(t), 25.0)), calibration=cal)
    assert not any("calibrated range" in w for w in quiet.warnings)


def test_cli_summary_results_h5_and_info_say_which_calibration_ran(tmp_path, store, walk):
    import h5py

    from bootnav.logger.cli_info import calibration_line
    from bootnav.simulator import simulate, write_h5

    rec = tmp_path / "walk.h5"
    write_h5(simulate("paper-straight", seed=3), rec)
    with h5py.File(rec, "r") as f:
        dev = f["meta"].attrs["device_id"]
        dev = dev.decode() if isinstance(dev, bytes) else str(dev)
    assert calibration_line(dev).startswith("none stored for device")
    assert "no device id" in calibration_line(None)
    cal_file = _cal(device_id=dev, scale=1.0, bias=0.0).save(tmp_path / "cal.json")
    from bootnav.cli import main

    assert main(["process", str(rec), "--out", str(tmp_path / "a"), "--no-plots", "-q",
                 "--calibration", str(cal_file)]) == 0
    s = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert s["calibration"]["status"] == "applied" and s["calibration"]["file"] == str(cal_file)
    assert s["calibration"]["device_id"] == dev and s["calibration"]["created_utc"] == "2026-12-01T10:00:00Z"
    assert s["settings"]["calibration"]["sensor_calibration"] == str(cal_file)
    with h5py.File(tmp_path / "a" / "results.h5", "r") as f:
        assert json.loads(f["results/default"].attrs["calibration"])["file"] == str(cal_file)
    assert main(["process", str(rec), "--out", str(tmp_path / "b"), "--no-plots", "--no-hdf5", "-q",
                 "--no-calibration"]) == 0
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert s["calibration"] == {"status": "none", "reason": "disabled (--no-calibration)"}
    stored = store_calibration(_cal(device_id=dev))
    line = calibration_line(dev)
    assert str(stored) in line and "applies" in line


def test_live_view_calibrates_its_chunks_from_the_store(walk, store):
    from bootnav.postproc.live.boot import BootView, LiveSettings
    from bootnav.postproc.live.sources import Chunk
    from bootnav.postproc.settings import ProcessSettings

    t, acc, gyro = walk
    cal = _cal()
    store_calibration(cal)
    view = BootView("left", ProcessSettings(), LiveSettings())
    c = view._calibrated(Chunk(t[:10], acc[:10], gyro[:10], np.zeros(10, np.uint8), device_id=DEV))
    assert view.calibration.provenance["how"] == "store"
    want_a, want_g = cal.apply(acc[:10], gyro[:10])
    np.testing.assert_array_equal(c.acc_mps2, want_a)
    np.testing.assert_array_equal(c.gyro_radps, want_g)


def test_identity_calibration_changes_no_eval_figure(datasets, tmp_path):
    """`bootnav eval` with an identity calibration file gives the same metric dict, figure for figure (a single
    foot trial and a two-boot trial; wall-clock timings aside)."""
    from bootnav.postproc.evaluate.runner import evaluate_all
    from bootnav.postproc.settings import ProcessSettings

    ident = SensorCalibration.identity().save(tmp_path / "identity.json")
    manifest = json.loads((datasets / "manifest.json").read_text())
    ids = ("pyshoe_vicon/2017-11-27-11-13-41", "gaitmap_example/stair_down")
    trials = [t for t in manifest["trials"] if t["id"] in ids]
    if len(trials) != len(ids):
        pytest.skip("the small trials of this test are not in the dataset tree")
    with_cal = ProcessSettings()
    with_cal.calibration.sensor_calibration = str(ident)
    a = evaluate_all(datasets, trials, jobs=1)
    b = evaluate_all(datasets, trials, jobs=1, foot_settings=with_cal)

    def figures(results):
        return {r.id: {k: v for k, v in r.metrics.items() if not k.endswith("seconds") and "runtime" not in k}
                for r in results}

    assert all(r.status == "ok" for r in a + b)
    assert figures(a) == figures(b)
    assert len(figures(a)[ids[0]]) > 3
