"""Heading methods on synthetic data with known truth (no dataset here has a magnetometer), and the
foot-mounted INS -> steps table conversion."""

import numpy as np
import pytest

from bootnav.postproc.pdr.foot_ins import steps_from_foot_ins
from bootnav.postproc.pdr.heading.complementary import complementary_heading
from bootnav.postproc.pdr.heading.gyro import gyro_heading
from bootnav.postproc.pdr.heading.mag_calibration import ellipse_fit_2d, ellipsoid_fit
from bootnav.postproc.pdr.heading.magnetometer import tilt_compensated_heading

# Earth field in ENU (x east, y north, z up), uT: 20 north, 40 down (mid-latitude)
B_N = np.array([0.0, 20.0, -40.0])


def rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


@pytest.mark.parametrize("bearing_deg", [0, 30, 139.581, 200, 300])
@pytest.mark.parametrize("pitch_deg,roll_deg", [(0, 0), (25, -10), (-40, 30)])
def test_tilt_compensated_heading_recovers_bearing(bearing_deg, pitch_deg, roll_deg):
    # body->nav rotation: yaw (bearing is clockwise, yaw counter-clockwise) then pitch, roll
    C_nb = rot_z(-np.radians(bearing_deg)) @ rot_x(np.radians(pitch_deg)) @ rot_y(np.radians(roll_deg))
    mag_b = C_nb.T @ B_N
    up_b = C_nb.T @ np.array([0, 0, 1.0])
    h = np.degrees(tilt_compensated_heading(mag_b, up_b))[0]
    assert (h - bearing_deg + 180) % 360 - 180 == pytest.approx(0.0, abs=1e-9)


def test_untilted_formula_is_wrong_when_tilted():
    # why tilt compensation: a 40 deg pitch with the plain 2-axis arctangent errs by degrees
    C_nb = rot_z(-np.radians(60)) @ rot_x(np.radians(40))
    mag_b = C_nb.T @ B_N
    plain = np.degrees(np.arctan2(-mag_b[0], mag_b[1]))
    assert abs((plain - 60 + 180) % 360 - 180) > 5


