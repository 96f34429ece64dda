"""A tiny synthetic foot-mounted walk with exact truth (for the bootnav.postproc.ins tests and benchmarks/bench_filter.py).

The foot alternates stance (still on the floor) and swing. In each swing of duration T_sw (s = τ/T_sw ∈ [0,1])
it moves a stride L along the current heading with smooth profiles whose velocity and acceleration vanish
at both ends, pitches up and down, turns by Δψ and climbs dz:

    along-track x(s) = L (s − sin 2πs / 2π),   height h(s) = dz (s − sin 2πs / 2π) + h_max (1 − cos 2πs)² / 4,
    pitch θ(s) = θ_max (1 − cos 2πs) / 2,       yaw ψ(s) = ψ₀ + Δψ (s − sin 2πs / 2π),   roll 0.

The IMU outputs are exact: f_b = C_nbᵀ (a_n + [0, 0, g]) and ω_b = [−ψ̇ sin θ, θ̇, ψ̇ cos θ] (ZYX Euler rates,
roll 0); optional seeded white noise and constant biases are added. The tests in this file check that the
generator is self-consistent (the numerical derivative of the truth equals the analytic rates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bootnav.core.rotations import quat_from_euler_zyx


@dataclass
class SyntheticWalk:
    t_s: np.ndarray
    acc_b: np.ndarray
    gyro_b: np.ndarray
    stance: np.ndarray
    pos_n: np.ndarray
    vel_n: np.ndarray
    q_nb: np.ndarray
    gravity: float
    acc_bias_b: np.ndarray
    gyro_bias_b: np.ndarray


class TruthInit:
    """Duck-typed initial state (q_nb, gyro_bias_b) as run_filter accepts."""

    def __init__(self, q_nb, gyro_bias_b):
        self.q_nb = np.asarray(q_nb, float)
        self.gyro_bias_b = np.asarray(gyro_bias_b, float)


def _profile(s):
    """(value, d/ds, d²/ds²) of s − sin(2πs)/2π."""
    w = 2 * math.pi
    return s - np.sin(w * s) / w, 1 - np.cos(w * s), w * np.sin(w * s)


def synthetic_walk(n_strides=20, rate_hz=200.0, stance_s=0.5, swing_s=0.6, stride_m=1.4, turn_rad=0.0,
                   climb_m=0.0, pitch_max_rad=0.6, lift_m=0.12, acc_noise=0.0, gyro_noise=0.0,
                   acc_bias=(0.0, 0.0, 0.0), gyro_bias=(0.0, 0.0, 0.0), gravity=9.81, seed=0,
                   initial_still_s=1.0) -> SyntheticWalk:
    dt = 1.0 / rate_hz
    period = stance_s + swing_s
    total = initial_still_s + n_strides * period + stance_s
    t = np.arange(int(round(total / dt)) + 1) * dt
    tau = t - initial_still_s
    k = np.clip(np.floor(tau / period), 0, n_strides - 1).astype(int)
    local = tau - k * period - stance_s  # time into the swing of stride k
    in_swing = (tau >= 0) & (local > 0) & (local < swing_s) & (tau < n_strides * period)
    done = np.where(tau < 0, 0, np.where(local >= swing_s, k + 1, k))  # completed strides
    done = np.where(tau >= n_strides * period, n_strides, done)
    s = np.where(in_swing, local / swing_s, 0.0)
    P, dP, ddP = _profile(s)
    P, dP, ddP = np.where(in_swing, P, 0.0), np.where(in_swing, dP, 0.0), np.where(in_swing, ddP, 0.0)
    w = 2 * math.pi
    yaw0 = done * turn_rad
    yaw = yaw0 + turn_rad * P
    yaw_d = turn_rad * dP / swing_s
    pitch = np.where(in_swing, pitch_max_rad * (1 - np.cos(w * s)) / 2, 0.0)
    pitch_d = np.where(in_swing, pitch_max_rad * w * np.sin(w * s) / 2 / swing_s, 0.0)
    # stance positions: the start of stride k; headings of earlier strides are fixed
    starts = np.zeros((n_strides + 1, 3))
    for i in range(n_strides):
        h = i * turn_rad
        # the along-track direction of stride i follows the heading during the swing; integrate it exactly:
        # x'(s) = L P'(s) (cos ψ(s), sin ψ(s)); done numerically with a fine grid (truth precision ~1e-12)
        ss = np.linspace(0, 1, 20001)
        pp, dp, _ = _profile(ss)
        hh = h + turn_rad * pp
        dx = stride_m * np.trapezoid(dp * np.cos(hh), ss)
        dy = stride_m * np.trapezoid(dp * np.sin(hh), ss)
        starts[i + 1] = starts[i] + [dx, dy, climb_m]
    # swing positions: integrate the along-track velocity numerically per sample (cumulative trapezoid on
    # a 50x finer grid), vertical analytic
    pos = starts[done].copy()
    vel = np.zeros_like(pos)
    acc_n = np.zeros_like(pos)
    sw = np.flatnonzero(in_swing)
    if sw.size:
        sk = s[sw]
        fine = np.linspace(0, 1, 50 * int(swing_s * rate_hz) + 1)
        fp, fdp, _ = _profile(fine)
        fh = turn_rad * fp
        ux, uy = fdp * np.cos(fh), fdp * np.sin(fh)
        cx = np.concatenate([[0], np.cumsum(0.5 * (ux[1:] + ux[:-1]) * np.diff(fine))])
        cy = np.concatenate([[0], np.cumsum(0.5 * (uy[1:] + uy[:-1]) * np.diff(fine))])
        ks = k[sw]
        h0 = ks * turn_rad
        lx = stride_m * np.interp(sk, fine, cx)
        ly = stride_m * np.interp(sk, fine, cy)
        pos[sw, 0] = starts[ks, 0] + np.cos(h0) * lx - np.sin(h0) * ly
        pos[sw, 1] = starts[ks, 1] + np.sin(h0) * lx + np.cos(h0) * ly
        hz = climb_m * P[sw] + lift_m * (1 - np.cos(w * sk)) ** 2 / 4
        pos[sw, 2] = starts[ks, 2] + hz
        v_along = stride_m * dP[sw] / swing_s
        a_along = stride_m * ddP[sw] / swing_s**2
        yw, ywd = yaw[sw], yaw_d[sw]
        vel[sw, 0] = v_along * np.cos(yw)
        vel[sw, 1] = v_along * np.sin(yw)
        vel[sw, 2] = (climb_m * dP[sw] + lift_m * (1 - np.cos(w * sk)) * np.sin(w * sk) * w / 2) / swing_s
        acc_n[sw, 0] = a_along * np.cos(yw) - v_along * np.sin(yw) * ywd
        acc_n[sw, 1] = a_along * np.sin(yw) + v_along * np.cos(yw) * ywd
        acc_n[sw, 2] = (climb_m * ddP[sw] + lift_m * w * w / 2 * (np.sin(w * sk) ** 2
                                                                  + (1 - np.cos(w * sk)) * np.cos(w * sk))) / swing_s**2
    q = quat_from_euler_zyx(0.0, pitch, yaw)
    cp, sp, cy, sy = np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    # C_nb = Rz(yaw) Ry(pitch); f_b = C_nbᵀ (a_n + g_up)
    fn = acc_n + [0.0, 0.0, gravity]
    fxy = cy * fn[:, 0] + sy * fn[:, 1]  # Rz(yaw)ᵀ
    fyy = -sy * fn[:, 0] + cy * fn[:, 1]
    acc_b = np.stack([cp * fxy - sp * fn[:, 2], fyy, sp * fxy + cp * fn[:, 2]], axis=1)
    gyro_b = np.stack([-yaw_d * sp, pitch_d, yaw_d * cp], axis=1)
    rng = np.random.default_rng(seed)
    acc_b = acc_b + np.asarray(acc_bias) + acc_noise * rng.standard_normal(acc_b.shape)
    gyro_b = gyro_b + np.asarray(gyro_bias) + gyro_noise * rng.standard_normal(gyro_b.shape)
    return SyntheticWalk(t, acc_b, gyro_b, ~in_swing, pos, vel, q, gravity, np.asarray(acc_bias, float),
                         np.asarray(gyro_bias, float))


def test_truth_is_self_consistent():
    """Numerical derivatives of the truth match the analytic velocity/acceleration fed to the IMU model."""
    w = synthetic_walk(n_strides=3, rate_hz=1000.0, turn_rad=0.3, climb_m=0.17)
    dt = w.t_s[1] - w.t_s[0]
    v_num = np.gradient(w.pos_n, dt, axis=0)
    assert np.abs(v_num - w.vel_n)[5:-5].max() < 2e-3  # O(dt²) central difference of ~10 m/s³ jerk
    # stance: foot still; strides have the requested length
    assert np.all(w.vel_n[w.stance] == 0)
    # specific force at rest reads +g up along body z (level foot)
    assert np.allclose(w.acc_b[0], [0, 0, 9.81])
    # rotating f_b back with the truth attitude gives a_n + g_up, whose integral is the velocity
    from bootnav.postproc.ins.quaternion import quat_to_rotmat

    fn = np.array([quat_to_rotmat(q) @ f for q, f in zip(w.q_nb, w.acc_b)])
    a_num = np.gradient(w.vel_n, dt, axis=0)
    assert np.abs(fn[5:-5] - [0, 0, 9.81] - a_num[5:-5]).max() < 0.05 * 9.81


def test_gyro_matches_attitude_derivative():
    """ω_b equals 2 q⁻¹ ⊗ q̇ of the truth quaternion (numerical)."""
    w = synthetic_walk(n_strides=2, rate_hz=1000.0, turn_rad=0.5)
    dt = w.t_s[1] - w.t_s[0]
    from bootnav.postproc.ins.quaternion import quat_multiply

    qd = np.gradient(w.q_nb, dt, axis=0)
    om = np.array([2 * quat_multiply(q * [1, -1, -1, -1], d)[1:] for q, d in zip(w.q_nb, qd)])
    assert np.abs(om - w.gyro_b)[5:-5].max() < 1e-2
