"""The HDF5 recording format: round trip, SI conversion, events, partial files."""

import h5py
import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger import mpu6050
from bootnav.logger.recording import (
    EVENT_DTYPE,
    RecordingWriter,
    counts_channel,
    load,
    make_events,
    write_group,
    write_recording,
)
from tests.conftest import reopen_in_fresh_process, sha


def _counts(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.integers(-32768, 32768, size=(n, 3), dtype=np.int16)


def test_counts_round_trip_is_bit_exact_and_si_uses_the_declared_scale(tmp_path):
    n = 5000
    acc, gyro = _counts(n, 1), _counts(n, 2)
    t = np.arange(n) / 200.0
    acc_scale = mpu6050.accel_scale_mps2(3)
    gyro_scale = mpu6050.gyro_scale_radps(3)
    path = write_recording(
        tmp_path / "r.h5", t, acc, gyro,
        acc_channel=counts_channel("acc", acc_scale), gyro_channel=counts_channel("gyro", gyro_scale),
        events=make_events([{"kind": "gap", "sample_index": 10, "count": 3, "t_s": 0.05}]),
        meta={"device": "MPU6050", "mount": "left_boot"},
    )
    summary = reopen_in_fresh_process(path)
    assert summary["n"] == n
    assert summary["acc_raw"] == sha(acc) and summary["gyro_raw"] == sha(gyro)
    assert summary["n_events"] == 1
    rec = load(path)
    # 16 g full scale is 2048 LSB/g exactly.
    np.testing.assert_allclose(rec.acc_mps2, acc * 9.80665 / 2048.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rec.gyro_radps, np.deg2rad(gyro / 16.4), rtol=1e-12)
    assert rec.meta["mount"] == "left_boot"
    assert abs(rec.meta["rate_measured_hz"] - 200.0) < 1e-6
    assert rec.events_of("gap")["count"][0] == 3


def test_every_dataset_has_units_and_root_documents_conventions(tmp_path):
    path = write_recording(tmp_path / "r.h5", np.arange(10) * 0.01, np.zeros((10, 3)), np.zeros((10, 3)))
    with h5py.File(path) as f:
        for key in ("format_version", "nav_frame", "body_frame", "quaternion_order", "gravity_model"):
            assert key in f.attrs
        seen = []
        f.visititems(lambda name, obj: seen.append((name, obj)) if isinstance(obj, h5py.Dataset) else None)
        for name, ds in seen:
            if name != "imu/axis":
                assert "units" in ds.attrs, name


def test_incremental_writer_is_readable_while_open_and_after_close(tmp_path):
    path = tmp_path / "live.h5"
    w = RecordingWriter(path, counts_channel("acc", 1e-3), counts_channel("gyro", 1e-4), seq=True,
                        device_time=True, host_time=True)
    for k in range(3):
        w.append(np.arange(100) * 0.01 + k, _counts(100, k), _counts(100, k + 10),
                 seq=np.arange(100, dtype=np.uint16), t_device=np.arange(100, dtype=np.uint32),
                 t_host=np.zeros(100))
        w.flush()
        assert reopen_in_fresh_process(path)["n"] == 100 * (k + 1)
    w.close(final_meta={"frames": 300})
    assert load(path).meta["frames"] == 300


def test_opens_with_xarray_dimension_scales(tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    path = write_recording(tmp_path / "r.h5", np.arange(10) * 0.01, np.ones((10, 3)), np.zeros((10, 3)))
    ds = xr.open_dataset(path, group="imu", engine="h5netcdf", phony_dims="sort")
    assert ds["acc"].dims == ("sample", "axis") and ds["t_s"].dims == ("sample",)
    assert ds["acc"].shape == (10, 3)


def test_write_group_adds_results_with_units(tmp_path):
    path = write_recording(tmp_path / "r.h5", np.arange(10) * 0.01, np.ones((10, 3)), np.zeros((10, 3)))
    write_group(path, "results/test", {"pos_n_m": np.zeros((10, 3))}, attrs={"settings": {"a": 1}},
                units={"pos_n_m": "m"})
    with h5py.File(path) as f:
        assert f["results/test/pos_n_m"].attrs["units"] == "m"


def test_load_rejects_non_recordings_clearly(tmp_path):
    bad = tmp_path / "x.h5"
    bad.write_bytes(b"not hdf5 at all")
    with pytest.raises(InputError, match="x.h5"):
        load(bad)
    with pytest.raises(InputError, match="no such file"):
        load(tmp_path / "missing.h5")
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = 1
    with pytest.raises(InputError, match="not a bootnav recording"):
        load(tmp_path / "other.h5")


def test_make_events_rejects_unknown_kinds():
    with pytest.raises(ValueError):
        make_events([{"kind": "nonsense"}])
    assert make_events([]).dtype == EVENT_DTYPE
