"""Calibration and initial alignment: WGS-84 normal gravity, still period, roll/pitch, gyro bias, accel file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bootnav.core.rotations import quat_from_euler_zyx
from bootnav.errors import InputError
from bootnav.postproc.calibration import (
    CalibrationSettings,
    apply_accel_calibration,
    find_still_period,
    initial_alignment,
    load_accel_calibration,
    normal_gravity,
)


def test_normal_gravity_matches_wgs84_equator_and_pole():
    # TR8350.2 table 3.4: γ_e = 9.7803253359, γ_p = 9.8321849378 m/s² (given to 10 decimals)
    assert normal_gravity(0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert normal_gravity(90.0) == pytest.approx(9.8321849378, abs=1e-9)
    assert normal_gravity(-90.0) == pytest.approx(normal_gravity(90.0), abs=1e-12)


def test_free_air_correction_is_about_minus_3_086e_6_per_metre():
    # textbook free-air gradient 0.3086 mGal/m = 3.086e-6 s^-2 (first order); 1 km changes g by ~3.09 mm/s²
    d = normal_gravity(45.0, 1000.0) - normal_gravity(45.0, 0.0)
    assert d == pytest.approx(-3.086e-3, rel=2e-3)
    with pytest.raises(ValueError):
        normal_gravity(91.0)


def _rest_then_walk(roll, pitch, *, rest_s=3.0, fs=200.0, g=9.80665, bias=(0.01, -0.02, 0.005), seed=1):
    rng = np.random.default_rng(seed)
    n_rest, n_move = int(rest_s * fs), int(4 * fs)
    t = np.arange(n_rest + n_move) / fs
    c_nb = Rotation.from_euler("ZYX", [0.0, pitch, roll]).as_matrix()
    f_rest = c_nb.T @ np.array([0.0, 0.0, g])
    acc = np.tile(f_rest, (t.size, 1)) + rng.normal(0, 0.02, (t.size, 3))
    gyro = np.tile(np.asarray(bias), (t.size, 1)) + rng.normal(0, 0.003, (t.size, 3))
    tm = t[n_rest:] - t[n_rest]
    acc[n_rest:, 0] += 15 * np.sin(2 * np.pi * tm)
    gyro[n_rest:, 1] += 4 * np.sin(2 * np.pi * tm)
    return t, acc, gyro, f_rest, n_rest


def test_alignment_recovers_roll_pitch_exactly_from_rotated_gravity():
    for roll, pitch in [(0.3, -0.2), (-2.5, 0.7), (1.2, 1.4), (math.pi - 0.1, -1.5)]:
        q = quat_from_euler_zyx(roll, pitch, 0.0)
        c_nb = Rotation.from_quat([q[1], q[2], q[3], q[0]]).as_matrix()
        f_b = c_nb.T @ np.array([0.0, 0.0, 9.81])
        t = np.arange(400) / 200.0
        st = initial_alignment(t, np.tile(f_b, (400, 1)), np.zeros((400, 3)), CalibrationSettings(), 9.81)
        assert st.roll_rad == pytest.approx(roll, abs=1e-12)
        assert st.pitch_rad == pytest.approx(pitch, abs=1e-12)
        c = Rotation.from_quat([st.q_nb[1], st.q_nb[2], st.q_nb[3], st.q_nb[0]]).as_matrix()
        np.testing.assert_allclose(c @ f_b, [0, 0, 9.81], atol=1e-12)  # levelled: specific force points up
        assert st.warnings == []


def test_still_period_and_gyro_bias_from_it():
    t, acc, gyro, f_rest, n_rest = _rest_then_walk(0.2, 0.1)
    still = find_still_period(t, acc, gyro)
    assert still is not None and still.start == 0
    # ends within one still window (0.25 s) of the true start of motion
    assert abs(still.stop - n_rest) <= 0.25 * 200
    st = initial_alignment(t, acc, gyro)
    # bias: mean of n >= 500 samples of σ = 0.003 rad/s noise -> 5σ/sqrt(n) = 7e-4 rad/s
    np.testing.assert_allclose(st.gyro_bias_b, [0.01, -0.02, 0.005], atol=7e-4)
    # attitude: mean of 0.02 m/s² noise over >= 500 samples -> < 1e-3 rad
    assert st.roll_rad == pytest.approx(0.2, abs=1e-3) and st.pitch_rad == pytest.approx(0.1, abs=1e-3)
    assert not st.warnings


def test_warning_when_no_still_period():
    t, acc, gyro, _, _ = _rest_then_walk(0.0, 0.0, rest_s=0.0)
    st = initial_alignment(t, acc, gyro)
    assert st.still is None
    np.testing.assert_array_equal(st.gyro_bias_b, 0.0)
    assert len(st.warnings) == 1 and "no initial still period" in st.warnings[0]


def test_accel_calibration_file_applied_with_documented_formula(tmp_path):
    bias = [0.1, -0.2, 0.3]
    mat = [[1.01, 0.002, 0.0], [0.0, 0.99, -0.003], [0.001, 0.0, 1.02]]
    p = tmp_path / "acc.json"
    p.write_text(json.dumps({"bias_mps2": bias, "matrix": mat}))
    raw = np.array([[0.0, 0.0, 9.81], [1.0, 2.0, 3.0]])
    out = apply_accel_calibration(raw, p)
    expect = np.array([np.array(mat) @ (r - np.array(bias)) for r in raw])  # f = M (f_raw − b)
    np.testing.assert_allclose(out, expect, rtol=0, atol=1e-12)
    bad = tmp_path / "bad.json"
    bad.write_text('{"bias_mps2": [1, 2], "matrix": [[1,0,0],[0,1,0],[0,0,1]]}')
    with pytest.raises(InputError, match="bad.json"):
        load_accel_calibration(bad)
    broken = tmp_path / "broken.json"
    broken.write_text("{not json")
    with pytest.raises(InputError, match="line 1"):
        load_accel_calibration(broken)


def test_gyro_bias_from_the_quiet_core_ignores_a_small_motion_inside_the_still_period():
    """A 0.4 s foot shift (0.04 rad/s rate, under the still thresholds) inside a 3 s rest: the quiet-core
    mean recovers the bias to the noise level (σ = 0.003 rad/s over >= 200 samples: 5σ/sqrt(200) = 1.1e-3),
    the plain mean of the whole period would be off by ~0.04 × 0.4 / 3 = 5e-3 rad/s."""
    t, acc, gyro, f_rest, n_rest = _rest_then_walk(0.0, 0.0)
    k = int(1.2 * 200)
    gyro[k:k + 80, 2] += 0.04 * np.sin(np.linspace(0, np.pi, 80)) * 1.57  # mean 0.04 rad/s over 0.4 s
    still = find_still_period(t, acc, gyro)
    assert still is not None and still.start == 0 and still.stop > k + 80  # the shift passes the still test
    st = initial_alignment(t, acc, gyro)
    np.testing.assert_allclose(st.gyro_bias_b, [0.01, -0.02, 0.005], atol=1.1e-3)
    plain = initial_alignment(t, acc, gyro, CalibrationSettings(still_quiet_ratio=0.0))
    assert abs(plain.gyro_bias_b[2] - 0.005) > 3e-3


def test_stance_detection_does_not_see_a_gyro_turn_on_bias():
    """A constant gyro bias (an MPU6050's turn-on ZRO, up to ±20 °/s) is measured at the initial rest and
    taken out of what the stance detector sees (``stance_reference``): the stance mask is the unbiased one
    (the added bias comes back to within the standard error of a still-period mean, σ/√N ≈ 1e-4 rad/s for the
    datasheet noise over >= 1 s at 200 Hz: a window at the quiet-core limit can flip), where the raw rate
    would change it."""
    import bootnav
    from bootnav.postproc.calibration import stance_reference
    from bootnav.postproc.detectors import DetectorSettings, detect_stance
    from bootnav.simulator import simulate

    res = simulate("mixed-walk", seed=2, profile="mpu6050-noise-only", duration_s=30.0)
    t, acc, gyro = res.t_s, res.acc_mps2, res.gyro_radps
    bias = np.radians([12.0, -8.0, 15.0])
    a = bootnav.process(t, acc, gyro)
    b = bootnav.process(t, acc, gyro + bias)
    np.testing.assert_array_equal(a.stance, b.stance)
    init = b.raw.init
    np.testing.assert_allclose(stance_reference(init, 9.8)[0] - a.raw.init.gyro_bias_b, bias, rtol=0, atol=1e-4)
    raw = detect_stance(t, acc, gyro + bias, DetectorSettings(), b.raw.gravity_mps2).stance
    assert np.count_nonzero(raw != a.stance) > 0.01 * len(t)  # what the detector did before


def _still_period_over_whole_record(t, acc, gyro, s, min_duration_s, gravity=9.80665):
    """find_still_period's rule on the still mask of the whole record (what it computed before it looked at
    the first seconds only)."""
    from bootnav.core.runs import runs
    from bootnav.core.timebase import sample_period
    from bootnav.postproc.calibration import still_mask

    ok = still_mask(t, acc, gyro, s, gravity)
    if not ok.any():
        return None
    starts, stops = runs(ok)
    dur = t[stops - 1] - t[starts] + sample_period(t)
    good = (dur >= min_duration_s) & (t[starts] - t[0] <= s.still_search_s)
    if not good.any():
        return None
    i = int(np.flatnonzero(good)[0])
    stop = min(int(stops[i]), int(np.searchsorted(t, t[starts[i]] + s.max_still_s)))
    return slice(int(starts[i]), max(stop, int(starts[i]) + 1))


@pytest.mark.parametrize("rest_s, lead_s, search_s, max_s", [
    (3.0, 0.0, 10.0, 30.0),  # rest at the start
    (45.0, 0.0, 10.0, 30.0),  # rest longer than the prefix looked at
    (2.0, 9.9, 10.0, 30.0),  # rest starting at the end of the search window
    (2.0, 10.5, 10.0, 30.0),  # too late: none
    (0.2, 0.0, 1.0, 0.3),  # shorter than min_still_s; max_still_s < min_still_s
    (40.5, 0.0, 10.0, 0.5),
    (1.5, 0.7, 1.0, 0.3),  # found only with min_still_s counted past search + max_still_s
])
def test_still_period_from_the_first_seconds_is_the_whole_records(rest_s, lead_s, search_s, max_s):
    # the still test over the first still_search_s + max_still_s (+ two windows) gives the period of the
    # whole record, exactly: moving means of a prefix equal the whole record's away from the prefix's end
    rng = np.random.default_rng(7)
    fs, total_s = 200.0, 80.0
    t = np.arange(int(total_s * fs)) / fs + 12.5
    acc = np.tile([0.1, -0.2, 9.79], (t.size, 1)) + rng.normal(0, 0.02, (t.size, 3))
    gyro = rng.normal(0, 0.003, (t.size, 3))
    move = (t - t[0] < lead_s) | (t - t[0] >= lead_s + rest_s)
    acc[move, 0] += 12 * np.sin(2 * np.pi * t[move])
    gyro[move, 2] += 3 * np.sin(2 * np.pi * 0.9 * t[move])
    s = CalibrationSettings(still_search_s=search_s, max_still_s=max_s)
    for min_s in (0.5, 0.1, 1.2):
        expected = _still_period_over_whole_record(t, acc, gyro, s, min_s)
        assert find_still_period(t, acc, gyro, min_duration_s=min_s, settings=s) == expected


def test_tilt_bias_takes_a_slow_steady_turn_out_of_the_horizontal_gyro_bias():
    """A start that passes the still test while the foot turns steadily at 0.03 rad/s about a horizontal axis
    (koroglu run 34's kind of start): its rate has no more variance than rest, so the quiet-core mean takes the
    turn for bias (off by 0.03 rad/s). The accelerometer sees the tilt: ``tilt_bias`` recovers the bias at right
    angles to gravity to the accelerometer's noise (σ_a = 0.01 m/s² over 400 samples spanning 2 s: the
    slope's σ is 0.01 / (√400 · 0.58 s) / g ≈ 9e-5 rad/s; tolerance 1e-3 rad/s covers the gyro noise's
    integral as well), and keeps the quiet core's part about gravity (not seen by a tilt)."""
    from scipy.spatial.transform import Rotation as R

    from bootnav.postproc.calibration import still_tilt_bias

    rng = np.random.default_rng(7)
    fs, dur, g = 200.0, 2.0, 9.80665
    t = np.arange(int(dur * fs)) / fs
    r0 = R.from_euler("xyz", [0.2, -0.6, 0.1])  # a tilted mount, as koroglu's
    up_b = r0.inv().apply([0.0, 0.0, 1.0])
    axis = np.cross(up_b, [0.0, 1.0, 0.0])
    axis /= np.linalg.norm(axis)  # horizontal, in the body frame
    rate = 0.03
    att = r0 * R.from_rotvec(np.outer(rate * t, axis))  # body -> nav; the body turns about `axis`
    f_b = att.inv().apply([0.0, 0.0, g]) + rng.normal(0.0, 0.01, (t.size, 3))
    bias = np.array([0.004, -0.002, 0.006])
    w_b = rate * axis + bias + rng.normal(0.0, 1e-3, (t.size, 3))
    still = find_still_period(t, f_b, w_b)
    assert still is not None and still.stop - still.start > 0.9 * t.size  # the turn passes as rest
    plain = initial_alignment(t, f_b, w_b).gyro_bias_b
    fixed = initial_alignment(t, f_b, w_b, CalibrationSettings(tilt_bias=True)).gyro_bias_b

    def horizontal(v):
        return v - (v @ up_b) * up_b

    assert np.linalg.norm(horizontal(plain - bias)) > 0.02  # the turn, taken for bias
    np.testing.assert_allclose(horizontal(fixed), horizontal(bias), atol=1e-3)
    assert abs((fixed - plain) @ up_b) < 1e-3  # the part about gravity stays the quiet core's
    # the function alone, on the whole period, gives the same
    np.testing.assert_allclose(still_tilt_bias(t, f_b, w_b, still, plain), fixed, atol=1e-12)
