"""Hard gaits of the simulator: crawling on hands and knees, fast near-running corridor walks, shuffling.

Every check follows from the configured geometry and timing or from physics (a still foot reads gravity
only; the DLPF's decay rate bounds how long motion leaks into a stance); nothing is tuned to the output.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal

from bootnav.core.rotations import dcm_from_euler_zyx, quat_multiply
from bootnav.core.runs import runs
from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from bootnav.simulator import PROFILES, PathBuilder, custom, simulate
from bootnav.simulator.gait import CRAWL, GAIT_CODES, TURN, WALK
from bootnav.simulator.imu_model import ErrorModel
from bootnav.simulator.scenarios import CRAWL_SCENARIO, FAST_CORRIDOR, SCENARIOS, SHUFFLE_SCENARIO

G = STANDARD_GRAVITY
HARD = {"crawl": None, "fast-corridor": 30.0, "shuffle": 30.0}  # scenario -> short test duration (None: fixed)
POSTURE = (GAIT_CODES["kneel"], GAIT_CODES["stand_up"])


@pytest.fixture(scope="module")
def crawl_ideal():
    return simulate("crawl", seed=3, profile="ideal", rate_hz=400.0)


def _gaits(res) -> list[dict]:
    return json.loads(res.attrs["gait_parameters"])


def _ball_and_heel(res, gait=CRAWL):
    """Ball (toe pivot) and heel points of the sole for every truth sample, nav frame."""
    val = res.trajectory.evaluate(res.truth["t_s"])[0]
    R = dcm_from_euler_zyx(val[:, 5], val[:, 4], val[:, 3])
    return val[:, :3] + R @ np.array([gait.toe_m, 0, 0]), val[:, :3] + R @ np.array([gait.heel_m, 0, 0])


def _toe_down_deg(q_nb: np.ndarray) -> np.ndarray:
    """Angle of the sensor x axis (toe-ward for the right_boot mount) below the horizontal, deg."""
    w, x, y, z = q_nb.T
    return np.degrees(np.arcsin(np.clip(-2 * (x * z - w * y), -1, 1)))


def _between(t, t0, t1):
    return (t >= t0) & (t <= t1)


@pytest.mark.parametrize("name", list(HARD))
def test_listed_and_deterministic_by_seed(name):
    assert name in SCENARIOS
    a = simulate(name, seed=4, duration_s=HARD[name])
    b = simulate(name, seed=4, duration_s=HARD[name])
    c = simulate(name, seed=5, duration_s=HARD[name], profile="mpu6050-16g-2000dps")
    assert np.array_equal(a.acc, b.acc) and np.array_equal(a.gyro, b.gyro) and np.array_equal(a.t_s, b.t_s)
    assert np.array_equal(a.truth["pos_n_m"], b.truth["pos_n_m"])
    # the geometry itself is drawn from the seed, not only the sensor errors
    assert not np.array_equal(a.steps["length_m"], c.steps["length_m"])


@pytest.mark.parametrize("name", list(HARD))
def test_truth_stance_is_exactly_still_and_reads_gravity_only(name):
    res = simulate(name, seed=1, profile="ideal", rate_hz=200.0, duration_s=HARD[name])
    tr = res.truth
    st = tr["stance"] == 1
    assert 0.05 < st.mean() < 0.95
    assert np.all(tr["vel_n_mps"][st] == 0.0) and np.all(tr["omega_b_radps"][st] == 0.0)
    q = tr["q_nb"][st]
    f = np.concatenate([np.zeros((q.shape[0], 1)), tr["f_b_mps2"][st]], axis=1)
    f_n = quat_multiply(quat_multiply(q, f), q * np.array([1, -1, -1, -1]))[:, 1:]
    assert np.allclose(f_n, [0.0, 0.0, G], atol=1e-12)
    # and the foot moves between stances: every stride's middle is not stance, its ends are
    mid = (res.steps["t_start_s"] + res.steps["t_end_s"]) / 2
    assert not np.any(st[np.searchsorted(tr["t_s"], mid)])


@pytest.mark.parametrize("name", list(HARD))
def test_delivered_accelerometer_in_stance_is_gravity_plus_noise(name):
    """Through the MPU6050 chain (white noise, DLPF, int16; bias walk off): in stance, once the DLPF has
    forgotten the swing, accelerometer minus the true gravity reaction is the filtered white noise plus
    rounding noise, per axis, whatever the foot's attitude (flat, or on the toe while crawling)."""
    prof = replace(PROFILES["mpu6050-noise-only"], accel_bias_rw_mps2_rts=0.0, gyro_bias_rw_dps_rts=0.0)
    res = simulate(name, seed=2, profile=prof, rate_hz=200.0, duration_s=HARD[name])
    model = ErrorModel(prof, res.attrs["internal_rate_hz"], np.random.default_rng(0))
    imp = np.zeros(4000)
    imp[0] = 1.0
    h = signal.sosfilt(model.sos_a, imp)
    # the DLPF forgets at the rate of its slowest pole, |p| = exp(-decay / f_i) (2nd-order Butterworth:
    # decay = 2 pi f_c / sqrt 2); 12 e-folds shrink a 10 g swing to well below the noise
    poles = signal.sos2zpk(model.sos_a)[1]
    decay = -math.log(float(np.max(np.abs(poles)))) * res.attrs["internal_rate_hz"]
    guard_s = 12.0 / decay
    t, st = res.truth["t_s"], res.truth["stance"] == 1
    settled = np.zeros_like(st)
    for i0, i1 in zip(*runs(st)):
        settled[i0:i1] = t[i0:i1] >= t[i0] + guard_s
    assert settled.sum() > 500
    resid = res.acc_mps2[settled] - res.truth["f_b_mps2"][settled]
    sigma = math.sqrt((prof.accel_noise_si * math.sqrt(res.attrs["internal_rate_hz"] / 2)) ** 2 * np.sum(h**2)
                      + prof.accel_lsb_mps2**2 / 12)
    # samples are correlated by the DLPF (autocorrelation rho at the output lags); 5 standard errors of
    # the sample std (variance factor 1 + 2 sum rho^2) and of the mean (factor 1 + 2 sum rho)
    acf = np.correlate(h, h, "full")[h.size - 1:] / np.sum(h**2)
    rho = acf[:: res.decimation][1:]
    n = settled.sum()
    rel_std = math.sqrt((1 + 2 * np.sum(rho**2)) / (2 * n))
    assert np.std(resid, axis=0) == pytest.approx(np.full(3, sigma), rel=5 * rel_std)
    assert np.all(np.abs(resid.mean(axis=0)) < 5 * sigma * math.sqrt((1 + 2 * abs(np.sum(rho))) / n))


