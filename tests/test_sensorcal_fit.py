"""postproc.sensorcal: static poses, accelerometer and gyroscope fits, temperature, errors naming what to add.

The sessions are exact (``postproc.sensorcal.synthetic``: closed-form rotations and rates through
y = S x + b + k ΔT + white noise), so the fit must return C = S⁻¹, b, k within its own 1σ; the bound is 5σ
(a 5σ miss among the ~30 parameters checked here has a probability of 2e-5).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bootnav.core.sensorcal import temperature_warning
from bootnav.errors import InputError
from bootnav.postproc.sensorcal import SensorCalSettings, calibrate
from bootnav.postproc.sensorcal import synthetic as sy
from bootnav.postproc.sensorcal.fit import reference_parameters
from bootnav.postproc.sensorcal.gyro_fit import integrate_segments
from bootnav.postproc.sensorcal.static import detect_static_poses

SETTINGS = SensorCalSettings(gravity_mps2=sy.G_STD)  # the synthetic sessions use standard gravity


def _sigma_matrix(tri, names_upper_only=False):
    return np.array([[tri.sigma.get(f"C_{a}{b}", 0.0) for b in "xyz"] for a in "xyz"])


def _within(est, true, sigma, k=5.0, floor=0.0):
    err = np.abs(np.asarray(est) - np.asarray(true))
    return bool(np.all(err <= k * np.asarray(sigma) + floor)), err


def test_integrator_matches_the_exact_rotation_of_a_constant_rate():
    rate = np.array([0.4, -1.1, 0.7])  # rad/s, constant: the exact rotation is Exp(rate T)
    n, dt = 501, 0.01
    omega = np.tile(rate, (n, 1))
    q = integrate_segments(omega, np.full(n, dt), np.array([0]), np.array([n - 1]))[0]
    want = Rotation.from_rotvec(rate * dt * (n - 1)).as_quat()  # xyzw
    got = np.array([q[1], q[2], q[3], q[0]])
    assert min(np.abs(got - want).max(), np.abs(got + want).max()) < 1e-12


def test_static_poses_are_found_once_each():
    truth = sy.draw_truth(11, with_temp=False)
    ses = sy.make_session(truth, 12)
    poses = detect_static_poses(ses.t_s, ses.acc, ses.gyro, ses.temp_degc, SETTINGS)
    assert len(poses) == len(sy.STANDARD_MOTIONS) + 1
    # every detected pose lies inside a hold: the true rate there is tremor only (< 0.05 rad/s)
    for a, b in zip(poses.start, poses.stop):
        assert np.abs(ses.truth["rate_b"][a:b]).max() < SETTINGS.gyro_std_max_radps


def test_fit_recovers_scale_misalignment_and_bias_within_its_sigma():
    truth = sy.draw_truth(21, with_temp=False)
    res = calibrate([sy.make_session(truth, 22)], SETTINGS)
    cal = res.calibration
    ok, err = _within(cal.acc.matrix, truth.c_acc, _sigma_matrix(cal.acc))
    assert ok, err
    ok, err = _within(cal.gyro.matrix, truth.c_gyro, _sigma_matrix(cal.gyro))
    assert ok, err
    # the session's own bias to the precision of its poses (the stored 1σ adds the turn-on repeatability)
    ok, err = _within(cal.acc.bias, truth.b_acc, np.sqrt(np.diag(res.accel.cov_data))[6:9])
    assert ok, err
    assert cal.acc.sigma["bias_x"] >= SETTINGS.acc_bias_repeatability_mps2
    # the gyro bias of the session: the fit's per-session bias (its own 1σ) against the drawn one
    sd = res.gyro.sigma()
    ok, err = _within(res.gyro.bias[0], truth.b_gyro, [sd[f"session0_bias_{a}"] for a in "xyz"])
    assert ok, err
    # the σ are those of a good calibration, not a formality: the datasheet spread is 1 % scale
    assert max(cal.acc.sigma["C_xx"], cal.gyro.sigma["C_xx"]) < 0.002
    # applying it turns the raw static poses into |f| = g (the residuals it reports)
    assert np.sqrt(np.mean(res.accel.residuals**2)) < 0.01
    assert res.calibration.device_id == "0x0000CA11" and res.calibration.sessions[0]["file"] == "synthetic.h5"


def test_reference_parameters_put_a_full_accelerometer_matrix_into_the_fit_convention():
    rng = np.random.default_rng(5)
    s_acc = np.eye(3) + rng.normal(0, 0.02, (3, 3))
    s_gyro = np.eye(3) + rng.normal(0, 0.02, (3, 3))
    c_acc, c_gyro = reference_parameters(s_acc, s_gyro)
    assert np.allclose(np.tril(c_acc, -1), 0) and np.all(np.diag(c_acc) > 0)
    # same rotation for both triads: C_acc S_acc and C_gyro S_gyro are one and the same rotation
    r = c_acc @ s_acc
    assert np.allclose(r @ r.T, np.eye(3), atol=1e-12) and np.allclose(c_gyro @ s_gyro, r, atol=1e-12)


def test_two_sessions_at_different_temperatures_fit_the_bias_coefficient():
    truth = sy.draw_truth(31, temp_ref_degc=25.0)
    cold = sy.make_session(truth, 32, temp_start_degc=12.0, name="cold.h5")
    warm = sy.make_session(truth, 33, temp_start_degc=38.0, name="warm.h5")
    res = calibrate([cold, warm], SETTINGS)
    cal = res.calibration
    lo, hi = cal.temp_range_degc
    assert 11.9 <= lo <= 16.0 and 38.0 <= hi <= 41.1
    k_sd = [cal.acc.sigma[f"temp_coeff_{a}"] for a in "xyz"]
    ok, err = _within(cal.acc.bias_temp_coeff, truth.k_acc, k_sd)
    assert ok, err
    k_sd = [cal.gyro.sigma[f"temp_coeff_{a}"] for a in "xyz"]
    ok, err = _within(cal.gyro.bias_temp_coeff, truth.k_gyro, k_sd)
    assert ok, err
    # the model's bias at any temperature in range: b + k (T − T_ref) against the truth's
    for temp in (15.0, 35.0):
        want = truth.b_acc + truth.k_acc * (temp - truth.temp_ref_degc)
        got = cal.acc.bias + cal.acc.bias_temp_coeff * (temp - cal.temp_ref_degc)
        assert np.all(np.abs(got - want) < 0.01)  # m/s²: 1 mg, a tenth of the datasheet's tempco over 30 °C
    assert temperature_warning(cal, [20.0, 30.0]) is None
    assert "leaves the calibrated range" in temperature_warning(cal, [30.0, 65.0])


def test_power_on_bias_jumps_between_sessions_widen_the_temperature_coefficient():
    """Two power-ons: the biases jump by the turn-on repeatability besides following temperature. The fit
    gives each session an offset with that prior, so k's 1σ covers what two sessions cannot separate."""
    from dataclasses import replace

    truth = sy.draw_truth(35, temp_ref_degc=25.0)
    rng = np.random.default_rng(36)
    jump_a = rng.normal(0, SETTINGS.acc_bias_repeatability_mps2, 3)
    jump_g = rng.normal(0, SETTINGS.gyro_bias_repeatability_radps, 3)
    cold = sy.make_session(truth, 37, temp_start_degc=10.0, name="cold.h5")
    warm = sy.make_session(replace(truth, b_acc=truth.b_acc + jump_a, b_gyro=truth.b_gyro + jump_g), 38,
                           temp_start_degc=30.0, name="warm.h5")
    cal = calibrate([cold, warm], SETTINGS).calibration
    for tri, k_true in ((cal.acc, truth.k_acc), (cal.gyro, truth.k_gyro)):
        ok, err = _within(tri.bias_temp_coeff, k_true, [tri.sigma[f"temp_coeff_{a}"] for a in "xyz"])
        assert ok, err
    # the scale and misalignment are shared by both power-ons and still recovered
    ok, err = _within(cal.acc.matrix, truth.c_acc, _sigma_matrix(cal.acc))
    assert ok, err


