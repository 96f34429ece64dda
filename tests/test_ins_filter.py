"""ZUPT error-state filter behaviour on synthetic truth: stance velocity, static drift, accuracy, smoother,
bias estimation, bad input, bookkeeping."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.mechanization import mechanize
from tests.test_ins_synthetic import TruthInit, synthetic_walk

# MPU6050-class white noise at 200 Hz with its DLPF: ~0.05 m/s² and ~0.3 °/s per sample
ACC_NOISE, GYRO_NOISE = 0.05, 0.005
GYRO_BIAS = (0.002, -0.001, 0.003)


@pytest.fixture(scope="module")
def walk():
    return synthetic_walk(n_strides=30, turn_rad=0.2, climb_m=0.1, acc_noise=ACC_NOISE, gyro_noise=GYRO_NOISE,
                          seed=1)


def _swing_errors(w, sol):
    """RMS swing velocity error and RMS swing position error relative to the preceding stance (stride shape)."""
    last = np.maximum.accumulate(np.where(w.stance, np.arange(len(w.t_s)), 0))
    sw = ~w.stance
    ev = np.linalg.norm(sol.vel_n - w.vel_n, axis=1)[sw]
    ep = np.linalg.norm((sol.pos_n - sol.pos_n[last]) - (w.pos_n - w.pos_n[last]), axis=1)[sw]
    return np.sqrt(np.mean(ev**2)), np.sqrt(np.mean(ep**2))


def test_static_velocity_zero_and_position_drift_bounded():
    """60 s still with noise and a known gyro bias: ZUPT keeps |v| < 0.05 m/s (seed-004 R16) and the position
    within 2 cm, while the same data integrated open loop drifts by metres."""
    rng = np.random.default_rng(2)
    n = 12000
    t = np.arange(n) * 0.005
    acc = np.tile([0.0, 0.0, 9.81], (n, 1)) + ACC_NOISE * rng.standard_normal((n, 3))
    gyr = np.array(GYRO_BIAS) + GYRO_NOISE * rng.standard_normal((n, 3))
    init = TruthInit([1, 0, 0, 0], GYRO_BIAS)
    sol = run_filter(t, acc, gyr, np.ones(n, bool), init, 9.81, FilterSettings())
    assert np.abs(sol.vel_n).max() < 0.05
    assert np.abs(sol.pos_n).max() < 0.02
    p_open, _, _ = mechanize(t, acc, gyr - np.array(GYRO_BIAS), [1, 0, 0, 0], 9.81)
    assert np.abs(p_open).max() > 1.0


@pytest.mark.parametrize("n_states", [9, 15])
def test_walk_stance_velocity_and_accuracy(walk, n_states):
    """|v| in stance < 0.05 m/s (R16); end-point error < 1 % of the 42 m walked (the paper reports 2–6 %)."""
    init = TruthInit(walk.q_nb[0], np.zeros(3))
    sol = run_filter(walk.t_s, walk.acc_b, walk.gyro_b, walk.stance, init, walk.gravity,
                     FilterSettings(n_states=n_states))
    assert np.abs(sol.vel_n[walk.stance]).max() < 0.05
    dist = np.linalg.norm(np.diff(walk.pos_n[:, :2], axis=0), axis=1).sum()
    assert dist == pytest.approx(42.0, rel=1e-3)
    assert np.linalg.norm(sol.pos_n[-1] - walk.pos_n[-1]) < 0.01 * dist
    assert sol.info["n_updates"] == walk.stance.sum() - sol.info["zupt_onset_samples_skipped"]
    # position is unobservable: its sigma grows over the walk (ZUPTs only trim its velocity-correlated part)
    assert np.all(np.isfinite(sol.pos_sigma_n)) and np.all(sol.pos_sigma_n[-1] > 5 * sol.pos_sigma_n[0])


@pytest.mark.parametrize("n_states,factor", [(9, 0.9), (15, 1.0)])
def test_smoother_reduces_swing_error(walk, n_states, factor):
    """RTS over each swing/stance segment: lower swing velocity and stride-shape errors than the filter alone
    (9 states: by > 10 %; 15 states, whose bias states soak up part of the heel-strike innovation: lower).
    The error to remove is the "endpoint" strapdown step's (its specific force half a sample late against the
    attitude, a swing-long systematic error the ZUPT at the end reveals); with the default step the filter
    alone is as good on this noise-only walk (docs/tuning-log.md, "Height at low rates")."""
    init = TruthInit(walk.q_nb[0], np.zeros(3))
    common = (walk.t_s, walk.acc_b, walk.gyro_b, walk.stance, init, walk.gravity)
    filt = run_filter(*common, FilterSettings(smoother="none", n_states=n_states, strapdown="endpoint"))
    smooth = run_filter(*common, FilterSettings(smoother="rts", n_states=n_states, strapdown="endpoint"))
    ev_f, ep_f = _swing_errors(walk, filt)
    ev_s, ep_s = _swing_errors(walk, smooth)
    assert ev_s < factor * ev_f
    assert ep_s < factor * ep_f
    assert smooth.info["smoother_segments"] >= 30
    # segment ends are the filtered estimate: the smoother never moves the last sample of a stance phase
    ends = np.flatnonzero(walk.stance[:-1] & ~walk.stance[1:])
    assert np.abs(smooth.pos_n[ends] - filt.pos_n[ends]).max() < 1e-12


def test_zaru_estimates_gyro_bias():
    """15 states + ZARU with its σ set to the simulated gyro noise: the bias estimate is consistent with the
    filter's own uncertainty (|error| < 3σ from the final P) and that σ is well below the bias itself."""
    w = synthetic_walk(n_strides=30, turn_rad=0.2, acc_noise=ACC_NOISE, gyro_noise=GYRO_NOISE,
                       gyro_bias=GYRO_BIAS, seed=4)
    init = TruthInit(w.q_nb[0], np.zeros(3))
    sol = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity,
                     FilterSettings(n_states=15, zaru=True, sigma_zaru_radps=GYRO_NOISE))
    sigma = np.array(sol.info["final_state_sigma"][12:15])
    assert np.all(sigma < 0.5 * np.abs(GYRO_BIAS))
    assert np.all(np.abs(sol.gyro_bias_b[-1] - GYRO_BIAS) < 3 * sigma)
    no_zaru = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, FilterSettings(n_states=15, zaru=False))
    assert np.linalg.norm(sol.pos_n[-1] - w.pos_n[-1]) < np.linalg.norm(no_zaru.pos_n[-1] - w.pos_n[-1])


