"""Height hold on level strides (``measurements.level_height``): z, H, R, both engines, a drifting level walk.

Expected values come from the model's equations (measurements.py): at a stance onset with a reference height
h_ref, a stride with |ĥ − h_ref| < ``level_max_dz_m`` gives z = h_ref − ĥ (ĥ nominal; the gate adds this
sample's earlier corrections), H selecting δp_U, R = σ_level²;
any other stride gives nothing and moves the reference to ĥ.
"""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.layout import HEIGHT, LVL_HAVE_REF, LVL_PENDING, LVL_REF_Z, POS, initial_nominal_state
from bootnav.postproc.ins.measurements import LevelHeightMeasurement
from bootnav.postproc.ins.params import kernel_params
from tests.test_ins_engines import messy_walk  # noqa: F401  (fixture)
from tests.test_ins_synthetic import TruthInit, synthetic_walk

SIGMA_LEVEL, MAX_DZ = 0.004, 0.08
SETTINGS = FilterSettings(sigma_level_m=SIGMA_LEVEL, level_max_dz_m=MAX_DZ)
PRM = kernel_params(SETTINGS, 9.81, 0.01, riccati=False, smooth=True, max_segment=500)
N = 15


def test_level_height_z_h_r_at_stance_onsets():
    meas = LevelHeightMeasurement(PRM, N)
    stance = np.array([True, False, True, True, False, True, True, True, False, True])
    acc = gyr = np.zeros((len(stance), 3))
    st = initial_nominal_state([1.0, 0.0, 0.0, 0.0], np.zeros(3), np.zeros(3))
    dx = np.zeros(N)

    def at(k, z):
        st[POS] = (0.3 * k, 0.0, z)
        return meas.evaluate(st, dx, acc, gyr, stance, k)

    assert st[LVL_HAVE_REF] == 0.0
    assert at(0, 1.0) is None and st[LVL_REF_Z] == 1.0 and st[LVL_HAVE_REF] == 1.0  # first footfall: reference
    z, h, r = at(2, 1.03)  # a level stride that drifted 3 cm up
    assert z == pytest.approx([-0.03], abs=1e-15)
    assert h.shape == (1, N) and h[0, HEIGHT] == 1.0 and np.count_nonzero(h) == 1 and HEIGHT == 2
    assert r.shape == (1, 1) and r[0, 0] == pytest.approx(SIGMA_LEVEL**2, rel=1e-15)
    assert st[LVL_REF_Z] == 1.0  # the floor's height is kept
    assert at(3, 1.005) is None and st[LVL_REF_Z] == 1.0  # mid-stance after a level stride: memory untouched
    assert at(5, 1.0 + 0.34) is None and st[LVL_REF_Z] == pytest.approx(1.34, abs=1e-15)  # stair stride: new floor
    assert st[LVL_PENDING] == 1.0
    assert at(6, 1.35) is None and at(7, 1.36) is None  # the foot settles: the reference follows it
    assert st[LVL_REF_Z] == pytest.approx(1.36, abs=1e-15)
    z, _, _ = at(9, 1.36 - 0.05)  # level again, 5 cm down: below the 8 cm gate
    assert z == pytest.approx([0.05], abs=1e-12) and st[LVL_PENDING] == 0.0


