"""Measurement models (``bootnav.postproc.ins.measurements``): z, H, R of each model against its equations.

The expected values are computed here from the model equations (z = H δx + ν, R):
ZUPT z = 0 − v̂, H selects δv, R = (σ_zupt² + (r |ω − b̂_g|)²) I;  ZARU z = ω − b̂_g, H selects δb_g,
R = (σ_zaru² + (c |ω − b̂_g|)²) I;  heading aid z = −e at stance onsets, H selects yaw, R = σ_hde².
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.postproc.ins import FilterSettings
from bootnav.postproc.ins.layout import (BIAS_GYRO, ERR_BG, ERR_V, HDE_HAVE_PREV, HDE_PREV_X, HDE_REF_HEADING,
                                         N_NOMINAL, POS, VEL, YAW, initial_nominal_state)
from bootnav.postproc.ins.measurements import (KERNEL_REGISTRY, N_KINDS, REGISTRY, HeadingAidMeasurement,
                                               ZaruMeasurement, ZuptMeasurement, active_flags, active_measurements)
from bootnav.postproc.ins.params import kernel_params

SIGMA_ZUPT, LEVER, SIGMA_ZARU, RATE_C, SIGMA_HDE = 0.02, 0.08, 0.003, 2.0, math.radians(4.0)
SETTINGS = FilterSettings(sigma_zupt_mps=SIGMA_ZUPT, zupt_lever_arm_m=LEVER, sigma_zaru_radps=SIGMA_ZARU,
                          zaru_rate_factor=RATE_C, sigma_hde_rad=SIGMA_HDE, heading_aid="dominant_directions")
PRM = kernel_params(SETTINGS, 9.81, 0.01, riccati=False, smooth=True, max_segment=500)
N = 15


def _sample(gyro_row, stance=(True,)):
    """A one-sample record (or len(stance) samples) with the given gyro row at every sample."""
    n = len(stance)
    return np.zeros((n, 3)), np.tile(np.asarray(gyro_row, float), (n, 1)), np.array(stance, dtype=bool)


def _state(vel=(0.0, 0.0, 0.0), gyro_bias=(0.0, 0.0, 0.0)):
    st = initial_nominal_state([1.0, 0.0, 0.0, 0.0], np.zeros(3), gyro_bias)
    st[VEL] = vel
    return st


def test_zupt_at_rest_measures_zero_with_the_velocity_block():
    acc, gyr, stance = _sample([0.0, 0.0, 0.0])
    z, h, r = ZuptMeasurement(PRM, N).evaluate(_state(), np.zeros(N), acc, gyr, stance, 0)
    assert np.array_equal(z, np.zeros(3))
    expected_h = np.zeros((3, N))
    expected_h[:, ERR_V] = np.eye(3)
    assert np.array_equal(h, expected_h)
    dx = np.arange(N, dtype=float)
    assert np.array_equal(h @ dx, dx[3:6])  # δv = (δx_3, δx_4, δx_5)
    assert np.array_equal(r, SIGMA_ZUPT**2 * np.eye(3))  # no rotation: the classic constant R


def test_zupt_z_is_minus_the_estimated_velocity():
    acc, gyr, stance = _sample([0.0, 0.0, 0.0])
    z, _, _ = ZuptMeasurement(PRM, N).evaluate(_state(vel=(0.1, -0.2, 0.3)), np.zeros(N), acc, gyr, stance, 0)
    assert np.array_equal(z, [-0.1, 0.2, -0.3])


@pytest.mark.parametrize("rate", [0.5, 3.0])
def test_rolling_foot_zupt_noise_grows_as_lever_arm_times_rate_squared(rate):
    """|ω − b̂_g| = rate (bias removed): R = σ² + (r·rate)² on each axis."""
    bias = np.array([0.01, -0.02, 0.03])
    direction = np.array([1.0, 2.0, 2.0]) / 3.0
    acc, gyr, stance = _sample(bias + rate * direction)
    _, _, r = ZuptMeasurement(PRM, N).evaluate(_state(gyro_bias=bias), np.zeros(N), acc, gyr, stance, 0)
    assert np.allclose(r, (SIGMA_ZUPT**2 + (LEVER * rate) ** 2) * np.eye(3), rtol=1e-12, atol=0)


def test_zaru_measures_rate_minus_bias_on_the_gyro_bias_block_with_quiet_core_noise():
    bias = np.array([0.002, -0.001, 0.004])
    w = np.array([0.03, 0.0, -0.04])  # |w| = 0.05 rad/s
    acc, gyr, stance = _sample(bias + w)
    z, h, r = ZaruMeasurement(PRM, N).evaluate(_state(gyro_bias=bias), np.zeros(N), acc, gyr, stance, 0)
    assert np.allclose(z, w, rtol=0, atol=1e-17)
    dx = np.arange(N, dtype=float)
    assert np.array_equal(h @ dx, dx[12:15])  # δb_g
    assert h[:, ERR_BG].tolist() == np.eye(3).tolist() and np.count_nonzero(h) == 3
    assert np.allclose(r, (SIGMA_ZARU**2 + (RATE_C * 0.05) ** 2) * np.eye(3), rtol=1e-12, atol=0)


@pytest.mark.parametrize("cls", [ZuptMeasurement, ZaruMeasurement])
def test_stance_models_do_not_apply_in_swing(cls):
    acc, gyr, stance = _sample([0.0, 0.0, 0.0], stance=(False,))
    assert cls(PRM, N).evaluate(_state(), np.zeros(N), acc, gyr, stance, 0) is None


def test_heading_aid_at_stance_onsets():
    """The first onset only starts the memory, the first stride sets the reference heading (0 rad), the next
    one runs 3° off it -> z = −3°; mid-stance samples give nothing, a stride 20° off is gated out, one at 93°
    is 3° off the nearest dominant direction (90°)."""
    meas = HeadingAidMeasurement(PRM, N)
    stance = np.array([False, True, True, False, True, False, True, False, True, False, True])
    acc, gyr = np.zeros((len(stance), 3)), np.zeros((len(stance), 3))
    st = _state()
    dx = np.zeros(N)

    def at(k, x, y):
        st[POS] = (x, y, 0.0)
        return meas.evaluate(st, dx, acc, gyr, stance, k)

    assert at(1, 0.0, 0.0) is None and st[HDE_HAVE_PREV] == 1.0
    assert at(2, 0.5, 0.0) is None  # not an onset (stance at k−1): memory untouched
    assert st[HDE_PREV_X] == 0.0
    assert at(4, 1.0, 0.0) is None and st[HDE_REF_HEADING] == 0.0  # reference set by the first stride
    z, h, r = at(6, 2.0, math.tan(math.radians(3.0)))
    assert z == pytest.approx([-math.radians(3.0)], rel=1e-12)
    assert h.shape == (1, N) and h[0, YAW] == 1.0 and np.count_nonzero(h) == 1
    assert r.shape == (1, 1) and r[0, 0] == pytest.approx(SIGMA_HDE**2, rel=1e-15)
    assert at(8, 3.0, 1.0 + math.tan(math.radians(20.0))) is None  # |e| = 20° > 10° threshold
    y0 = st[POS][1]
    z, _, _ = at(10, 3.0 - math.sin(math.radians(3.0)), y0 + math.cos(math.radians(3.0)))  # heading 93°
    assert z == pytest.approx([-math.radians(3.0)], rel=1e-9)


def test_heading_aid_uses_the_position_corrected_by_earlier_updates():
    """The stride end point is p̂ + δp of this sample (the ZUPT's correction comes first)."""
    meas = HeadingAidMeasurement(PRM, N)
    stance = np.array([True, False, True])
    acc, gyr = np.zeros((3, 3)), np.zeros((3, 3))
    st = _state()
    dx = np.zeros(N)
    meas.evaluate(st, dx, acc, gyr, stance, 0)
    dx[0:2] = (0.4, 0.1)
    meas.evaluate(st, dx, acc, gyr, stance, 2)
    assert st[HDE_PREV_X] == 0.4 and st[HDE_REF_HEADING] == pytest.approx(math.atan2(0.1, 0.4), rel=1e-15)


def test_registry_ids_order_and_activation():
    assert [cls.kind for cls in REGISTRY] == list(range(N_KINDS))
    assert [e.kind for e in KERNEL_REGISTRY] == list(range(N_KINDS))
    assert len({type(e) for e in KERNEL_REGISTRY}) == N_KINDS  # one type each: unrolled per model in numba
    names = lambda s: [m.name for m in active_measurements(s, PRM)]  # noqa: E731
    assert names(FilterSettings()) == ["zupt", "zaru", "level_height"]
    assert names(FilterSettings(n_states=9)) == ["zupt", "level_height"]
    assert names(FilterSettings(zaru=False, heading_aid="dominant_directions", level_height=False)) == [
        "zupt", "heading_aid"]
    assert names(FilterSettings(mode="riccati")) == []  # the paper's constant gain applies the ZUPT itself
    assert active_flags(FilterSettings()).tolist() == [True, True, False, True]


def test_kernel_params_are_the_settings_variances_as_floats():
    prm = kernel_params(FilterSettings(sigma_zupt_mps=2, zupt_lever_arm_m=0, sigma_acc_mps2=0.5), 9.8, 0.005,
                        riccati=False, smooth=False, max_segment=16)
    assert prm.var_zupt == 4.0 and isinstance(prm.var_zupt, float)
    assert prm.lever_arm2 == 0.0 and isinstance(prm.lever_arm2, float)
    assert prm.var_acc == 0.25 * 0.005  # σ² Δt₀ (settings.py noise convention)
    assert prm.var_zaru == FilterSettings().sigma_zaru_radps ** 2


def test_nominal_state_layout():
    st = initial_nominal_state([0.5, 0.5, 0.5, 0.5], [1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    assert st.shape == (N_NOMINAL,)
    assert st[BIAS_GYRO].tolist() == [4.0, 5.0, 6.0] and st[6:10].tolist() == [0.5] * 4
    assert math.isnan(st[HDE_REF_HEADING]) and st[HDE_HAVE_PREV] == 0.0