def test_bad_input_and_settings_give_clear_errors(walk):
    init = SimpleNamespace(q_nb=np.array([1.0, 0, 0, 0]), gyro_bias_b=np.zeros(3))  # duck typing
    t, acc, gyr, st = walk.t_s[:200], walk.acc_b[:200].copy(), walk.gyro_b[:200], walk.stance[:200]
    acc[123, 2] = np.nan
    with pytest.raises(InputError, match="acc_b has a non-finite value .* sample 123"):
        run_filter(t, acc, gyr, st, init, 9.81, FilterSettings())
    with pytest.raises(InputError, match="stance must have shape"):
        run_filter(t, walk.acc_b[:200], gyr, st[:10], init, 9.81, FilterSettings())
    with pytest.raises(InputError, match="gravity"):
        run_filter(t, walk.acc_b[:200], gyr, st, init, 1.0, FilterSettings())
    with pytest.raises(InputError, match="q_nb"):
        run_filter(t, walk.acc_b[:200], gyr, st, SimpleNamespace(q_nb=[0, 0, 0, 0], gyro_bias_b=None), 9.81)
    for bad, msg in ((dict(n_states=12), "n_states"), (dict(sigma_zupt_mps=0.0), "sigma_zupt_mps"),
                     (dict(zupt_lever_arm_m=-0.1), "zupt_lever_arm_m"), (dict(heading_aid="magic"), "heading_aid")):
        with pytest.raises(ValueError, match=msg):
            run_filter(t, walk.acc_b[:200], gyr, st, init, 9.81, FilterSettings(**bad))


def test_no_stance_warns_and_progress_is_reported_a_few_times(walk):
    init = TruthInit(walk.q_nb[0], np.zeros(3))
    calls = []
    sol = run_filter(walk.t_s, walk.acc_b, walk.gyro_b, np.zeros(len(walk.t_s), bool), init, walk.gravity,
                     FilterSettings(), progress=calls.append)
    assert any("no stance" in m for m in sol.info["warnings"])
    assert 1 <= len(calls) <= 11 and calls[-1] == 1.0 and calls == sorted(calls)
    assert sol.info["n_updates"] == 0
    assert sol.info["settings"]["sigma_acc_mps2"] == FilterSettings().sigma_acc_mps2
    import json

    json.dumps(sol.info)  # info is saved with the results


def test_smoother_memory_bound_splits_segments_without_jumps(walk):
    """A 0.3 s segment limit (60 samples, shorter than one swing + stance) forces early flushes: more segments,
    the path stays continuous (no step larger than the true foot speed allows) and still beats the filter."""
    init = TruthInit(walk.q_nb[0], np.zeros(3))
    common = (walk.t_s, walk.acc_b, walk.gyro_b, walk.stance, init, walk.gravity)
    exact = dict(n_states=9, zupt_onset_delay_s=0.0)  # the synthetic stance mask is exact
    full = run_filter(*common, FilterSettings(**exact))
    short = run_filter(*common, FilterSettings(smoother_max_segment_s=0.3, **exact))
    filt = run_filter(*common, FilterSettings(smoother="none", **exact))
    assert short.info["smoother_segments"] > 2 * full.info["smoother_segments"]
    dt = walk.t_s[1] - walk.t_s[0]
    vmax = np.linalg.norm(walk.vel_n, axis=1).max()
    assert np.linalg.norm(np.diff(short.pos_n, axis=0), axis=1).max() < 1.2 * vmax * dt
    assert _swing_errors(walk, short)[0] < _swing_errors(walk, filt)[0]


