"""A recording that starts with the foot in motion (issue 28: mocap trials cut from longer walks).

Levelling on the first samples of a swing tilts the start by tens of degrees and the filter, which trusts its
initial attitude, carries the tilt through the walk: the strides climb or sink and are flagged implausible.
The alignment now levels on the first foot-flat (or the first still period) and carries that attitude back
to the first sample with the gyro. Truth: the simulator's exact attitude of the first sample (ideal sensor).
"""

from __future__ import annotations

import numpy as np
import pytest

from bootnav import simulator as sim
from bootnav.core.rotations import euler_zyx_from_quat
from bootnav.postproc.calibration import CalibrationSettings, initial_alignment


@pytest.fixture(scope="module")
def walk():
    scen = sim.custom("stand-walk", lambda pb: pb.stand(2.0).walk(30.0).stand(1.5).walk(6.0))
    return sim.simulate(scen, seed=3, profile="ideal", rate_hz=200.0)


def _cut_in_swing(res, after_s: float) -> int:
    """First sample after ``after_s`` in the middle of a swing (truth stance off for 0.1 s on either side)."""
    stance = np.asarray(res.truth["stance"], bool)
    t = np.asarray(res.truth["t_s"], float)
    n = int(round(0.1 * res.rate_hz))
    for k in np.flatnonzero(t > after_s):
        if not stance[max(0, k - n):k + n].any():
            return int(k)
    raise AssertionError("no swing")


def _tilt_error_rad(init, res, k0: int) -> float:
    rp_true = euler_zyx_from_quat(np.asarray(res.truth["q_nb"][k0], float))[:2]
    return float(np.max(np.abs(np.array([init.roll_rad, init.pitch_rad]) - rp_true)))


def _bound_rad() -> float:
    # the foot-flat window may turn by at most rest_gyro_max × rest_window (the still test's own bound)
    s = CalibrationSettings()
    return s.rest_gyro_max_radps * s.rest_window_s


def test_start_in_a_swing_is_levelled_on_the_first_foot_flat(walk):
    k0 = _cut_in_swing(walk, 4.0)
    t, acc, gyr = walk.t_s[k0:] - walk.t_s[k0], np.asarray(walk.acc, float)[k0:], np.asarray(walk.gyro, float)[k0:]
    init = initial_alignment(t, acc, gyr)
    assert init.still is None and "first foot-flat" in init.warnings[0]
    assert _tilt_error_rad(init, walk, k0) < _bound_rad()
    # the old rule (the first min_still_s of motion) is wrong by more than that bound: this test can fail
    from bootnav.postproc.calibration import roll_pitch_from_specific_force

    n = int(round(CalibrationSettings().min_still_s * walk.rate_hz))
    old = np.array(roll_pitch_from_specific_force(acc[:n].mean(axis=0)))
    rp_true = euler_zyx_from_quat(np.asarray(walk.truth["q_nb"][k0], float))[:2]
    assert np.max(np.abs(old - rp_true)) > _bound_rad()


def test_a_still_period_after_a_moving_start_is_carried_back_to_the_first_sample(walk):
    stance = np.asarray(walk.truth["stance"], bool)
    t_true = np.asarray(walk.truth["t_s"], float)
    # a swing shortly before the 1.5 s stand in the middle of the walk
    stand_start = next(k for k in np.flatnonzero(stance & (t_true > 6.0))
                       if stance[k:k + int(1.4 * walk.rate_hz)].all())
    k0 = _cut_in_swing(walk, t_true[stand_start] - 1.0)
    assert k0 < stand_start
    t, acc, gyr = walk.t_s[k0:] - walk.t_s[k0], np.asarray(walk.acc, float)[k0:], np.asarray(walk.gyro, float)[k0:]
    init = initial_alignment(t, acc, gyr)
    assert init.still is not None and init.still.start > 0
    assert _tilt_error_rad(init, walk, k0) < _bound_rad()
    # the levelled rest attitude itself is not the first sample's (the foot turned in between)
    rp_rest = euler_zyx_from_quat(np.asarray(walk.truth["q_nb"][stand_start + 50], float))[:2]
    rp_true = euler_zyx_from_quat(np.asarray(walk.truth["q_nb"][k0], float))[:2]
    assert np.max(np.abs(rp_rest - rp_true)) > _bound_rad()


@pytest.mark.parametrize("gait", ["walk", "run"])
def test_a_foot_that_never_rests_a_second_passes_the_gravity_check(gait):
    """The importer's unit check reads gravity in the quietest second; a foot cut out of a run never rests
    that long (|f| of its quietest second is ~2.7 g on the simulated run), so the check used to refuse it.
    Its foot-flats read g exactly (ideal sensor); the same samples in g units are still caught."""
    from bootnav.logger.importers import checks

    res = sim.simulate(sim.custom(gait, lambda pb: pb.stand(1.0).walk(60.0, gait=sim.GAITS[gait])),
                       seed=0, profile="ideal", rate_hz=200.0)
    acc = np.asarray(res.acc, float)[int(2.0 * res.rate_hz):]  # from the first swing on: no still second
    assert not np.asarray(res.truth["stance"], bool)[int(2.0 * res.rate_hz):][:200].all()
    assert checks.acc_unit_problem(acc, 1.0, "mps2", res.rate_hz) is None
    mag, _ = checks.quietest_magnitude(np.linalg.norm(acc, axis=1), res.rate_hz, checks.FOOT_FLAT_S)
    assert mag == pytest.approx(9.80665, rel=1e-3)
    p = checks.acc_unit_problem(acc / 9.80665, 1.0, "mps2", res.rate_hz)
    assert p is not None and "fits --acc-unit g" in p
