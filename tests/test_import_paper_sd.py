"""The source paper's SD-card .txt as it comes off the card [Heidari2019, §3]: headerless
``ms ax ay az gx gy gz`` raw MPU6050 counts, profile ``heidari2019_sd_txt``, auto-detected."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.importers import read_any
from bootnav.logger.mpu6050 import STANDARD_GRAVITY

PROFILE = "heidari2019_sd_txt"


def _paper_log(tmp_path, profile="mpu6050-2g-250dps", delimiter=" ", name="DATALOG.TXT"):
    """A simulated walk written the way an Arduino sketch prints it: millis() and the six int16 registers."""
    from bootnav import simulator as sim
    res = sim.simulate("paper-straight", seed=0, profile=profile)
    ms = np.floor(res.t_s * 1000.0).astype(np.int64) + 5123  # millis() since power-on
    rows = np.column_stack([ms, res.acc.astype(np.int64), res.gyro.astype(np.int64)])
    path = tmp_path / name
    path.write_text("\n".join(delimiter.join(map(str, r)) for r in rows.tolist()) + "\n")
    return res, ms, path


@pytest.mark.parametrize("delimiter", [" ", ",", "\t"])
def test_paper_log_is_auto_detected_and_read_bit_exact(tmp_path, delimiter):
    res, ms, path = _paper_log(tmp_path, delimiter=delimiter)
    r = read_any(path)
    assert r.profile == PROFILE and r.meta["detected"]["profile_auto_detected"]
    assert r.acc.dtype == np.int16 and np.array_equal(r.acc, res.acc) and np.array_equal(r.gyro, res.gyro)
    # counts at the power-on ranges: 16384 LSB/g, 131 LSB/(deg/s)
    assert r.acc_channel.scale_to_si == pytest.approx(STANDARD_GRAVITY / 16384)
    assert r.gyro_channel.scale_to_si == pytest.approx(np.radians(1 / 131))
    np.testing.assert_allclose(r.t_s, (ms - ms[0]) / 1000.0, atol=1e-12)
    # a walking foot clips +-2 g / +-250 deg/s: flagged, not silently trusted
    assert r.saturated.any() == bool(np.any(np.abs(res.acc) >= 32767) | np.any(np.abs(res.gyro) >= 32767))
    assert r.count("saturation") > 0


def test_other_seven_column_files_are_not_taken_for_the_paper_log(tmp_path):
    """Floats in the same column order (g, deg/s) match no profile: the generic reader takes them."""
    _, _, path = _paper_log(tmp_path)
    rows = np.loadtxt(path)
    floats = tmp_path / "floats.txt"
    floats.write_text("\n".join(" ".join(f"{v:.4f}" for v in [r[0] / 1000, *(r[1:4] / 16384), *(r[4:7] / 131)])
                                for r in rows) + "\n")
    r = read_any(floats, acc_unit="g", gyro_unit="dps")
    assert r.profile != PROFILE and "no profile matched" in " ".join(r.messages)


def test_a_different_range_is_named_by_the_gravity_check(tmp_path):
    res, _, path = _paper_log(tmp_path, profile="mpu6050-16g-2000dps")
    with pytest.raises(InputError, match="--acc-range 16"):
        read_any(path)
    r = read_any(path, profile=PROFILE, acc_range_g=16, gyro_range_dps=2000)
    np.testing.assert_allclose(r.acc_mps2, res.acc_mps2, rtol=1e-12)
    np.testing.assert_allclose(r.gyro_radps, res.gyro_radps, rtol=1e-12)