def test_ellipsoid_fit_removes_hard_and_soft_iron():
    rng = np.random.default_rng(0)
    v = rng.standard_normal((500, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    field = 45.0 * v
    A = np.array([[1.2, 0.1, 0.0], [0.1, 0.8, 0.05], [0.0, 0.05, 1.1]])
    meas = field @ A.T + np.array([12.0, -7.0, 3.0])
    cal = ellipsoid_fit(meas)
    n = np.linalg.norm(cal.apply(meas), axis=1)
    assert np.std(n) / np.mean(n) < 1e-6
    assert np.allclose(cal.offset, [12.0, -7.0, 3.0], atol=1e-6)


def test_ellipse_fit_2d_heading_error_removed():
    a = np.radians(np.arange(0, 360, 2.0))
    hx = 30 * np.cos(a) * 1.3 + 8.0
    hy = 30 * np.sin(a) * 0.8 - 5.0
    cal = ellipse_fit_2d(hx, hy)
    c = cal.apply(np.c_[hx, hy, np.zeros_like(hx)])
    ang = np.arctan2(c[:, 1], c[:, 0])
    assert np.max(np.abs(np.angle(np.exp(1j * (ang - a))))) < 1e-9


def test_gyro_heading_integrates_rate_about_gravity():
    fs, T, rate = 100.0, 20.0, np.radians(9.0)  # 9 deg/s counter-clockwise = left turn
    t = np.arange(0, T, 1 / fs)
    tilt = rot_x(np.radians(30))  # sensor tilted 30 deg: the rate must be projected on gravity
    up_b = tilt.T @ np.array([0, 0, 1.0])
    acc = np.tile(9.81 * up_b, (t.size, 1))
    gyro = np.tile(rate * up_b, (t.size, 1))
    tt, psi = gyro_heading(t, gyro, acc, psi0_rad=np.radians(90))
    assert np.degrees(psi[-1]) == pytest.approx(90 - 9.0 * t[-1], abs=1e-6)  # bearing decreases


def test_complementary_removes_gyro_drift_and_mag_noise():
    rng = np.random.default_rng(2)
    t = np.arange(0, 600, 0.02)
    truth = 0.5 * np.sin(2 * np.pi * t / 60)
    psi_g = truth + 0.01 * t  # 0.01 rad/s bias -> 6 rad drift
    psi_m = truth + 0.2 * rng.standard_normal(t.size)
    fused = complementary_heading(t, psi_g, psi_m, tau_s=10.0)
    err = np.abs(np.angle(np.exp(1j * (fused - truth))))[500:-500]
    assert err.max() < 0.15 and np.sqrt(np.mean(err ** 2)) < 0.2 / 3


def test_steps_from_foot_ins():
    # strides of 1.4 m at bearing 30 deg; stance 0.3 s, swing 0.7 s at 100 Hz
    fs, n_str, L, h = 100.0, 8, 1.4, np.radians(30)
    pos, stance = [], []
    for k in range(n_str + 1):
        p = k * L * np.array([np.sin(h), np.cos(h), 0])
        pos += [p] * 30
        stance += [True] * 30
        if k < n_str:
            s = np.linspace(0, 1, 70)[:, None]
            pos += list(p + s * L * np.array([np.sin(h), np.cos(h), 0]) + np.c_[0 * s, 0 * s, 0.1 * np.sin(np.pi * s)])
            stance += [False] * 70
    pos = np.array(pos)
    t = np.arange(len(pos)) / fs
    out = steps_from_foot_ins(t, pos, np.array(stance))
    assert out["length_m"].size == n_str
    assert np.allclose(out["length_m"], L, atol=1e-9)
    assert np.allclose(out["yaw_enu_rad"], np.pi / 2 - h, atol=1e-9)  # bearing 30 deg = 60 deg from east
    assert out["x_m"][-1] == pytest.approx(n_str * L * np.sin(h))
    assert np.allclose(out["t_s"], np.arange(1, n_str + 1) * 1.0)  # stance starts (initial contacts)


def test_steps_from_foot_ins_merges_split_stance():
    # a stance phase split in two by a noisy detector is one contact, not a 2-cm stride
    t = np.arange(300) / 100.0
    pos = np.zeros((300, 3))
    pos[150:, 1] = 1.3  # one stride north between the two stances
    stance = np.zeros(300, bool)
    stance[0:40] = stance[45:80] = True  # first stance split
    stance[150:200] = True
    out = steps_from_foot_ins(t, pos, stance)
    assert out["length_m"].tolist() == pytest.approx([1.3])
    assert out["yaw_enu_rad"][0] == pytest.approx(np.pi / 2)  # due north


def test_seed000_T14_synthetic_checkpoint_walk():
    # legs N, E, S, W of 25.37, 22.76, 28.53, 22.76 m from (49.09, 21.14) in 0.7-m steps (seed-000 T14)
    from bootnav.postproc.pdr.path import checkpoint_errors, local_path

    legs = [(0, 25.37), (90, 22.76), (180, 28.53), (270, 22.76)]
    true = np.array([[49.09, 21.14], [49.09, 46.51], [71.85, 46.51], [71.85, 17.98], [49.09, 17.98]])

    def walk_legs(bias_ew_deg):
        L, h, ends = [], [], []
        for bearing, length in legs:
            n = length / 0.7
            k = int(np.floor(n))
            L += [0.7] * k + [length - 0.7 * k]  # last, partial step makes the leg exact
            b = bearing + (bias_ew_deg if bearing in (90, 270) else 0.0)
            h += [np.radians(b)] * (k + 1)
            ends.append(len(L) - 1)
        x, y = local_path(L, h, *true[0])
        return np.c_[x, y][ends]

    assert np.max(checkpoint_errors(walk_legs(0.0), true[1:])) < 1e-9
    err = checkpoint_errors(walk_legs(-10.0), true[1:])
    # 10 deg on the E/W legs: a few metres, the same order as Table 6.3.3 (1.49, 3.29, 3.49, 1.98 m)
    assert 1.0 < err.max() < 6.0 and err[0] < 1e-9


def test_run_pdr_with_magnetometer_heading():
    from bootnav.postproc.pdr import PdrSettings, run_pdr
    from tests.test_pdr_detectors import walk

    t, acc = walk()
    bearing = np.radians(75.0)
    mag_b = np.tile(rot_z(-bearing).T @ B_N, (t.size, 1))  # level phone pointing at 75 deg (clockwise)
    res = run_pdr(t, acc, settings=PdrSettings(heading="mag", declination_deg=5.0), mag_b=mag_b)
    # the 1 m/s^2 sway of the synthetic walk leaks ~0.1 m/s^2 through the 0.3-Hz gravity low-pass:
    # a tilt of ~0.01 rad, so the bearing is good to ~1 deg
    assert np.allclose(np.degrees(res.yaw_enu_rad), 90.0 - 80.0, atol=1.0)  # bearing 80 deg = 10 deg from east
    assert res.heading_source == "mag"
