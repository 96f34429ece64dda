"""bootnav.core.sensorcal: the calibration model, file format, store and temperature warning."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bootnav.core import sensorcal
from bootnav.core.sensorcal import SensorCalibration, TriadCalibration
from bootnav.errors import InputError


def _cal(device_id="0x0000BEEF", created="2026-12-01T10:00:00Z", with_temp=True):
    rng = np.random.default_rng(3)
    c_acc = np.eye(3) + np.triu(rng.normal(0, 0.02, (3, 3)))
    c_gyro = np.eye(3) + rng.normal(0, 0.02, (3, 3))
    acc = TriadCalibration(c_acc, [0.3, -0.5, 0.4], [0.002, -0.001, 0.003] if with_temp else np.zeros(3),
                           {"bias_x": 1e-3, "scale_x": 2e-4}, 0.004)
    gyro = TriadCalibration(c_gyro, [0.1, -0.2, 0.05], [1e-4, 2e-4, -3e-4] if with_temp else np.zeros(3),
                            {"bias_x": 1e-5}, 0.002)
    return SensorCalibration(device_id=device_id, acc=acc, gyro=gyro, temp_ref_degc=24.5,
                             temp_range_degc=(20.0, 41.0) if with_temp else None, created_utc=created,
                             sessions=[{"file": "cal.h5", "sha256": "ab" * 32, "duration_s": 95.0,
                                        "temp_range_degc": [20.0, 41.0]}])


def test_json_round_trip_is_exact(tmp_path):
    cal = _cal()
    p = cal.save(tmp_path / "c.json")
    back = SensorCalibration.load(p)
    for a, b in ((cal.acc, back.acc), (cal.gyro, back.gyro)):
        assert np.array_equal(a.matrix, b.matrix) and np.array_equal(a.bias, b.bias)
        assert np.array_equal(a.bias_temp_coeff, b.bias_temp_coeff)
        assert a.sigma == b.sigma and a.residual_rms == b.residual_rms
    assert back.device_id == "0x0000BEEF" and back.temp_range_degc == (20.0, 41.0)
    assert back.temp_ref_degc == 24.5 and back.created_utc == cal.created_utc and back.sessions == cal.sessions
    assert back.source == str(p)
    doc = json.loads(p.read_text())
    assert doc["format"] == "bootnav-sensor-calibration" and doc["version"] == 1
    assert set(doc["accelerometer"]) >= {"matrix", "bias_mps2", "bias_temp_coeff_mps2_per_degc", "sigma",
                                         "residual_rms_mps2"}
    assert set(doc["gyroscope"]) >= {"matrix", "bias_radps", "bias_temp_coeff_radps_per_degc", "sigma",
                                     "residual_rms_rad"}


def test_save_never_overwrites_without_force(tmp_path):
    p = tmp_path / "c.json"
    p.write_text("precious")
    with pytest.raises(InputError, match="exists"):
        _cal().save(p)
    assert p.read_text() == "precious"
    _cal().save(p, force=True)
    assert SensorCalibration.load(p).device_id == "0x0000BEEF"


def test_apply_matches_hand_computation_and_leaves_inputs():
    cal = _cal()
    rng = np.random.default_rng(0)
    acc, gyro = rng.normal(0, 9, (50, 3)), rng.normal(0, 2, (50, 3))
    temp = rng.uniform(15, 45, 50)
    acc0, gyro0 = acc.copy(), gyro.copy()
    a, g = cal.apply(acc, gyro, temp)
    assert np.array_equal(acc, acc0) and np.array_equal(gyro, gyro0)
    for i in (0, 17, 49):
        dt = temp[i] - 24.5
        want_a = cal.acc.matrix @ (acc[i] - cal.acc.bias - cal.acc.bias_temp_coeff * dt)
        want_g = cal.gyro.matrix @ (gyro[i] - cal.gyro.bias - cal.gyro.bias_temp_coeff * dt)
        np.testing.assert_allclose(a[i], want_a, rtol=0, atol=1e-12)
        np.testing.assert_allclose(g[i], want_g, rtol=0, atol=1e-12)
    # without a temperature the bias at T_ref applies
    a2, _ = cal.apply(acc, gyro)
    np.testing.assert_allclose(a2[3], cal.acc.matrix @ (acc[3] - cal.acc.bias), atol=1e-12)


def test_inverse_of_the_sensor_model_recovers_truth():
    """y = S x + b + k (T − T_ref) corrected by C = S⁻¹ gives back x (the model of the module docstring)."""
    rng = np.random.default_rng(1)
    s = np.eye(3) + rng.normal(0, 0.03, (3, 3))
    b, k, tref = np.array([0.2, -0.1, 0.3]), np.array([0.01, 0.0, -0.02]), 30.0
    x = rng.normal(0, 5, (20, 3))
    temp = rng.uniform(10, 50, 20)
    y = x @ s.T + b + (temp - tref)[:, None] * k
    tri = TriadCalibration(np.linalg.inv(s), b, k)
    cal = SensorCalibration(acc=tri, gyro=tri, temp_ref_degc=tref)
    a, g = cal.apply(y, y, temp)
    np.testing.assert_allclose(a, x, atol=1e-12)
    np.testing.assert_allclose(g, x, atol=1e-12)


def test_identity_is_bit_identical_and_none_triad_passes_through():
    cal = SensorCalibration.identity()
    assert cal.is_identity() and not _cal().is_identity()
    rng = np.random.default_rng(2)
    acc = rng.normal(0, 9, (30, 3))
    acc[0] = [-0.0, 0.0, -1e-300]
    gyro = rng.normal(0, 1, (30, 3))
    a, g = cal.apply(acc, gyro, np.full(30, 80.0))
    assert a.tobytes() == acc.tobytes() and g.tobytes() == gyro.tobytes()
    assert a is not acc and g is not gyro
    only_acc = SensorCalibration(acc=_cal().acc, gyro=None)
    _, g2 = only_acc.apply(acc, gyro)
    assert g2.tobytes() == gyro.tobytes()


def test_old_accelerometer_file_loads_as_accel_only(tmp_path):
    from bootnav.postproc.calibration import apply_accel_calibration

    m = [[1.01, 0.002, 0.0], [0.0, 0.99, -0.003], [0.0, 0.0, 1.005]]
    p = tmp_path / "acc.json"
    p.write_text(json.dumps({"bias_mps2": [0.1, -0.2, 0.3], "matrix": m}))
    cal = SensorCalibration.load(p)
    assert cal.gyro is None and cal.device_id is None
    acc = np.random.default_rng(4).normal(0, 9, (10, 3))
    a, _ = cal.apply(acc, np.zeros((10, 3)), np.full(10, 60.0))
    np.testing.assert_allclose(a, apply_accel_calibration(acc, p), atol=1e-12)


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d["accelerometer"].update(matrix=[[1, 0], [0, 1]]), "accelerometer.matrix"),
    (lambda d: d["gyroscope"].update(bias_radps=[0, "x", 0]), "gyroscope.bias_radps"),
    (lambda d: d["gyroscope"].update(matrix=[[0, 0, 0]] * 3), "singular"),
    (lambda d: d.update(format="other"), "'format'"),
    (lambda d: d.update(version=7), "version 7"),
    (lambda d: d.update(device_id="beef-cafe"), "'device_id'"),
    (lambda d: d["temperature"].update(range_degc=[50, 10]), "temperature.range_degc"),
    (lambda d: d["accelerometer"].pop("bias_mps2"), "accelerometer.bias_mps2"),
    (lambda d: d.update(accelerometer=None, gyroscope=None), "neither"),
])
def test_corrupt_files_give_one_line_errors_naming_file_and_field(tmp_path, mutate, field):
    doc = _cal().to_dict()
    mutate(doc)
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError) as ei:
        SensorCalibration.load(p)
    msg = str(ei.value)
    assert "\n" not in msg and str(p) in msg and field in msg


@pytest.mark.parametrize("content, words", [("{not json", "invalid JSON at line 1"), ("[1, 2]", "JSON object"),
                                            (b"\xff\xfe\x00", "not a text")])
def test_unreadable_files(tmp_path, content, words):
    p = tmp_path / "bad.json"
    p.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(InputError, match=words):
        SensorCalibration.load(p)
    with pytest.raises(InputError, match="not found"):
        SensorCalibration.load(tmp_path / "missing.json")


def test_store_keeps_every_calibration_and_finds_the_newest(tmp_path, monkeypatch):
    monkeypatch.setenv("BOOTNAV_CALIBRATION_DIR", str(tmp_path / "store"))
    assert sensorcal.store_dir() == tmp_path / "store"
    assert sensorcal.find_calibration("0x0000BEEF") is None
    p1 = sensorcal.store_calibration(_cal(created="2026-12-01T10:00:00Z"))
    p2 = sensorcal.store_calibration(_cal(created="2026-12-02T09:00:00Z", with_temp=False))
    p3 = sensorcal.store_calibration(_cal(created="2026-12-02T09:00:00Z", with_temp=False))  # same second
    assert len({p1, p2, p3}) == 3 and all(p.exists() for p in (p1, p2, p3))
    sensorcal.store_calibration(_cal(device_id="0x00000001", created="2027-01-01T00:00:00Z"))
    found = sensorcal.find_calibration(0xBEEF)
    assert found.source == str(p3) and found.temp_range_degc is None
    assert sensorcal.find_calibration("0xbeef").source == str(p3)
    assert sensorcal.find_calibration(None) is None and sensorcal.find_calibration("0x12345678") is None
    with pytest.raises(InputError, match="device id"):
        sensorcal.store_calibration(_cal(device_id=None))


def test_store_dir_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.delenv("BOOTNAV_CALIBRATION_DIR", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    assert sensorcal.store_dir() == tmp_path / "bootnav" / "calibrations"


def test_temperature_warning():
    cal = _cal()  # range 20..41 °C
    assert sensorcal.temperature_warning(cal, np.array([22.0, 30.0, np.nan])) is None
    w = sensorcal.temperature_warning(cal, np.array([25.0, 63.0]))
    assert w and "63.0" in w and "20.0..41.0" in w and "\n" not in w
    assert sensorcal.temperature_warning(None, [90.0]) is None
    flat = _cal(with_temp=False)  # no temperature fit: reference 24.5 °C
    assert sensorcal.temperature_warning(flat, [26.0]) is None
    assert "no temperature fit" in sensorcal.temperature_warning(flat, [70.0])


def test_provenance_is_small_and_json():
    p = _cal().with_source("/x/c.json").provenance()
    json.dumps(p, allow_nan=False)
    assert p["file"] == "/x/c.json" and p["device_id"] == "0x0000BEEF" and p["temp_range_degc"] == [20.0, 41.0]
    assert p["accelerometer_residual_rms_mps2"] == 0.004 and p["identity"] is False


def test_normalize_device_id():
    assert sensorcal.normalize_device_id(0xBEEF) == "0x0000BEEF"
    assert sensorcal.normalize_device_id("0x0000beef") == "0x0000BEEF"
    assert sensorcal.normalize_device_id("") is None
    with pytest.raises(ValueError):
        sensorcal.normalize_device_id(2**40)