def test_crawl_rests_on_the_toe_pitched_down_with_gravity_along_the_boot(crawl_ideal):
    res = crawl_ideal
    tr, s = res.truth, res.steps
    k = s["kind"]
    t_knelt = s["t_end_s"][k == GAIT_CODES["kneel"]][0]
    t_rise = s["t_start_s"][k == GAIT_CODES["stand_up"]][0]
    st = tr["stance"] == 1
    crawling = _between(tr["t_s"], t_knelt, t_rise)
    toe_down = _toe_down_deg(tr["q_nb"])
    assert np.allclose(toe_down[st & crawling], CRAWL.rest_pitch_deg, atol=1e-9)
    assert np.all(toe_down[st & crawling] >= 60.0)
    assert np.allclose(toe_down[st & ~crawling], 0.0, atol=1e-9)  # standing stances are flat
    # gravity reaction mostly along the boot's long axis: f_b = g [-sin b, 0, cos b]
    b = math.radians(CRAWL.rest_pitch_deg)
    assert np.allclose(tr["f_b_mps2"][st & crawling], [-G * math.sin(b), 0.0, G * math.cos(b)], atol=1e-9)
    # the ball of the foot rests on the floor in stance, no sole point ever goes below it
    ball, heel = _ball_and_heel(res)
    assert np.allclose(ball[st & crawling, 2], 0.0, atol=1e-12)
    assert min(ball[:, 2].min(), heel[:, 2].min()) > -1e-5
    # the heel is up by (toe - heel) sin b while crawling
    assert np.allclose(heel[st & crawling, 2], (CRAWL.toe_m - CRAWL.heel_m) * math.sin(b), atol=1e-12)


