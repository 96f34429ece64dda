"""Issue 26, point 2: files a user opens without bootnav. xarray (h5netcdf engine) decodes /imu to SI from the
CF attributes, the axis coordinate is text, the index is monotonic although the clock repeats a value;
trajectory.csv carries the attitude and heading; results.h5 refers to its recording instead of copying it."""

from __future__ import annotations

import csv
import json
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from bootnav.logger.recording import RecordingWriter, counts_channel, file_sha256, load
from bootnav.logger.mpu6050 import accel_scale_mps2, gyro_scale_radps
from tests.conftest import REPO

SIM = REPO / "recordings" / "sim_paper-straight.h5"


def _counts_recording(path, n=400):
    """int16 counts (our firmware's format) with a repeated timestamp, as a device clock gives one."""
    rng = np.random.default_rng(0)
    t = np.arange(n) * 0.005
    t[101] = t[100]  # a duplicate time stamp
    acc = rng.integers(-20000, 20000, (n, 3)).astype(np.int16)
    gyro = rng.integers(-20000, 20000, (n, 3)).astype(np.int16)
    w = RecordingWriter(path, counts_channel("acc", accel_scale_mps2(3)), counts_channel("gyro", gyro_scale_radps(3)),
                        temp=counts_channel("temp", 1 / 340.0))
    w.append(t, acc, gyro, temp=np.full(n, 1000, np.int16))
    w.close()
    return path


def test_xarray_decodes_si_text_axis_and_a_monotonic_index_without_bootnav(tmp_path):
    pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = _counts_recording(tmp_path / "walk.h5")
    rec = load(path)
    # a fresh interpreter that imports xarray only: what a user without bootnav gets
    code = ("import sys, json, xarray as xr\n"
            "ds = xr.open_dataset(sys.argv[1], engine='h5netcdf', group='imu')\n"
            "print(json.dumps({'acc': ds['acc'].values.tolist(), 'gyro_x': ds['gyro'].sel(axis='x').values.tolist(),"
            " 'temp': ds['temp'].values.tolist(), 't': ds['t_s'].values.tolist(), 'dims': list(ds['acc'].dims),"
            " 'index_monotonic': bool(ds.indexes['sample'].is_monotonic_increasing),"
            " 'coords': sorted(ds.coords), 'units': ds['acc'].attrs.get('units', ds['acc'].encoding.get('units'))}))")
    out = json.loads(subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True,
                                    check=True, cwd=tmp_path).stdout)
    # SI values, to float32 decoding precision at worst (int16 * float scale: relative 2**-24)
    assert np.allclose(out["acc"], rec.acc_mps2, rtol=1e-6, atol=0)
    assert np.allclose(out["gyro_x"], rec.gyro_radps[:, 0], rtol=1e-6, atol=0)
    assert np.allclose(out["temp"], rec.temp_degc, rtol=1e-6) and abs(out["temp"][0] - (1000 / 340 + 36.53)) < 1e-4
    assert out["dims"] == ["sample", "axis"] and out["index_monotonic"]
    assert "t_s" in out["coords"] and out["t"] == rec.t_s.tolist()  # the clock kept as recorded, duplicate too
    with h5py.File(path) as f:
        acc = f["imu/acc"]
        assert acc.dtype == np.int16  # stored raw, decoded by the reader
        assert acc.attrs["scale_factor"] == acc.attrs["scale_to_si"] and acc.attrs["add_offset"] == 0.0
        assert acc.attrs["units"] == "m/s^2" and acc.attrs["raw_units"] == "count"


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    """``bootnav process`` on a copy of the simulated walk, as a user runs it: (recording, output folder)."""
    tmp = tmp_path_factory.mktemp("cf")
    rec = tmp / "walk.h5"
    rec.write_bytes(SIM.read_bytes())
    out = tmp / "out"
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "process", str(rec), "--out", str(out), "--no-plots",
                           "-q"], capture_output=True, text=True, timeout=180, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    return rec, out


def test_trajectory_csv_has_attitude_and_heading_in_both_conventions(processed):
    _, out = processed
    with open(out / "trajectory.csv") as fh:
        rows = list(csv.reader(fh))
    header, data = rows[0], np.array(rows[1:], float)
    col = {name: data[:, i] for i, name in enumerate(header)}
    q = np.column_stack([col[k] for k in ("qw", "qx", "qy", "qz")])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=4e-6)  # unit quaternions to the printed 6 decimals
    with h5py.File(out / "results.h5") as f:
        assert np.allclose(q, f["results/default/q_nb"][()], atol=5e-7)
    yaw, compass = col["sensor_yaw_enu_rad"], col["sensor_heading_deg_cw_from_north"]
    # the sensor's x axis from q_nb: its horizontal direction, both ways
    x_n = np.column_stack([1 - 2 * (q[:, 2] ** 2 + q[:, 3] ** 2), 2 * (q[:, 1] * q[:, 2] + q[:, 0] * q[:, 3])])
    assert np.allclose(np.angle(np.exp(1j * (yaw - np.arctan2(x_n[:, 1], x_n[:, 0])))), 0, atol=1e-3)
    diff = np.mod(compass - (90 - np.degrees(yaw)), 360)
    assert np.all(np.minimum(diff, 360 - diff) < 0.01)


def test_results_h5_refers_to_the_recording_and_loads_like_it(processed, tmp_path):
    rec, out = processed
    res = out / "results.h5"
    with h5py.File(res) as f:
        assert f.attrs["recording_sha256"] == file_sha256(rec) and f.attrs["recording_file"] == "../walk.h5"
        assert isinstance(f.get("imu", getlink=True), h5py.ExternalLink)
        n_results = f["results/default/pos_n_m"].shape[0]
    # no copy: the results file is smaller than the recording plus its own results arrays
    assert res.stat().st_size < n_results * 8 * 30 + 200_000
    a, b = load(res), load(rec)
    assert np.array_equal(a.acc_mps2, b.acc_mps2) and np.array_equal(a.t_s, b.t_s) and a.meta == b.meta
    # moved together, the relative link still resolves
    moved = tmp_path / "moved"
    moved.mkdir()
    (moved / "out").mkdir()
    shutil.copy(rec, moved / "walk.h5")  # copies: the module's other tests read the originals
    shutil.copy(res, moved / "out" / "results.h5")
    assert load(moved / "out" / "results.h5").n == b.n
    # recording gone: a one-line error naming it (bootnav info, like every reader)
    (moved / "walk.h5").unlink()
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "info", str(moved / "out" / "results.h5")],
                          capture_output=True, text=True, timeout=60, cwd=REPO)
    assert proc.returncode == 1 and "../walk.h5" in proc.stderr and "Traceback" not in proc.stderr


def test_results_h5_of_earlier_releases_still_load(tmp_path):
    """An earlier results.h5 is a whole copy of the recording plus /results: it reads as the recording."""
    old = tmp_path / "results.h5"
    old.write_bytes(SIM.read_bytes())
    with h5py.File(old, "r+") as f:
        f.create_group("results/default").create_dataset("pos_n_m", data=np.zeros((3, 3)))
    assert np.array_equal(load(old).acc_mps2, load(SIM).acc_mps2)
