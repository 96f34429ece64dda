"""Riccati ("paper") mode: eq. 4–5 gain, detectability report, discrete conversion, filter mode."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from scipy.spatial.transform import Rotation

from bootnav.postproc.ins import FilterSettings, run_filter, steady_state_gain
from bootnav.postproc.ins.prepare import delay_zupt_onsets
from bootnav.postproc.ins.riccati import (full_pv_model, open_loop_durations, paper_zupt_gain,
                                         still_period_acc_bias, zupt_observable_model)
from tests.test_ins_synthetic import TruthInit, synthetic_walk


def test_velocity_only_gain_is_analytic():
    """A = 0, C = I, W = q I, V = r I: P = √(q r), K = √(q/r) = 50 s⁻¹ for q = 0.25, r = 1e-4."""
    rep = steady_state_gain(np.zeros((3, 3)), np.eye(3), 0.25 * np.eye(3), 1e-4 * np.eye(3))
    assert rep.stabilising, rep.message
    assert np.allclose(rep.P, 0.005 * np.eye(3), rtol=1e-10, atol=1e-15)
    assert np.allclose(rep.gain, 50.0 * np.eye(3), rtol=1e-10, atol=1e-9)
    assert np.allclose(rep.closed_loop_eigenvalues, -50.0)


def test_full_position_velocity_model_is_reported_not_stabilising():
    """Position is unobservable from ZUPT: eq. 5 has no stabilising solution (seed-004 §2.5)."""
    A, C, W, V, names = full_pv_model()
    rep = steady_state_gain(A, C, W, V, state_names=names)
    assert not rep.stabilising
    assert "observable subsystem" in rep.message
    assert "not stabilising" in rep.message or "no solution" in rep.message or "ill-conditioned" in rep.message


def test_observable_subsystem_is_stabilising_and_discrete_gain_is_exact_observer_integration():
    s = FilterSettings()
    A, C, W, V, names = zupt_observable_model(s.sigma_acc_mps2, s.sigma_gyro_radps, s.sigma_zupt_mps, 9.81, 0.005,
                                              s.sigma_acc_bias_rw)
    assert names[-1] == "dba_U"  # 15 states: the vertical accelerometer bias is part of the subsystem
    zg = paper_zupt_gain(s, 9.81, 0.005)
    assert zg.report.stabilising
    assert np.all(zg.report.closed_loop_eigenvalues.real < 0)
    # position from the steady-state cross-covariance: the p-o block of eq. 5 on the augmented (p, o) model,
    # 0 = E P_oo + P_po (A − K C)ᵀ (E selects δv), solved here as a Sylvester equation; K_p = P_po Cᵀ V⁻¹ = I
    P_po = scipy.linalg.solve_sylvester(np.zeros((3, 3)), (A - zg.report.gain @ C).T, -C @ zg.report.P)
    Kp = zg.report.position_gain
    assert np.allclose(Kp, P_po @ C.T @ np.linalg.inv(V), atol=1e-9)
    assert np.allclose(Kp, np.eye(3), atol=1e-9)
    K = np.vstack([Kp, zg.report.gain])
    c_nb = Rotation.from_euler("ZYX", [0.7, 0.1, -0.2]).as_matrix()
    for dt, tau in ((0.001, 0.0), (0.005, 0.8), (0.03, 0.0)):
        # ẋ = K (z − C x), x(0) = 0, z constant, x = (δp, o): Van Loan block exponential gives x(Δt) = M z
        n = K.shape[0]
        Ca = np.hstack([np.zeros((3, 3)), C])
        big = np.zeros((n + 3, n + 3))
        big[:n, :n] = -K @ Ca
        big[:n, n:] = K
        M = scipy.linalg.expm(big * dt)[:n, n:]
        Kd = zg.discrete(dt, tau, c_nb, 15)
        assert np.allclose(Kd[0:3], M[0:3] + 0.5 * tau * np.eye(3), atol=1e-12)  # + the open-loop row at onset
        assert np.allclose(Kd[3:8], M[3:8], atol=1e-12)
        assert np.allclose(Kd[9:12], np.outer(c_nb[2], M[8]), atol=1e-12)  # δb_U along the body axis now up
        assert np.all(Kd[8] == 0) and np.all(Kd[12:15] == 0)  # yaw and gyro biases never corrected


def test_open_loop_durations_and_still_period_bias():
    t = np.arange(12) * 0.1
    zupt = np.array([1, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 0], bool)
    # τ at each ZUPT run's first sample: the time since the previous run's last sample
    assert np.allclose(open_loop_durations(t, zupt), [0, 0, 0, 0, 0, 0.4, 0, 0, 0.2, 0, 0, 0])
    # a recording that starts in motion: the first run closes the interval from the first sample
    starts_moving = np.array([0, 0, 0, 1, 1, 0, 0, 1, 1, 1, 0, 0], bool)
    assert np.allclose(open_loop_durations(t, starts_moving), [0, 0, 0, 0.3, 0, 0, 0, 0.3, 0, 0, 0, 0])
    b = still_period_acc_bias([0.0, 0.6, 9.9], 9.81)
    assert np.linalg.norm([0.0, 0.6, 9.9] - b) == pytest.approx(9.81)  # the bias is along the mean force
    assert np.cross(b, [0.0, 0.6, 9.9]) == pytest.approx(np.zeros(3), abs=1e-12)


def test_riccati_mode_pins_velocity_in_stance_and_honours_n_states():
    w = synthetic_walk(n_strides=8, acc_noise=0.05, gyro_noise=0.005, seed=3)
    init = TruthInit(w.q_nb[0], np.zeros(3))
    sol = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, FilterSettings(mode="riccati", n_states=9))
    assert sol.info["riccati"]["stabilising"]
    assert sol.info["smoother"] == "none"
    # after 5 time constants of the slowest velocity pole the residual velocity is < 1 % of its start
    lam = paper_zupt_gain(FilterSettings(), w.gravity, 0.005).lam.min()
    settle = int(np.ceil(5 / lam / 0.005))
    # counted from the first ZUPT of each phase (the onset delay skips the settling start, filter.py)
    s0 = FilterSettings()
    idx = np.flatnonzero(delay_zupt_onsets(w.t_s, w.stance, s0.zupt_onset_delay_s, s0.zupt_onset_max_fraction))
    run_start = np.concatenate([[True], np.diff(idx) > 1])
    first = np.maximum.accumulate(np.where(run_start, idx, 0))
    late = idx[idx - first >= settle]
    assert late.size > 100 and np.abs(sol.vel_n[late]).max() < 0.05
    assert sol.acc_bias_b is None
    # 15 states: the vertical accelerometer bias is estimated, only along the body axis that is up in stance
    # (this walk keeps the foot level in stance: body z); the gyro biases are not corrected
    sol15 = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, FilterSettings(mode="riccati", n_states=15))
    assert np.all(sol15.gyro_bias_b == 0.0)
    up_b = Rotation.from_quat(w.q_nb[0][[1, 2, 3, 0]]).as_matrix()[2]
    moved = sol15.acc_bias_b[-1]
    assert np.linalg.norm(moved) > 0 and np.linalg.norm(np.cross(moved, up_b)) < 1e-3 * np.linalg.norm(moved) + 1e-9
    # ZARU (on by default) needs a Kalman gain: the paper mode runs without it and says so
    assert FilterSettings().zaru and sol15.info["zaru"] is False