def test_crawl_transitions_pivot_on_the_ball(crawl_ideal):
    """Kneeling turns the flat foot about its fixed ball; the sampled knots carry exact derivatives, so
    the interpolated ball stays put to well under a millimetre (wrong derivatives would move it by mm)."""
    res = crawl_ideal
    tr, s = res.truth, res.steps
    ball, _ = _ball_and_heel(res)
    i = np.flatnonzero(s["kind"] == GAIT_CODES["kneel"])[0]
    during = _between(tr["t_s"], s["t_start_s"][i], s["t_end_s"][i])
    assert np.abs(ball[during] - ball[during][0]).max() < 1e-5
    toe_down = _toe_down_deg(tr["q_nb"][during])
    # samples near the ends (the ramp starts and stops with zero first to third derivatives)
    assert toe_down[0] == pytest.approx(0.0, abs=1e-6) and toe_down[-1] == pytest.approx(75.0, abs=1e-6)
    # the foot origin rises by toe sin b; getting up returns it to the floor, a step ahead
    assert s["dz_m"][i] == pytest.approx(CRAWL.toe_m * math.sin(math.radians(CRAWL.rest_pitch_deg)), abs=1e-12)
    j = np.flatnonzero(s["kind"] == GAIT_CODES["stand_up"])[0]
    assert s["dz_m"][j] == pytest.approx(-s["dz_m"][i], abs=1e-12)
    assert tr["foot_pos_n_m"][-1, 2] == pytest.approx(0.0, abs=1e-12)


def test_crawl_strides_follow_the_configured_geometry_and_timing(crawl_ideal):
    res = crawl_ideal
    tr, s = res.truth, res.steps
    gaits = _gaits(res)
    crawl = s["kind"] == GAIT_CODES["crawl"]
    g = CRAWL_SCENARIO
    lo, hi = g["stride_m"]
    assert np.all((s["length_m"][crawl] > 0.2) & (s["length_m"][crawl] < 0.4))  # drawn in [lo, hi], rescaled
    assert lo <= np.median(s["length_m"][crawl]) <= hi
    assert np.sum(s["length_m"][crawl]) == pytest.approx(g["first_leg_m"] + g["second_leg_m"], abs=1e-9)
    # the turn between the legs: +-90 deg, spread over the first strides of the second leg
    assert abs(np.sum(s["turn_rad"][crawl])) == pytest.approx(math.radians(g["turn_deg"]), abs=1e-12)
    # stride timing: drag (1 - still) T, preceded by exactly still_fraction T of stance, T = 120 / cadence
    st = tr["stance"] == 1
    dt = tr["t_s"][1] - tr["t_s"][0]
    for i in np.flatnonzero(crawl):
        p = gaits[s["gait"][i]]
        T = 120.0 / p["cadence_spm"]
        assert g["cadence_spm"][0] <= p["cadence_spm"] <= g["cadence_spm"][1]
        assert s["t_end_s"][i] - s["t_start_s"][i] == pytest.approx((1 - p["still_fraction"]) * T, abs=1e-9)
        before = _between(tr["t_s"], s["t_start_s"][i] - p["still_fraction"] * T + dt, s["t_start_s"][i] - dt)
        assert np.all(st[before])
    # a slow drag: the ball lifts by the clearance at most, and crawling averages 0.1-0.3 m/s
    ball, _ = _ball_and_heel(res)
    drag = np.zeros_like(st)
    for t0, t1 in zip(s["t_start_s"][crawl], s["t_end_s"][crawl]):
        drag |= _between(tr["t_s"], t0, t1)
    assert ball[drag, 2].max() == pytest.approx(CRAWL.clearance_m, abs=2e-4)
    v_ball = np.linalg.norm(np.gradient(ball, tr["t_s"], axis=0), axis=1)
    assert v_ball[drag].max() < 1.2
    t_crawl = s["t_end_s"][crawl][-1] - s["t_start_s"][crawl][0]
    assert 0.1 < np.sum(s["length_m"][crawl]) / t_crawl < 0.3


def test_crawl_truth_is_self_consistent_by_finite_differences():
    res = simulate(custom("crawl-bit", lambda pb: pb.stand(1.0).walk(2.0).kneel().stand(0.5)
                          .stride(0.3, 0.0, 0.4, CRAWL).stride(0.3, 0.0, -0.2, CRAWL).stand_up().stand(0.5)),
                   profile="ideal", rate_hz=2000.0, mount="right_boot_tilted")
    tr, t = res.truth, res.truth["t_s"]
    v_fd = np.gradient(tr["pos_n_m"], t, axis=0)
    assert np.abs(v_fd - tr["vel_n_mps"])[2:-2].max() < 2e-3
    q = tr["q_nb"]
    w_fd = 2 * quat_multiply(q * np.array([1, -1, -1, -1]), np.gradient(q, t, axis=0))[:, 1:]
    assert np.abs(w_fd - tr["omega_b_radps"])[2:-2].max() < 5e-3