def test_optional_heading_aid_reduces_drift_on_a_corridor_walk():
    """Straight corridor walk with an uncompensated yaw-gyro bias (0.004 rad/s ≈ 0.23 °/s): heading drifts and the
    path bends sideways. The dominant-direction aid at least halves the cross-track error; ``run_filter`` with
    "none", or with the default "auto" (decided by ``process`` on this unaided path), applies none."""
    w = synthetic_walk(n_strides=40, acc_noise=ACC_NOISE, gyro_noise=GYRO_NOISE, gyro_bias=(0, 0, 0.004), seed=8)
    init = TruthInit(w.q_nb[0], np.zeros(3))
    common = (w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity)
    free = run_filter(*common, FilterSettings(heading_aid="none", zaru=False))
    assert run_filter(*common, FilterSettings(zaru=False)).info["heading_aid_updates"] == 0  # "auto": the unaided pass
    aided = run_filter(*common, FilterSettings(heading_aid="dominant_directions", zaru=False))
    assert free.info["heading_aid_updates"] == 0 and free.info["heading_aid"] == "none"
    assert aided.info["heading_aid_updates"] >= 30
    cross_free = abs(free.pos_n[-1, 1] - w.pos_n[-1, 1])
    assert cross_free > 1.0  # the drift is real: > 1 m sideways after 56 m
    assert abs(aided.pos_n[-1, 1] - w.pos_n[-1, 1]) < 0.5 * cross_free


def test_default_quiet_core_zaru_removes_yaw_bias_drift():
    """The same corridor walk with the DEFAULT settings (quiet-core ZARU on, no heading aid): the z gyro bias
    is observed in stance, so the cross-track drift is at least 4x smaller than without ZARU and the bias
    estimate is within 3 filter sigmas of the simulated 0.004 rad/s."""
    w = synthetic_walk(n_strides=40, acc_noise=ACC_NOISE, gyro_noise=GYRO_NOISE, gyro_bias=(0, 0, 0.004), seed=8)
    init = TruthInit(w.q_nb[0], np.zeros(3))
    common = (w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity)
    default = run_filter(*common, FilterSettings())
    off = run_filter(*common, FilterSettings(zaru=False))
    assert default.info["zaru"] and default.info["heading_aid_updates"] == 0
    assert abs(default.pos_n[-1, 1] - w.pos_n[-1, 1]) < 0.25 * abs(off.pos_n[-1, 1] - w.pos_n[-1, 1])
    sigma_bgz = default.info["final_state_sigma"][14]
    assert abs(default.gyro_bias_b[-1, 2] - 0.004) < 3 * sigma_bgz < 0.002


def test_delay_zupt_onsets_trims_each_phase_start_with_a_cap():
    """First min(delay, fraction × duration) of each stance phase is not a ZUPT; the initial phase is whole."""
    from bootnav.postproc.ins.prepare import delay_zupt_onsets

    t = np.arange(200) * 0.01
    st = np.zeros(200, bool)
    st[0:50] = True  # initial still period: kept whole
    st[80:140] = True  # 0.59 s phase: loses 0.1 s = 10 samples
    st[170:176] = True  # 0.05 s phase: loses 1/3 of its 0.05 s -> 2 samples
    out = delay_zupt_onsets(t, st, 0.1, 1.0 / 3.0)
    assert out[0:50].all()
    assert not out[80:90].any() and out[90:140].all()
    assert not out[170:172].any() and out[172:176].all()
    assert not (out & ~st).any()  # never adds stance
    assert np.array_equal(delay_zupt_onsets(t, st, 0.0, 0.5), st)


def test_zupt_onset_delay_recovers_motion_inside_early_stance():
    """The detector fires 0.06 s early (the last 0.06 s of every swing, where the foot still moves, is marked
    stance; sensor exact). ZUPTs from that onset throw the real motion away (decimetres along track after 10
    strides); delaying them by 0.1 s gives the same end point as the exact stance mask (within 1 cm)."""
    w = synthetic_walk(n_strides=10, acc_noise=0.0, gyro_noise=0.0, seed=3)
    dt = w.t_s[1] - w.t_s[0]
    early = w.stance.copy()
    for a in np.flatnonzero(w.stance[1:] & ~w.stance[:-1]) + 1:
        early[max(0, a - int(round(0.06 / dt))):a] = True
    init = TruthInit(w.q_nb[0], np.zeros(3))
    fs = dict(zupt_lever_arm_m=0.0, zaru=False)
    exact = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, FilterSettings(zupt_onset_delay_s=0.0, **fs))
    plain = run_filter(w.t_s, w.acc_b, w.gyro_b, early, init, w.gravity, FilterSettings(zupt_onset_delay_s=0.0, **fs))
    delayed = run_filter(w.t_s, w.acc_b, w.gyro_b, early, init, w.gravity, FilterSettings(zupt_onset_delay_s=0.1, **fs))
    assert delayed.info["zupt_onset_samples_skipped"] > 0 and plain.info["zupt_onset_samples_skipped"] == 0
    assert np.linalg.norm(plain.pos_n[-1] - w.pos_n[-1]) > 0.3
    assert np.linalg.norm(delayed.pos_n[-1] - exact.pos_n[-1]) < 0.01
