"""One simulated unit (``--device``): device/seed split, the unchanged path without a device, temperature.

Statistical tolerances are 5 standard errors from the sample count; exactness checks use float round-off
or half an LSB (quantisation), never the observed output.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from bootnav.logger.recording import load
from bootnav.simulator import simulate
from bootnav.simulator.device import (DEVICE_SALT, DeviceModel, TemperatureProfile, draw_unit,
                                      parse_device_id)
from bootnav.simulator.imu_model import PROFILES, ErrorModel, get_profile
from bootnav.simulator.scenarios import get_scenario
from bootnav.simulator.writers import SIM_DEVICE_ID, write_h5

REPO = Path(__file__).resolve().parents[1]
PROF = PROFILES["mpu6050-16g-2000dps"]
STABLE = ("acc_sensitivity_matrix", "gyro_sensitivity_matrix", "acc_bias_device_mean_b_mps2",
          "gyro_bias_device_mean_b_radps", "acc_bias_tempco_b_mps2_per_degc", "gyro_bias_tempco_b_radps_per_degc",
          "acc_scale_tempco_per_degc", "gyro_scale_tempco_per_degc", "clock_error")
PER_POWER_ON = ("acc_bias_turn_on_b_mps2", "gyro_bias_turn_on_b_radps")


@pytest.fixture(scope="module")
def runs():
    """paper-straight at 50 Hz: device 42 with seeds 1 and 2, device 43 with seed 1, and no device (seed 1)."""
    kw = dict(rate_hz=50.0)
    return {"d42s1": simulate("paper-straight", seed=1, device=42, **kw),
            "d42s2": simulate("paper-straight", seed=2, device="0x2A", **kw),
            "d43s1": simulate("paper-straight", seed=1, device=43, **kw),
            "none": simulate("paper-straight", seed=1, **kw)}


def test_two_seeds_of_one_device_share_the_stable_constants(runs):
    a, b, c = runs["d42s1"].truth, runs["d42s2"].truth, runs["d43s1"].truth
    for key in STABLE:
        assert np.array_equal(a[key], b[key]), key  # one unit: identical, whatever the seed
        assert not np.array_equal(a[key], c[key]), key  # another unit: different
    for key in PER_POWER_ON:
        assert not np.array_equal(a[key], b[key]), key  # each power-on draws its repeatability
    # the recorded walk is the seed's: one seed, two devices -> the same truth path
    assert np.array_equal(runs["d42s1"].truth["pos_n_m"], runs["d43s1"].truth["pos_n_m"])
    # the turn-on bias scatters around the unit's mean by the repeatability sigma (5 sigma bound)
    unit = draw_unit(42, PROF)
    dev = (a["gyro_bias_turn_on_b_radps"] - a["gyro_bias_device_mean_b_radps"]) / unit.gyro_bias_repeat_sigma_radps
    assert np.all(np.abs(dev) < 5)


def test_device_constants_are_a_function_of_the_id_alone():
    u1, u2 = draw_unit(7, PROF), draw_unit("7", PROF)
    assert np.array_equal(u1.M_a, u2.M_a) and u1.clock_error == u2.clock_error
    # the salt is fixed: the unit is the generator [DEVICE_SALT, id]'s first draws (scale diagonal of M_a)
    first = np.random.default_rng([DEVICE_SALT, 7]).normal(0.0, 1.0, 3) * PROF.accel_scale_sigma
    assert np.allclose(np.diag(u1.M_a) - 1.0, first, rtol=0, atol=1e-15)  # round-off of 1 + x
    assert parse_device_id("0x2A") == parse_device_id("42") == 42
    for bad in ("-1", "4294967296", "2a", "1.5", True):
        with pytest.raises(ValueError):
            parse_device_id(bad)


def test_without_a_device_the_draws_are_those_of_the_old_path(runs):
    """No device: the constants are ``ErrorModel(profile, f_int, rng)``'s after the scenario's draws."""
    res = runs["none"]
    rng = np.random.default_rng(1)
    get_scenario("paper-straight").make(rng, None)
    old = ErrorModel(PROF, res.attrs["internal_rate_hz"], rng).constants()
    assert json.loads(res.attrs["drawn_constants"]) == json.loads(json.dumps(old))
    assert "device_id" not in res.attrs and not any(k in res.truth for k in STABLE + ("temp_degc",))
    from bootnav.simulator.writers import recording_meta

    assert recording_meta(res)["device_id"] == f"0x{SIM_DEVICE_ID:08X}"
    # temperature channel: the old warm-up formula, 25 C + 3 C (1 - exp(-t / 300 s)), as register counts
    t = res.truth["t_s"]
    old_counts = np.rint((PROF.temp_degc + 3.0 * (1 - np.exp(-t / 300.0)) - 36.53) * 340.0).astype(np.int16)
    assert np.array_equal(res.temp, old_counts)


def test_header_carries_the_device_id_like_the_recorder(runs, tmp_path):
    path = write_h5(runs["d42s2"], tmp_path / "d.h5")
    rec = load(path)
    assert rec.meta["device_id"] == "0x0000002A"  # serial_recorder: f"0x{h.device_id:08X}"
    assert rec.temp_degc is not None
    assert np.allclose(rec.temp_degc, runs["d42s2"].truth["temp_degc"], atol=0.5 / 340 + 1e-9)


def _quiet(profile):
    """The profile without noise, bias walk or DLPF: only the deterministic error terms remain."""
    return replace(profile, name="quiet", accel_noise_ug_rthz=0.0, gyro_noise_dps_rthz=0.0,
                   accel_bias_rw_mps2_rts=0.0, gyro_bias_rw_dps_rts=0.0, dlpf_cfg=None)


def test_bias_follows_the_temperature_coefficients_exactly():
    temp = TemperatureProfile(ambient_degc=5.0, tau_s=5.0, ramp_degc_per_min=20.0, ramp_start_s=3.0,
                              ramp_duration_s=12.0)  # a fast chip, so that 27 s see a large change
    res = simulate("paper-straight", seed=3, profile=_quiet(PROF), rate_hz=100.0, device=9, temperature=temp)
    tr = res.truth
    dT = (tr["temp_degc"] - 25.0)[:, None]
    assert np.ptp(tr["temp_degc"]) > 3.0  # the ramp really moved the chip
    for s, unit_si in (("acc", "mps2"), ("gyro", "radps")):
        expected = tr[f"{s}_bias_turn_on_b_{unit_si}"] + tr[f"{s}_bias_tempco_b_{unit_si}_per_degc"] * dT
        assert np.allclose(tr[f"{s}_bias_b_{unit_si}"], expected, rtol=0, atol=1e-12)
    # delivered at rest = (I + diag(s) dT) M f + b(T), to half an LSB (the only other error: int16 rounding)
    st = tr["stance"] == 1
    for s, lsb, meas, true, unit_si in (("acc", PROF.accel_lsb_mps2, res.acc_mps2, tr["f_b_mps2"], "mps2"),
                                        ("gyro", PROF.gyro_lsb_radps, res.gyro_radps, tr["omega_b_radps"], "radps")):
        model = (true @ tr[f"{s}_sensitivity_matrix"].T) * (1 + tr[f"{s}_scale_tempco_per_degc"] * dT) \
            + tr[f"{s}_bias_b_{unit_si}"]
        assert np.abs(meas[st] - model[st]).max() <= 0.5 * lsb * (1 + 1e-9)
    # truth of the temperature: ambient ramp 20 C/min for 12 s -> +4 C, chip between ambient and ambient + 3 C
    assert tr["ambient_degc"][-1] == pytest.approx(9.0)
    assert np.all(tr["temp_degc"] <= tr["ambient_degc"] + temp.self_heating_degc + 1e-12)


def test_chip_temperature_solves_the_first_order_lag():
    """tau T' = A(t) + S - T with T(0) = A(0), checked by central differences (error O(h^2))."""
    p = TemperatureProfile(ambient_degc=10.0, self_heating_degc=3.0, tau_s=200.0, ramp_degc_per_min=6.0,
                           ramp_start_s=100.0, ramp_duration_s=400.0)
    h = 1e-3
    t = np.concatenate([np.linspace(1.0, 95.0, 50), np.linspace(105.0, 495.0, 50), np.linspace(505.0, 3000, 50)])
    dT = (p.chip(t + h) - p.chip(t - h)) / (2 * h)
    assert np.allclose(p.tau_s * dT, p.ambient(t) + p.self_heating_degc - p.chip(t), atol=1e-6)
    assert p.chip(np.array([0.0]))[0] == 10.0
    assert p.chip(np.array([1e6]))[0] == pytest.approx(10.0 + 40.0 + 3.0)  # ambient +40 C, plus self-heating
    with pytest.raises(ValueError):
        simulate("paper-straight", temperature=p)  # temperature needs a device


