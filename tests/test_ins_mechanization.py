"""Strapdown mechanization (seed-004 eq. 1) against closed-form trajectories; quaternion helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.core.rotations import euler_zyx_from_quat, quat_from_euler_zyx
from bootnav.core.timebase import time_base
from bootnav.errors import InputError
from bootnav.postproc.ins.mechanization import mechanize, validate_imu
from bootnav.postproc.ins.quaternion import (
    correct_attitude,
    quat_multiply,
    quat_to_rotmat,
    rotvec_to_quat,
)

G = 9.81


def _constant_rate_truth(t, omega_b, a_n, v0_n, q0):
    """q(t) = q0 ⊗ exp(ω t / 2); p(t) = v0 t + ½ a t²; f_b = C(q)ᵀ (a_n + g_up) — exact samples."""
    q = np.array([quat_multiply(q0, rotvec_to_quat(np.asarray(omega_b) * ti)) for ti in t])
    f_n = np.asarray(a_n) + [0.0, 0.0, G]
    acc_b = np.array([quat_to_rotmat(qi).T @ f_n for qi in q])
    gyro_b = np.tile(omega_b, (len(t), 1))
    pos = np.outer(t, v0_n) + 0.5 * np.outer(t**2, a_n)
    return acc_b, gyro_b, pos, q


def test_constant_rate_and_acceleration_is_exact_on_jittered_time():
    """With constant body rate (since the start) and constant nav acceleration, point samples and the "endpoint"
    step have no truncation error: only rounding remains (≈1e-13 m over 10 s), so 1e-9 m is a tight,
    physics-free tolerance."""
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.002, 0.008, 2000))  # jittered 200 Hz-ish clock
    t -= t[0]
    q0 = quat_from_euler_zyx(0.1, -0.2, 0.7)
    omega = np.array([0.3, -0.5, 1.1])
    a_n = np.array([0.4, -0.2, 0.05])
    v0 = np.array([1.0, 0.5, 0.0])
    acc_b, gyro_b, pos_true, q_true = _constant_rate_truth(t, omega, a_n, v0, q0)
    pos, vel, q = mechanize(t, acc_b, gyro_b, q0, G, vel0_n=v0, midpoint=False)
    assert np.abs(pos - pos_true).max() < 1e-9
    assert np.abs(vel - (v0 + np.outer(t, a_n))).max() < 1e-9
    q_true *= np.sign(q_true[:, :1])  # q and −q are one rotation; the filter keeps w ≥ 0
    assert np.abs(q - q_true).max() < 1e-9
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)


def test_time_varying_acceleration_error_bound_and_first_order_convergence():
    """a_n(t) = A sin(Ωt): the rectangle rule on a(t_k) has velocity error ≤ ½ max|ȧ| T Δt and position error
    ≤ ½ max|ȧ| T² Δt (+ local terms); halving Δt halves the error (first-order scheme)."""
    A, W, T = 2.0, 2 * math.pi, 5.0
    errs = []
    for rate in (100.0, 200.0):
        dt = 1 / rate
        t = np.arange(int(T * rate) + 1) * dt
        a_n = np.stack([A * np.sin(W * t), np.zeros_like(t), 0.5 * A * np.sin(W * t)], axis=1)
        acc_b = a_n + [0.0, 0.0, G]  # level, non-rotating body
        gyro_b = np.zeros_like(acc_b)
        pos, vel, _ = mechanize(t, acc_b, gyro_b, [1, 0, 0, 0], G)
        v_true = np.stack([A / W * (1 - np.cos(W * t)), 0 * t, 0.5 * A / W * (1 - np.cos(W * t))], axis=1)
        p_true = np.stack([A / W * (t - np.sin(W * t) / W), 0 * t, 0.5 * A / W * (t - np.sin(W * t) / W)], axis=1)
        adot = A * W
        assert np.abs(vel - v_true).max() <= 0.5 * adot * T * dt
        perr = np.abs(pos - p_true).max()
        assert perr <= 0.5 * adot * T**2 * dt + adot * T * dt**2
        errs.append(perr)
    assert 1.7 < errs[0] / errs[1] < 2.3


def test_duplicate_timestamp_does_not_propagate_and_gap_is_flagged():
    t = np.array([0.0, 0.01, 0.01, 0.02, 0.2, 0.21])
    acc = np.tile([0.0, 0.0, G + 1.0], (6, 1))  # 1 m/s² up
    gyr = np.zeros((6, 3))
    pos, vel, _ = mechanize(t, acc, gyr, [1, 0, 0, 0], G)
    assert vel[2, 2] == vel[1, 2]  # dt = 0: nothing happens
    assert vel[-1, 2] == pytest.approx(0.21, abs=1e-12)
    tb = time_base(t)
    assert tb.n_duplicates == 1
    assert tb.gaps == [(4, pytest.approx(0.18))]


def test_bad_input_names_the_first_bad_sample():
    t = np.arange(10) * 0.01
    acc = np.tile([0.0, 0.0, G], (10, 1))
    gyr = np.zeros((10, 3))
    gyr[7, 1] = np.nan
    gyr[9, 0] = np.inf
    with pytest.raises(InputError, match=r"gyro_b .*sample 7 .*2 bad"):
        validate_imu(t, acc, gyr)
    t2 = t.copy()
    t2[4] = 0.0
    with pytest.raises(InputError, match="backwards at sample 4"):
        time_base(t2)
    with pytest.raises(InputError, match=r"shape \(10, 3\)"):
        validate_imu(t, acc[:, :2], gyr)


def test_quaternion_helpers():
    q = quat_from_euler_zyx(0.3, -0.4, 2.5)
    assert np.allclose(euler_zyx_from_quat(q), [0.3, -0.4, 2.5])
    c = quat_to_rotmat(q)
    assert np.allclose(c @ c.T, np.eye(3), atol=1e-15)
    # small-angle branch continuous with the exact one
    th = np.array([1e-9, -2e-9, 3e-9])
    assert np.allclose(rotvec_to_quat(th), [1, 0.5e-9, -1e-9, 1.5e-9], atol=1e-18)
    assert np.allclose(rotvec_to_quat(th * 1e3)[1:], 0.5 * th * 1e3, rtol=1e-10)
    # nav-frame correction: exp(δθ/2) ⊗ q rotates C by Rot(δθ) on the left
    d = np.array([0.01, -0.02, 0.03])
    c2 = quat_to_rotmat(correct_attitude(q, d))
    assert np.allclose(c2, quat_to_rotmat(rotvec_to_quat(d)) @ c, atol=1e-15)
