"""The HDF5 recording format: round trip, SI conversion, events, partial files."""

from pathlib import Path

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


def test_a_new_recording_is_synced_before_and_its_folder_after_the_rename(tmp_path, monkeypatch):
    """``_publish`` is crash-safe as ``core.atomic.commit``: fsync of the hidden file, rename, fsync of the
    folder (after a power cut the name shows the whole structure or nothing)."""
    from bootnav.logger import recording

    calls = []
    real_replace = recording.os.replace
    monkeypatch.setattr(recording, "fsync_path", lambda p: calls.append(("fsync", Path(p))))
    monkeypatch.setattr(recording.os, "replace", lambda a, b: (calls.append(("rename", Path(b))), real_replace(a, b)))
    path = tmp_path / "r.h5"
    w = RecordingWriter(path, counts_channel("acc", 1.0), counts_channel("gyro", 1.0), swmr=False)
    w.close()
    kinds = [k for k, _ in calls]
    assert kinds == ["fsync", "rename", "fsync"], calls
    assert calls[0][1].name.startswith(".r.h5.") and calls[1][1] == path and calls[2][1] == tmp_path


def test_the_recorder_s_rewrites_go_through_the_recording_module(tmp_path):
    """``retime_boots`` maps every sample's and event's time (events by their clipped ``sample_index``),
    writes the root attributes and each boot's ``/meta``; ``set_scale_factors`` changes only the factors."""
    from bootnav.logger.recording import retime_boots, set_scale_factors, write_multi_boot

    n = 50
    t = np.arange(n) / 100.0
    ev = [dict(t_s=0.105, sample_index=10, kind="gap", count=1), dict(t_s=-0.5, sample_index=-1, kind="resync")]
    boots = {b: dict(t_s=t, acc=_counts(n, i).astype(float), gyro=_counts(n, i + 5).astype(float), events=ev)
             for i, b in enumerate(("left", "right"))}
    path = write_multi_boot(tmp_path / "two.h5", boots)
    got = retime_boots(path, {"left": lambda t, i: 2.0 * t + i, "right": lambda t, i: t - 1.0},
                       attrs={"session_start_unix_s": 123.5}, meta_of=lambda label, t_new: {"first_s": t_new[0]})
    assert np.array_equal(got["left"], 2.0 * t + np.arange(n))
    left, right = load(path, boot="left"), load(path, boot="right")
    assert np.array_equal(left.t_s, 2.0 * t + np.arange(n)) and np.array_equal(right.t_s, t - 1.0)
    assert np.allclose(left.events["t_s"], [0.21 + 10, -1.0 + 0]) and np.allclose(right.events["t_s"], [-0.895, -1.5])
    assert left.meta["first_s"] == 0.0 and right.meta["first_s"] == -1.0
    with h5py.File(path, "r") as f:
        assert f.attrs["session_start_unix_s"] == 123.5
    set_scale_factors(path, 2.0, 0.5, boot="right")
    assert np.array_equal(load(path, boot="right").acc_mps2, 2.0 * boots["right"]["acc"])
    assert np.array_equal(load(path, boot="right").gyro_radps, 0.5 * boots["right"]["gyro"])
    assert np.array_equal(load(path, boot="left").acc_mps2, boots["left"]["acc"])
