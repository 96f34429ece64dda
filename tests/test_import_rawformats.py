"""Every file under datasets/raw-formats/ imports without options; checked against facts from its README.

Reference values are computed independently of the importer (plain Python parsing of the file) or
quoted from the folder's README.md; never taken from the importer's own output.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.importers import import_file, load_aux, read_any
from bootnav.logger.recording import load
from tests.conftest import reopen_in_fresh_process, sha

G = 9.80665


def _rows(path, delim=","):
    """Independent parse: non-empty lines split by ``delim`` (trailing delimiter dropped)."""
    out = []
    for line in path.read_text().splitlines():
        line = line.strip().rstrip(delim)
        if line:
            out.append([float(v) for v in line.split(delim)])
    return np.array(out)


@pytest.fixture
def raw(datasets):
    return datasets / "raw-formats"


def _sat_count(raw_values):
    return int(np.sum((raw_values >= 32767) | (raw_values <= -32768)))


def test_iez_conf0000_counts_ranges_and_saturation(raw, tmp_path):
    src = raw / "iez_mpu6050_csv" / "conf-0000-coleta01-02-06-21-5ds_01.csv"
    ref = _rows(src)
    assert src.read_bytes().count(b"\r\n") == 2 * len(ref) - 1  # README: CRLF + empty line per record (last: CRLF only)
    out = import_file(src, tmp_path / "iez.h5")
    rec = load(out)
    assert rec.meta["importer_profile"] == "iez_mpu6050_csv"
    assert rec.n == len(ref)
    assert rec.raw["acc"].dtype == np.int16 and np.array_equal(rec.raw["acc"], ref[:, 1:4].astype(np.int16))
    assert np.array_equal(rec.raw["gyro"], ref[:, 4:7].astype(np.int16))
    # conf-0000: +-2 g (16384 LSB/g), +-250 deg/s (131 LSB/(deg/s))
    assert rec.meta["accel_range_g"] == 2 and rec.meta["gyro_range_dps"] == 250
    assert rec.acc_mps2[0, 0] == pytest.approx(ref[0, 1] / 16384 * G)
    assert rec.gyro_radps[0, 0] == pytest.approx(math.radians(ref[0, 4] / 131))
    assert np.median(np.diff(rec.t_s)) == pytest.approx(0.01)  # 100 Hz, 10 ms steps
    assert 27 <= rec.t_s[-1] <= 32
    # README: saturates on both sensors while walking; flags must equal an independent count
    acc_sat = sum(int(np.sum((rec.saturated >> b) & 1)) for b in range(3))
    gyro_sat = sum(int(np.sum((rec.saturated >> b) & 1)) for b in range(3, 6))
    assert acc_sat == _sat_count(ref[:, 1:4]) > 0
    assert gyro_sat == _sat_count(ref[:, 4:7]) > 0
    sat_ev = rec.events_of("saturation")
    assert sat_ev["count"].sum() == acc_sat + gyro_sat
    aux = load_aux(out)
    assert np.array_equal(aux["ax2"], ref[:, 7])  # sensor 2 kept
    fresh = reopen_in_fresh_process(out)
    assert fresh["n"] == len(ref) and fresh["acc_raw"] == sha(rec.raw["acc"])


def test_iez_conf3232_sensor2_option(raw):
    src = raw / "iez_mpu6050_csv" / "conf-3232-coleta12-29-06-21-11ds_03.csv"
    ref = _rows(src)
    r1 = read_any(src)
    assert (r1.meta["accel_range_g"], r1.meta["gyro_range_dps"]) == (16, 1000)  # A1=3 G1=2
    r2 = read_any(src, sensor=2)
    assert (r2.meta["accel_range_g"], r2.meta["gyro_range_dps"]) == (16, 1000)  # A2=3 G2=2
    assert np.array_equal(r2.acc, ref[:, 7:10].astype(np.int16))
    assert np.array_equal(r2.gyro, ref[:, 10:13].astype(np.int16))
    assert r1.saturated.sum() == 0  # +-16 g / +-1000 deg/s do not clip a walk


def test_ttruty_rtc_seconds_spread_and_saturation(raw, tmp_path):
    src = raw / "ttruty_sd_log" / "Steps21.txt"
    ref = _rows(src)
    assert len(ref) == 1664  # README
    rec = load(import_file(src, tmp_path / "tt.h5"))
    assert rec.n == 1664
    assert np.all(np.diff(rec.t_s) > 0), "repeated 1-s stamps must be spread, not duplicated"
    # every sample stays inside the RTC second it was logged in
    t_abs = rec.t_s + rec.meta["t0_source_s"]
    assert np.array_equal(np.floor(t_abs + 1e-6), ref[:, 0])
    assert 60 <= rec.t_s[-1] <= 62  # "62 s in total"
    assert rec.meta["start_utc"].startswith("2019-07-29")
    notes = [e["detail"].decode() for e in rec.events_of("note")]
    assert any("1-s clock" in d for d in notes)
    gyro_sat = sum(int(np.sum((rec.saturated >> b) & 1)) for b in range(3, 6))
    acc_sat = sum(int(np.sum((rec.saturated >> b) & 1)) for b in range(3))
    assert gyro_sat == 31  # README: 31 gyro values at +-32767/-32768
    # README says 14 accelerometer values; the file itself holds this many at +-32767/-32768:
    assert acc_sat == _sat_count(ref[:, 1:4])
    assert np.array_equal(load_aux(tmp_path / "tt.h5")["fsr"], ref[:, 7])


@pytest.mark.parametrize("name,rows,seconds", [("line", 2436, 18.8), ("circle", 4902, 37.8), ("rec", 6767, 52.3)])
def test_sstk123_trailing_semicolon_and_clipping(raw, name, rows, seconds):
    src = raw / "sstk123_mpu9250_serial" / f"{name}_3_0228.txt"
    ref = _rows(src, ";")
    r = read_any(src)
    assert r.profile == "sstk123_mpu9250_serial"
    assert r.n == rows == len(ref)
    assert r.t_s[-1] + ref[0, 0] == pytest.approx(ref[-1, 0]) and r.t_s[-1] == pytest.approx(seconds, abs=0.1)
    assert 1 / np.median(np.diff(r.t_s)) == pytest.approx(129.7, abs=1.5)
    np.testing.assert_array_equal(r.acc, ref[:, 1:4])
    # clipped at +-2 g = 19.62 m/s^2 and +-250 deg/s = 4.363 rad/s: flagged within 0.5 %
    acc_lim, gyro_lim = 2 * G * 0.995, math.radians(250) * 0.995
    assert int(np.sum((r.saturated & 0b111) != 0)) == int(np.sum(np.any(np.abs(ref[:, 1:4]) >= acc_lim, axis=1))) > 0
    assert int(np.sum((r.saturated & 0b111000) != 0)) == int(np.sum(np.any(np.abs(ref[:, 4:7]) >= gyro_lim, axis=1)))


@pytest.mark.parametrize("folder,rows,t_end", [("test1-84step", 6100, 60.96), ("test2-100steps", 6585, 65.81)])
def test_purestreams_linear_acceleration_is_flagged(raw, tmp_path, folder, rows, t_end):
    src = raw / "purestreams_phyphox" / folder / "Raw Data.csv"
    rec = load(import_file(src, tmp_path / "p.h5"))
    assert rec.n == rows
    assert rec.t_s[-1] + rec.meta["t0_source_s"] == pytest.approx(t_end, abs=0.01)
    assert rec.meta["t0_source_s"] < 0  # first value slightly negative
    # meta/time.csv: START "2026-04-08 HH:MM:SS.fff UTC+08:00" (experiment time 0); meta/device.csv: iPhone18,2
    import datetime as dt

    start_text = (src.parent / "meta" / "time.csv").read_text().splitlines()[1].split(",")[3].strip('"')
    local = dt.datetime.strptime(start_text[:23], "%Y-%m-%d %H:%M:%S.%f").replace(tzinfo=dt.timezone(dt.timedelta(hours=8)))
    first_sample = local + dt.timedelta(seconds=rec.meta["t0_source_s"])
    assert abs(dt.datetime.fromisoformat(rec.meta["start_utc"]) - first_sample).total_seconds() < 0.002
    assert "iPhone18,2" in rec.meta["device"]
    assert rec.meta["acc_quantity"] == "linear_acceleration"
    assert rec.meta["gyro_present"] == 0 and np.all(np.isnan(rec.gyro_radps))
    assert any(b"NOT specific force" in e["detail"] for e in rec.events_of("note"))
    from bootnav.logger.importers.checks import quietest_second

    assert quietest_second(rec.acc_mps2, 100)[0] < 1.0  # gravity removed: ~0 at rest, not 9.81
    # as specific force (the generic phyphox profile) it is refused, saying why
    with pytest.raises(InputError, match="LINEAR acceleration"):
        read_any(src, profile="phyphox_csv")


def test_koroglu_scaled_g_and_rad_s(raw):
    src = raw / "koroglu_sensorconnect_csv" / "SensorConnectData_31.csv"
    lines = src.read_text().splitlines()
    ref = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    r = read_any(src)
    assert r.profile == "koroglu_sensorconnect_csv" and r.n == len(ref)
    np.testing.assert_allclose(r.acc_mps2, ref[:, 1:4] * G)  # scaledAccel in g
    np.testing.assert_allclose(r.gyro_radps, ref[:, 4:7])  # scaledGyro in rad/s
    assert 1 / np.median(np.diff(r.t_s)) == pytest.approx(200, rel=0.01)
    np.testing.assert_array_equal(r.aux["mag_x"], ref[:, 7])
    np.testing.assert_array_equal(r.aux["yaw"], ref[:, 12])


def test_koroglu_est_19_columns_synthetic():
    from pathlib import Path

    src = Path(__file__).parent / "data" / "koroglu_sensorconnect_est_synthetic.csv"  # SYNTHETIC sample
    ref = np.loadtxt(src, delimiter=",", skiprows=1)
    r = read_any(src)
    assert r.profile == "koroglu_sensorconnect_est_csv" and r.n == len(ref) and ref.shape[1] == 19
    np.testing.assert_allclose(r.acc_mps2, ref[:, [1, 3, 5]])  # m/s^2, flags skipped
    np.testing.assert_allclose(r.gyro_radps, ref[:, [7, 9, 11]])
    assert np.array_equal(r.aux["estcompensatedaccelx_valid"], ref[:, 2])


def test_xio_gyro_first_duplicates_kept(raw, tmp_path):
    src = raw / "xio_ngimu_csv" / "short_walk.csv"
    ref = np.loadtxt(src, delimiter=",", skiprows=1)
    rec = load(import_file(src, tmp_path / "x.h5"))
    assert rec.n == 16539 == len(ref)  # README
    np.testing.assert_allclose(rec.gyro_radps, np.radians(ref[:, 1:4]))  # gyro FIRST, deg/s
    np.testing.assert_allclose(rec.acc_mps2, ref[:, 4:7] * G)  # then acc, g
    assert len(rec.events_of("duplicate_time")) == 205 == int(np.sum(np.diff(ref[:, 0]) == 0))
    assert rec.t_s[-1] == pytest.approx(41.6, abs=0.05)
    assert np.median(np.diff(rec.t_s)) == pytest.approx(0.00251, abs=0.00002)
    gaps = rec.events_of("gap")
    assert len(gaps) > 0 and gaps["count"].min() >= 1 and gaps["count"].max() <= 4  # gaps of 2-5 intervals


def test_openshoe_no_time_column(raw, tmp_path):
    src = raw / "openshoe_820_txt" / "OpenShoeDataSet.txt"
    r = read_any(src)
    assert r.profile == "openshoe_820_txt" and r.n == 51055
    assert r.t_s[-1] == pytest.approx(51054 / 820)  # t_i = i / 820
    assert r.meta["rate_nominal_hz"] == 820
    g_rest = np.median(np.linalg.norm(r.acc_mps2[:820], axis=1))
    assert g_rest == pytest.approx(G, rel=0.05)
    out = import_file(src, tmp_path / "o.h5")
    assert reopen_in_fresh_process(out)["n"] == 51055
