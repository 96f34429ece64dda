"""Property-based fuzz of the HDF5 loader: a recording cut anywhere, or with any datasets and attributes
deleted, either loads with equal-length finite-time arrays or raises ``InputError`` naming the file -
never another exception, never a hang. Derandomized so CI is reproducible."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bootnav.errors import InputError
from bootnav.logger.recording import load

WALK = Path(__file__).resolve().parents[2] / "recordings" / "xio_ngimu_short_walk.h5"
DATA = WALK.read_bytes()
NODES = ["imu/t_s", "imu/acc", "imu/gyro", "imu/saturated", "imu/axis", "events", "meta", "imu"]
ATTRS = [("imu/acc", "scale_to_si"), ("imu/gyro", "offset_to_si"), ("/", "format_version")]
FUZZ = settings(derandomize=True, max_examples=40, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])


def _load_or_input_error(path: Path) -> None:
    t0 = time.monotonic()
    try:
        rec = load(path)
    except InputError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc)
    else:
        assert rec.acc_mps2.shape == rec.gyro_radps.shape == (rec.n, 3) and rec.saturated.shape == (rec.n,)
    assert time.monotonic() - t0 < 5.0  # no SWMR retry loop


@FUZZ
@given(fraction=st.floats(0.0, 0.9999))
def test_cut_anywhere(tmp_path, fraction):
    path = tmp_path / "cut.h5"
    path.write_bytes(DATA[: int(len(DATA) * fraction)])
    _load_or_input_error(path)


@FUZZ
@given(delete=st.sets(st.sampled_from(NODES), max_size=3),
       attrs=st.sets(st.sampled_from(ATTRS), max_size=2),
       junk=st.sampled_from([None, "text", np.nan, np.array([1.0, 2.0])]))
def test_datasets_and_attributes_deleted_or_replaced(tmp_path, delete, attrs, junk):
    path = tmp_path / "edited.h5"
    shutil.copy(WALK, path)
    with h5py.File(path, "r+") as f:
        for name in sorted(delete, key=len, reverse=True):
            if name in f:
                del f[name]
        for where, key in attrs:
            if where in f:
                if junk is None:
                    f[where].attrs.pop(key, None)
                else:
                    f[where].attrs[key] = junk
    _load_or_input_error(path)


@pytest.mark.parametrize("offset", [0, 4096, len(DATA) // 2, len(DATA) - 100])
def test_flipped_bytes(tmp_path, offset):
    """Damage inside the file (not only at its end): a clear error or a consistent recording."""
    data = bytearray(DATA)
    data[offset:offset + 64] = bytes(64)
    path = tmp_path / "flipped.h5"
    path.write_bytes(bytes(data))
    _load_or_input_error(path)