def test_a_heel_or_toe_roll_is_not_held_and_moves_the_reference():
    """A move shorter than level_min_stride_m (here 2 cm forward, 3 cm down: the heel dropping after a
    toe-first landing) is not a stride: no measurement. After a stair stride the reference still follows the
    foot, so it ends where the rolled foot settled; on a floor a short move (crawling, turning) is held."""
    meas = LevelHeightMeasurement(PRM, N)
    stance = np.array([True, False, True, False, True, True, False, True, False, True, False, True])
    acc = gyr = np.zeros((len(stance), 3))
    st = initial_nominal_state([1.0, 0.0, 0.0, 0.0], np.zeros(3), np.zeros(3))
    dx = np.zeros(N)

    def at(k, p):
        st[POS] = p
        return meas.evaluate(st, dx, acc, gyr, stance, k)

    assert at(0, (0.0, 0.0, 0.0)) is None
    z, _, _ = at(2, (1.0, 0.0, 0.01))  # level
    assert z == pytest.approx([-0.01]) and st[LVL_PENDING] == 0.0
    assert at(4, (1.3, 0.0, -0.36)) is None and st[LVL_PENDING] == 1.0  # stair stride down, on the toe
    assert at(5, (1.3, 0.0, -0.361)) is None
    assert at(7, (1.32, 0.0, -0.395)) is None  # the heel drops: a roll
    assert st[LVL_REF_Z] == -0.361  # (the roll's onset keeps it; the stance samples after it move it)
    at(8, (1.4, 0.0, 0.0))  # (swing sample: nothing)
    z, _, _ = at(9, (2.7, 0.0, -0.40))  # a level stride after the roll: held to where the toe stance ended
    assert z == pytest.approx([0.039], abs=1e-12)
    z, _, _ = at(11, (2.72, 0.0, -0.38))  # a short move on a floor: held like a stride
    assert z == pytest.approx([0.019], abs=1e-12) and st[LVL_REF_Z] == -0.361


def test_level_height_uses_the_height_corrected_by_earlier_updates():
    """The gate sees ĥ = p̂_U + δp_U of this sample (the ZUPT's correction comes first, as for the heading aid),
    and the correction is counted once: z is against the nominal p̂_U, because the sequential update's
    innovation is z − δp_U (``kalman.sequential_update``), which is then h_ref − ĥ."""
    meas = LevelHeightMeasurement(PRM, N)
    stance = np.array([True, False, True])
    acc = gyr = np.zeros((3, 3))
    st = initial_nominal_state([1.0, 0.0, 0.0, 0.0], np.zeros(3), np.zeros(3))
    dx = np.zeros(N)
    meas.evaluate(st, dx, acc, gyr, stance, 0)
    st[POS] = (1.0, 0.0, 0.2)  # the nominal 20 cm up (beyond the gate), the correction brings it back to 1 cm
    dx[HEIGHT] = -0.19
    z, _, _ = meas.evaluate(st, dx, acc, gyr, stance, 2)  # level: held
    assert z == pytest.approx([-0.2], abs=1e-12)  # h_ref − p̂_U
    assert z[0] - dx[HEIGHT] == pytest.approx(-0.01, abs=1e-12)  # the innovation: h_ref − ĥ


def test_a_zupt_height_correction_at_the_onset_is_not_undone_by_the_hold():
    """After an unaided stretch (a run whose foot-flats were missed) the onset's ZUPT moves the height by
    P_zv P_vv⁻¹ δv, here +0.7 m back to the floor the foot left. The hold that follows in the same sample
    (sequential updates, both engines' convention) must keep that correction: the height ends on the
    reference, within σ_level of it. Counting the ZUPT's correction twice in z pulled it back down by 0.7 m
    and the drifted height became the floor of the rest of the walk (docs/tuning-log.md, "Unaided runs and
    the height hold")."""
    from bootnav.postproc.ins.kalman import sequential_update

    meas = LevelHeightMeasurement(PRM, N)
    stance = np.array([True, False, True])
    acc = gyr = np.zeros((3, 3))
    st = initial_nominal_state([1.0, 0.0, 0.0, 0.0], np.zeros(3), np.zeros(3))
    meas.evaluate(st, np.zeros(N), acc, gyr, stance, 0)  # the reference: 0 m
    st[POS] = (12.0, 0.0, -0.7)  # the forward height after the run: 0.7 m low
    P = np.eye(N) * 1e-4
    P[HEIGHT, HEIGHT] = 0.5  # the height is uncertain after the unaided run
    dx = np.zeros(N)
    dx[HEIGHT] = 0.7  # the onset ZUPT's correction of this sample
    z, _, r = meas.evaluate(st, dx, acc, gyr, stance, 2)
    sequential_update(P, dx, z, 1, HEIGHT, float(r[0, 0]), N, np.zeros((N, 3)), np.empty((N, N)))
    assert st[POS][2] + dx[HEIGHT] == pytest.approx(0.0, abs=SIGMA_LEVEL)


