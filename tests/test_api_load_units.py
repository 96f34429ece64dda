"""``bootnav.load`` on a text file whose units are wrong names the API's keywords, and takes them (issue 26)."""

import numpy as np
import pytest

import bootnav
from bootnav.errors import InputError

G = 9.80665


def _still_csv(path, header, acc_scale):
    """30 s of a sensor lying still at 100 Hz, acc in m/s^2 times ``acc_scale``, gyro in rad/s."""
    rng = np.random.default_rng(26)
    n = 3000
    acc = (np.tile([0.0, 0.0, G], (n, 1)) + rng.normal(0, 0.02, (n, 3))) * acc_scale
    gyro = rng.normal(0, 0.01, (n, 3))
    np.savetxt(path, np.column_stack([np.arange(n) / 100.0, acc, gyro]), delimiter=",", header=header,
               comments="", fmt="%.6f")
    return path


def test_wrong_declared_unit_names_the_keyword_and_the_keyword_fixes_it(tmp_path):
    # header says g, values are m/s^2: |acc| at rest 9.81 "g" contradicts gravity
    f = _still_csv(tmp_path / "wrong.csv", "t_s,ax_g,ay_g,az_g,gx_radps,gy_radps,gz_radps", 1.0)
    with pytest.raises(InputError) as e:
        bootnav.load(f)
    assert 'acc_unit="mps2"' in str(e.value) and "--" not in str(e.value)
    rec = bootnav.load(f, acc_unit="mps2")
    assert abs(np.median(np.linalg.norm(rec.acc_mps2, axis=1)) - G) < 0.1  # gravity, to the noise


def test_undeclared_unrecognisable_unit_names_the_keyword(tmp_path):
    # no units anywhere and |acc| at rest 3 (neither 1 g nor 9.81 m/s^2)
    f = _still_csv(tmp_path / "nounit.csv", "time,ax,ay,az,gx,gy,gz", 3.0 / G)
    with pytest.raises(InputError) as e:
        bootnav.load(f)
    assert "acc_unit=" in str(e.value) and "--acc-unit" not in str(e.value)
    rec = bootnav.load(f, acc_unit="mps2", gyro_unit="radps", check_units=False)  # the user's word, kept
    assert rec.n == 3000


def test_unit_keywords_refused_for_a_recording(tmp_path):
    from bootnav.logger.importers import import_file

    f = _still_csv(tmp_path / "ok.csv", "t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps", 1.0)
    with pytest.raises(InputError, match="declares its own units"):
        bootnav.load(import_file(f, tmp_path / "ok.h5"), acc_unit="g")
