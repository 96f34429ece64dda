"""`bootnav pdr` / `bootnav.pdr` on a recording with no walking motion: zero steps and a warning that says so
(issue 27, "pdr counts 4148 steps in noise")."""

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

import bootnav

FS, DURATION = 100.0, 60.0


def _noise(sigma_mps2, seed=27):
    """A sensor lying still, z up: gravity plus white noise of ``sigma_mps2`` per axis, gyro noise 0.01 rad/s."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(FS * DURATION)) / FS
    acc = np.array([0.0, 0.0, 9.80665]) + rng.normal(0.0, sigma_mps2, (t.size, 3))
    return t, acc, rng.normal(0.0, 0.01, (t.size, 3))


# 0.02 m/s^2: a MEMS accelerometer at rest; 1 m/s^2 (0.1 g) per sample: a very noisy one, whose walking-band
# share (~0.2 m/s^2 RMS) matches slow walking in amplitude but not in spectrum
@pytest.mark.parametrize("sigma", [0.02, 1.0])
def test_api_noise_gives_zero_steps_and_says_why(sigma):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = bootnav.pdr(*_noise(sigma))
    assert res.summary["steps"] == 0
    assert any("no walking motion" in str(w.message) for w in caught)


def test_api_walk_in_the_same_noise_keeps_its_steps():
    # 1.8 steps/s, 1.5 m/s^2 vertical (a slow walk at the waist) on the 1 m/s^2 noise: ~108 steps, none dropped
    t, acc, gyro = _noise(1.0)
    acc[:, 2] += 1.5 * np.sin(2 * np.pi * 1.8 * t)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = bootnav.pdr(t, acc, gyro)
    assert abs(res.summary["steps"] - 1.8 * DURATION) <= 5  # a bout's first/last step and the band-pass edges
    assert not any("dropped as noise" in w for w in res.summary["warnings"])


def test_cli_noise_gives_zero_steps_and_a_warning(tmp_path):
    t, acc, gyro = _noise(1.0)
    csv = tmp_path / "noise.csv"
    np.savetxt(csv, np.column_stack([t, acc, gyro]), delimiter=",", comments="", fmt="%.5f",
               header="t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps")
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "bootnav.cli", "pdr", str(csv), "--out", str(out), "--no-plots"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((out / "summary.json").read_text())["steps"] == 0
    lines = [ln for ln in proc.stderr.splitlines() if "no walking motion" in ln]
    assert len(lines) == 1 and "Traceback" not in proc.stderr