def test_level_height_off_and_in_paper_mode_is_not_active():
    assert LevelHeightMeasurement.active(FilterSettings())
    assert not LevelHeightMeasurement.active(FilterSettings(level_height=False))
    assert not LevelHeightMeasurement.active(FilterSettings(mode="riccati"))
    with pytest.raises(ValueError, match="level_max_dz_m"):
        FilterSettings(level_max_dz_m=0.0).validate()
    with pytest.raises(ValueError, match="level_height"):
        FilterSettings(level_height="yes").validate()


@pytest.mark.parametrize("n_states", [9, 15])
def test_both_engines_agree_with_the_height_hold(messy_walk, n_states):  # noqa: F811
    """The gate is opened to 0.2 m so that the messy walk's 0.15 m climbs count as level and the hold acts."""
    t, acc, gyr, stance, init, g = messy_walk
    case = dict(n_states=n_states, level_max_dz_m=0.2)
    fast = run_filter(t, acc, gyr, stance, init, g, FilterSettings(engine="fast", **case))
    ref = run_filter(t, acc, gyr, stance, init, g, FilterSettings(engine="reference", **case))
    assert fast.info["level_height_updates"] == ref.info["level_height_updates"] >= 2
    assert np.abs(fast.pos_n - ref.pos_n).max() < 1e-9
    assert np.abs(fast.q_nb - ref.q_nb).max() < 1e-9
    assert np.abs(fast.pos_sigma_n - ref.pos_sigma_n).max() < 1e-9
    assert np.abs(fast.pos_cov_en - ref.pos_cov_en).max() < 1e-12
    # the hold really acted: the 4 × 0.15 m climb is mostly flattened (each update keeps < the 0.15 m stride)
    free = run_filter(t, acc, gyr, stance, init, g, FilterSettings(engine="fast", n_states=n_states,
                                                                     level_height=False))
    assert free.pos_n[-1, 2] > 0.45 and fast.pos_n[-1, 2] < 0.3


def test_a_level_walk_with_a_vertical_drift_keeps_its_height():
    """A vertical accelerometer bias (not estimated: 9 states) and the "endpoint" strapdown step (its specific
    force half a sample late against the attitude, docs/tuning-log.md "Height at low rates") make the free
    filter's height drift on a level walk (truth: height 0 throughout). Its drift per stride d = |h_end| /
    strides sets the bound: the hold keeps every stance sample within the drift of the first stride (before a
    reference exists) and of one more, plus 3 σ_level, while the free filter ends beyond three times that
    bound."""
    n = 30
    w = synthetic_walk(n_strides=n, acc_bias=(0.0, 0.0, 0.05), seed=3)
    assert np.abs(w.pos_n[:, 2]).max() < 0.2 and np.abs(w.pos_n[w.stance, 2]).max() < 1e-9  # a level walk
    init = TruthInit(w.q_nb[0], [0.0, 0.0, 0.0])
    free = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity,
                      FilterSettings(n_states=9, level_height=False, strapdown="endpoint"))
    held = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity,
                      FilterSettings(n_states=9, strapdown="endpoint"))
    per_stride = abs(free.pos_n[-1, 2]) / n
    bound = 2 * per_stride + 3 * FilterSettings().sigma_level_m
    assert abs(free.pos_n[-1, 2]) > 3 * bound  # precondition: without the hold the walk drifts far beyond it
    assert np.abs(held.pos_n[w.stance, 2]).max() < bound
    assert held.info["level_height_updates"] >= n - 2
