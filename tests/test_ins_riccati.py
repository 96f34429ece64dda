"""Riccati ("paper") mode: eq. 4–5 gain, detectability report, discrete conversion, filter mode."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from bootnav.postproc.ins import FilterSettings, run_filter, steady_state_gain
from bootnav.postproc.ins.filter import delay_zupt_onsets
from bootnav.postproc.ins.riccati import full_pv_model, paper_zupt_gain, zupt_observable_model
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
    A, C, W, V, _ = zupt_observable_model(s.sigma_acc_mps2, s.sigma_gyro_radps, s.sigma_zupt_mps, 9.81, 0.005)
    zg = paper_zupt_gain(s, 9.81, 0.005)
    assert zg.report.stabilising
    assert np.all(zg.report.closed_loop_eigenvalues.real < 0)
    K = zg.report.gain
    for dt in (0.001, 0.005, 0.03):
        # ẋ = K (z − C x), x(0) = 0, z constant: Van Loan block exponential gives x(Δt) = M z
        n = K.shape[0]
        big = np.zeros((n + 3, n + 3))
        big[:n, :n] = -K @ C
        big[:n, n:] = K
        M = scipy.linalg.expm(big * dt)[:n, n:]
        Kd = zg.discrete(dt)
        assert np.allclose(Kd[3:8], M, atol=1e-12)
        assert np.all(Kd[[0, 1, 2, 8]] == 0)  # position and yaw never corrected (open loop)


def test_riccati_mode_pins_velocity_in_stance_and_runs_the_9_state_model():
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
    sol15 = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, FilterSettings(mode="riccati", n_states=15))
    assert sol15.gyro_bias_b is None and any("9-state" in m for m in sol15.info["warnings"])
    assert np.array_equal(sol15.pos_n, sol.pos_n)
    # ZARU (on by default) needs the gyro-bias states: the paper mode runs without it and says so
    assert FilterSettings().zaru and sol.info["zaru"] is False