def test_split_keeps_the_datasheet_spread():
    """Across units the mean bias has sigma_total sqrt(1 - r^2); across power-ons of one unit sigma_total r."""
    n = 400
    model = DeviceModel()
    r = model.repeat_fraction
    sig_g = math.radians(PROF.gyro_turn_on_bias_sigma_dps)
    sig_a = np.asarray(PROF.accel_turn_on_bias_sigma_mg) * 1e-3 * STANDARD_GRAVITY
    units = [draw_unit(d, PROF) for d in range(n)]
    tol = 5 / math.sqrt(2 * n)  # relative standard error of a std estimate
    means_g = np.array([u.gyro_bias_mean_radps for u in units])
    assert np.std(means_g, axis=0) == pytest.approx(np.full(3, sig_g * math.sqrt(1 - r**2)), rel=tol)
    means_a = np.array([u.acc_bias_mean_mps2 for u in units])
    assert np.std(means_a, axis=0) == pytest.approx(sig_a * math.sqrt(1 - r**2), rel=tol)
    k_g = np.array([u.gyro_bias_tempco_radps_per_degc for u in units])
    sig_k = math.radians(model.gyro_bias_tempco_sigma_dps_per_degc)
    assert np.std(k_g) == pytest.approx(sig_k, rel=5 / math.sqrt(6 * n))  # 3 axes x n units
    unit = units[0]
    b0 = np.array([ErrorModel(PROF, 1000.0, np.random.default_rng(s), unit).b0_g for s in range(n)])
    assert np.std(b0, axis=0) == pytest.approx(np.full(3, sig_g * r), rel=tol)
    assert np.mean(b0, axis=0) == pytest.approx(unit.gyro_bias_mean_radps, abs=5 * sig_g * r / math.sqrt(n))
    # the noise-only profile has no per-unit errors at all
    quiet = draw_unit(5, get_profile("mpu6050-noise-only"))
    assert np.array_equal(quiet.M_a, np.eye(3)) and not np.any(quiet.gyro_bias_tempco_radps_per_degc)


def test_cli_device_flags(tmp_path):
    run = lambda *a: subprocess.run([sys.executable, "-m", "bootnav", "simulate", *a], cwd=REPO,  # noqa: E731
                                    capture_output=True, text=True, timeout=120)
    out = tmp_path / "d.h5"
    p = run("--scenario", "paper-straight", "--rate", "50", "--device", "0xBEEF", "--seed", "2",
            "--ambient-degc", "40", "--out", str(out))
    assert p.returncode == 0, p.stderr
    rec = load(out)
    assert rec.meta["device_id"] == "0x0000BEEF"
    assert rec.temp_degc[0] == pytest.approx(40.0, abs=0.5 / 340 + 1e-9)
    bad = run("--scenario", "paper-straight", "--ambient-degc", "40", "--out", str(tmp_path / "x.h5"))
    assert bad.returncode == 1 and "--device" in bad.stderr and not (tmp_path / "x.h5").exists()