def test_posture_rules_are_enforced():
    with pytest.raises(ValueError, match="kneel"):
        PathBuilder().stride(0.3, gait=CRAWL)
    pb = PathBuilder().kneel()
    with pytest.raises(ValueError, match="stand_up"):
        pb.stride(1.0, gait=WALK)
    with pytest.raises(ValueError, match="stand_up"):
        pb.turn_in_place(math.pi, TURN)
    with pytest.raises(ValueError, match="flat foot"):
        pb.kneel()
    with pytest.raises(ValueError, match="level"):
        pb.stride(0.3, 0.1, 0.0, CRAWL)
    pb.stand_up()
    with pytest.raises(ValueError, match="on its toe"):
        pb.stand_up()


def test_fast_corridor_strides_are_long_quick_and_briefly_still():
    res = simulate("fast-corridor", seed=6, profile="ideal", rate_hz=1000.0, duration_s=45.0)  # two lengths
    tr, s = res.truth, res.steps
    gaits = _gaits(res)
    fast = s["kind"] == GAIT_CODES["fast"]
    cruise = fast & (s["length_m"] > FAST_CORRIDOR["ramp_m"][1] + 1e-9)
    lo, hi = FAST_CORRIDOR["stride_m"]
    # equal strides over the cruise part of a length, none longer than the drawn stride <= 2.5 m
    assert cruise.sum() >= 20
    assert np.all((s["length_m"][cruise] > lo * 0.9) & (s["length_m"][cruise] <= hi + 1e-12))
    st = tr["stance"] == 1
    starts, stops = runs(st)
    for i in np.flatnonzero(cruise):
        p = gaits[s["gait"][i]]
        T = 120.0 / p["cadence_spm"]
        assert T == pytest.approx(0.8 * math.sqrt(2.5 / p["stride_length_m"]), rel=1e-12)  # cadence from stride
        # the foot-flat rest before the stride (truth stance run ending at its start) lasts 0.1-0.2 s
        k = np.searchsorted(tr["t_s"][starts], s["t_start_s"][i]) - 1
        still = tr["t_s"][stops[k] - 1] - tr["t_s"][starts[k]]
        assert still == pytest.approx(p["still_fraction"] * T, abs=2e-3)  # (n - 1) samples of 1 ms
        lo_s, hi_s = FAST_CORRIDOR["still_s"]
        assert lo_s - 2e-3 <= still <= hi_s
        swing = _between(tr["t_s"], s["t_start_s"][i], s["t_end_s"][i])
        assert np.linalg.norm(tr["omega_b_radps"][swing], axis=1).max() > 10.0  # > 570 deg/s
    # a straight corridor, 180 deg turns on the spot at its ends
    foot = tr["foot_pos_n_m"]
    assert foot[:, 0].min() > -0.5 and foot[:, 0].max() < FAST_CORRIDOR["corridor_m"] + 0.5
    assert np.abs(foot[:, 1]).max() < 0.5
    turns = s["kind"] == GAIT_CODES["turn"]
    assert abs(np.sum(s["turn_rad"][turns][:3])) == pytest.approx(math.pi, abs=1e-12)
    assert set(np.round(np.cos(s["heading_rad"][cruise]), 12)) == {1.0, -1.0}


def test_shuffle_steps_are_short_low_and_turn_on_the_spot():
    res = simulate("shuffle", seed=7, profile="ideal", rate_hz=500.0, duration_s=40.0)
    s, tr = res.steps, res.truth
    sh = s["kind"] == GAIT_CODES["shuffle"]
    lo, hi = SHUFFLE_SCENARIO["stride_m"]
    assert sh.sum() >= 10
    assert np.all((s["length_m"][sh] >= lo - 1e-12) & (s["length_m"][sh] <= hi + 1e-12))
    assert (s["kind"] == GAIT_CODES["turn"]).sum() >= 2
    # the swing passes 3 cm clearance (a knot; the curve may overshoot it by millimetres), a walk lifts 12 cm
    assert 0.03 <= tr["foot_pos_n_m"][:, 2].max() < 0.035
    for i in np.flatnonzero(sh):
        p = _gaits(res)[s["gait"][i]]
        T = 120.0 / p["cadence_spm"]
        assert s["t_end_s"][i] - s["t_start_s"][i] == pytest.approx((1 - p["still_fraction"]) * T, abs=1e-9)
