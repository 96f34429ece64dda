"""Issue 26, point 1: the array API checks units from physics as ``bootnav import`` does and speaks its own
words. Each test is what a notebook user does: arrays in g, deg/s or ms, times forgotten, a DataFrame, settings
by name, a gap, a second save."""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import bootnav
from bootnav.errors import BootnavWarning, InputError
from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from tests.conftest import REPO

BUNDLED = REPO / "recordings" / "xio_ngimu_short_walk.h5"
CROP = (0.0, 25.0)  # a still start and a dozen strides: enough for every check, a second to process


@pytest.fixture(scope="module")
def rec():
    if not BUNDLED.exists():
        pytest.skip("recordings/ not present")
    return bootnav.load(BUNDLED)


def _no_cli_words(message: str) -> None:
    assert not re.search(r"(^|\s)--[a-z]", message), message  # no command-line flag inside Python


def test_arrays_in_wrong_units_are_named_with_the_keyword_that_fixes_them(rec):
    cases = [((rec.t_s, rec.acc_mps2 / STANDARD_GRAVITY, rec.gyro_radps), 'acc_unit="g"'),  # acc in g
             ((rec.t_s, rec.acc_mps2, np.degrees(rec.gyro_radps)), 'gyro_unit="dps"'),  # gaitmap's deg/s
             ((rec.t_s * 1e3, rec.acc_mps2, rec.gyro_radps), 'time_unit="ms"')]  # a ms clock
    for args, keyword in cases:
        with pytest.raises(InputError) as err:
            bootnav.process(*args)
        assert keyword in str(err.value) and "check_units=False" in str(err.value)
        assert "crop" not in str(err.value)  # the ms clock is a unit, not a gap to crop around
        _no_cli_words(str(err.value))
    with pytest.raises(InputError, match=r'gyro_unit="dps"'):  # pdr checks the same physics
        bootnav.pdr(rec.t_s, rec.acc_mps2, np.degrees(rec.gyro_radps))


def test_forgotten_times_are_named(rec):
    with pytest.raises(InputError, match="times are missing"):
        bootnav.process(rec.acc_mps2, rec.gyro_radps)


def test_declared_units_give_the_si_path(rec):
    si = bootnav.process(rec.t_s, rec.acc_mps2, rec.gyro_radps, crop_s=CROP)
    other = bootnav.process(rec.t_s * 1e3, rec.acc_mps2 / STANDARD_GRAVITY, np.degrees(rec.gyro_radps),
                            acc_unit="g", gyro_unit="dps", time_unit="ms", crop_s=CROP)
    # the same samples after a unit conversion: equal to rounding (1e-9 m over 25 s of a 16-stride walk)
    assert si.summary["strides"] == other.summary["strides"]
    assert np.allclose(si.pos_n_m, other.pos_n_m, atol=1e-6)


def test_every_warning_is_a_python_warning_in_api_words(rec):
    with pytest.warns(BootnavWarning) as caught:
        res = bootnav.process(rec.t_s, rec.acc_mps2 / STANDARD_GRAVITY, rec.gyro_radps, crop_s=CROP,
                              check_units=False)
    said = [str(w.message) for w in caught if issubclass(w.category, BootnavWarning)]
    assert said == [bootnav.api.api_words(w) for w in res.warnings] and len(said) >= 1
    assert "unit check overridden" in said[0] and 'acc_unit="g"' in said[0]
    for m in said:
        _no_cli_words(m)


def test_a_gap_suggests_crop_keywords_never_a_zero_length_crop(rec):
    for at in (len(rec.t_s) // 2, 1):  # a gap in the middle; a gap after the first sample
        t = rec.t_s.copy()
        t[at:] += 5.0
        with pytest.raises(InputError) as err:
            bootnav.process(t, rec.acc_mps2, rec.gyro_radps)
        msg = str(err.value)
        _no_cli_words(msg)
        crops = [(float(a), float(b)) for a, b in re.findall(r"crop_s=\((-?[0-9.]+), (-?[0-9.]+)\)", msg)]
        assert crops and all(b > a for a, b in crops), msg
        assert len(crops) == (2 if at > 1 else 1)


def test_settings_by_name_and_reference_as_dict(rec):
    r = bootnav.process(rec, crop_s=CROP, detector="shoe", reference={"closed_loop": True})
    assert r.raw.settings.detector.method == "shoe"
    assert r.metrics["reference_kind"] == "closed_loop"
    r = bootnav.process(rec, crop_s=CROP, settings={"detector": "shoe"})
    assert r.raw.settings.detector.method == "shoe"


def test_save_twice_says_force_true(rec, tmp_path):
    r = bootnav.process(rec, crop_s=CROP, output={"plots": False})
    r.save(tmp_path / "out")
    with pytest.raises(InputError) as err:
        r.save(tmp_path / "out")
    assert "force=True" in str(err.value)
    _no_cli_words(str(err.value))


def test_dataframes_in_and_out_indexed_by_time(rec):
    pd = pytest.importorskip("pandas")
    cols = {"t_ms": rec.t_s * 1e3, **{f"a{a}_g": rec.acc_mps2[:, i] / STANDARD_GRAVITY for i, a in enumerate("xyz")},
            **{f"g{a}_dps": np.degrees(rec.gyro_radps[:, i]) for i, a in enumerate("xyz")}}
    by_frame = bootnav.process(pd.DataFrame(cols), crop_s=CROP)
    by_arrays = bootnav.process(rec.t_s, rec.acc_mps2, rec.gyro_radps, crop_s=CROP)
    assert np.allclose(by_frame.pos_n_m, by_arrays.pos_n_m, atol=1e-6)
    with pytest.raises(InputError, match="ax_mps2"):  # the documented names, not a TypeError
        bootnav.process(pd.DataFrame({"time": rec.t_s, "acc": rec.acc_mps2[:, 0]}))
    traj, steps = by_arrays.to_dataframe(), by_arrays.steps_dataframe()
    assert traj.index.name == steps.index.name == "t_s"
    assert np.array_equal(traj.index.to_numpy(), by_arrays.t_s)
    assert {"qw", "qx", "qy", "qz"} <= set(traj.columns)
    steps_pdr = bootnav.pdr(rec.t_s, rec.acc_mps2, rec.gyro_radps)
    assert steps_pdr.steps_dataframe().index.name == "t_s"  # one name on both result types
    assert steps_pdr.to_dataframe().equals(steps_pdr.steps_dataframe())  # the old name kept


def test_recording_repr_is_one_short_line(rec):
    text = repr(rec)
    assert "\n" not in text and len(text) < 160 and "16539 samples" in text