def test_one_session_without_temperature_span_fits_no_coefficient():
    truth = sy.draw_truth(41)
    res = calibrate([sy.make_session(truth, 42, temp_rise_degc=1.0)], SETTINGS)
    assert not res.calibration.acc.bias_temp_coeff.any() and res.calibration.temp_range_degc is None
    assert any("no bias temperature coefficient" in w for w in res.warnings)


def test_too_few_poses_is_a_one_line_error_saying_what_to_add():
    truth = sy.draw_truth(51, with_temp=False)
    ses = sy.make_session(truth, 52, motions=sy.STANDARD_MOTIONS[:5])
    with pytest.raises(InputError) as ei:
        calibrate([ses], SETTINGS)
    msg = str(ei.value)
    assert "\n" not in msg and "synthetic.h5" in msg and "found 6 static poses" in msg and "hold the boot" in msg


def test_no_rotation_about_x_names_the_axis():
    truth = sy.draw_truth(61, with_temp=False)
    ses = sy.make_session(truth, 62, motions=sy.NO_X_MOTIONS)
    with pytest.raises(InputError) as ei:
        calibrate([ses], SETTINGS)
    msg = str(ei.value)
    assert "\n" not in msg and "no rotation about the sensor's x axis" in msg and "at least twice" in msg
    # the live mode asks for what is missing instead of failing
    res = calibrate([ses], SETTINGS, require_determined=False)
    assert any(name.startswith("gyroscope C_") and name.endswith("x") for name, *_ in res.undetermined)


def test_sessions_of_two_devices_are_refused():
    truth = sy.draw_truth(71, with_temp=False)
    a = sy.make_session(truth, 72, device_id="0x00000001", name="a.h5")
    b = sy.make_session(truth, 73, device_id="0x00000002", name="b.h5")
    with pytest.raises(InputError, match="different devices"):
        calibrate([a, b], SETTINGS)


def test_fit_does_not_modify_the_session_arrays():
    truth = sy.draw_truth(81, with_temp=False)
    ses = sy.make_session(truth, 82)
    before = [x.copy() for x in (ses.t_s, ses.acc, ses.gyro, ses.temp_degc)]
    calibrate([ses], SETTINGS)
    for x, y in zip(before, (ses.t_s, ses.acc, ses.gyro, ses.temp_degc)):
        assert np.array_equal(x, y)


def test_gyro_scale_is_relative_to_the_device_clock():
    """A clock running fast by ε stretches every integrated angle by 1 + ε: the fitted C absorbs it (the
    recordings of the same boot carry the same clock), so C_gyro = S⁻¹ / (1 + ε)."""
    truth = sy.draw_truth(91, with_temp=False)
    ses = sy.make_session(truth, 92)
    eps = 2e-3
    ses.t_s = ses.t_s * (1 + eps)
    res = calibrate([ses], SETTINGS)
    sd = _sigma_matrix(res.calibration.gyro)
    ok, err = _within(np.diag(res.calibration.gyro.matrix), np.diag(truth.c_gyro) / (1 + eps), np.diag(sd))
    assert ok, err
    assert math.isfinite(res.calibration.gyro.residual_rms)
