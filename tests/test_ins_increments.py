"""The strapdown step at low rates (``FilterSettings.strapdown``, ``ins.increments``): a walk sampled at
800 Hz and its block means at 200 and 100 Hz (what a lower-rate sensor's averaging stage delivers) give the
same height."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav import simulator as sim
from bootnav.postproc.calibration import CalibrationSettings, initial_alignment
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.increments import previous_rows, sculling_coning

G = CalibrationSettings().gravity()
# floor flatness, m [DIN18202] (FilterSettings.sigma_level_m): a height difference below it is not observable
# on a floor, so the rate may not change the final height of a level loop by more
FLOOR_FLATNESS_M = FilterSettings().sigma_level_m


def _block_mean(t, x, k):
    n = (len(t) // k) * k
    return t[:n].reshape(-1, k).mean(axis=1), x[:n].reshape(-1, k, x.shape[1]).mean(axis=1)


@pytest.fixture(scope="module")
def loop():
    """Exact (ideal-sensor) samples of a level rectangle walked at 800 Hz."""
    res = sim.simulate("rectangle", seed=1, profile="ideal", rate_hz=800.0)
    return res.t_s, np.hstack([np.asarray(res.acc_mps2, float), np.asarray(res.gyro_radps, float)])


def _final_height(t, x, strapdown):
    a, w = x[:, :3], x[:, 3:]
    init = initial_alignment(t, a, w, CalibrationSettings(), G)
    stance = detect_stance(t, a, w, DetectorSettings(), G).stance
    nav = run_filter(t, a, w, stance, init, G, FilterSettings(strapdown=strapdown, level_height=False))
    return float(nav.pos_n[-1, 2] - nav.pos_n[0, 2])


def test_height_does_not_depend_on_the_rate(loop):
    t, x = loop
    z = {k: _final_height(*_block_mean(t, x, k), "increments") for k in (1, 4, 8)}
    assert abs(z[1]) < FLOOR_FLATNESS_M  # the truth is 0: a level loop
    for k in (4, 8):
        assert abs(z[k] - z[1]) < FLOOR_FLATNESS_M, (k, z)
    # the same check on the step that rotates f with the attitude at the end of its interval fails: the Δt/2
    # timing error of that step (2.5 / 5 ms) lowers the loop's end by centimetres at 200 / 100 Hz
    end = {k: _final_height(*_block_mean(t, x, k), "endpoint") for k in (1, 8)}
    assert abs(end[8] - end[1]) > 4 * FLOOR_FLATNESS_M, end


def test_sculling_and_coning_terms_are_the_two_sample_forms():
    """f' = f + (Δt/12)(ω_{k−1} × f + f_{k−1} × ω), ω' = ω + (Δt/12) ω_{k−1} × ω; none for the first sample,
    a duplicate timestamp or a constant rotation of a constant body-frame vector."""
    rng = np.random.default_rng(5)
    f, w = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    dt = np.array([0.0, 0.01, 0.01, 0.0, 0.01, 0.05])  # first sample, two steps, a duplicate, a step, a gap
    fp, wp, dp = previous_rows(f, None), previous_rows(w, None), previous_rows(dt, None)
    f2, w2 = sculling_coning(f, w, dt, fp, wp, dp)
    h = np.minimum(dt, dp)[:, None] / 12.0
    assert np.allclose(f2, f + h * (np.cross(wp, f) + np.cross(fp, w)), rtol=0, atol=1e-15)
    assert np.allclose(w2, w + h * np.cross(wp, w), rtol=0, atol=1e-15)
    assert np.array_equal(f2[[0, 3, 4]], f[[0, 3, 4]])  # Δt or the previous Δt is 0: nothing to correct
    gap = f[5] + 0.01 / 12 * (np.cross(w[4], f[5]) + np.cross(f[4], w[5]))  # after a gap: the shorter Δt
    assert np.allclose(f2[5], gap, rtol=0, atol=1e-15)
    const = sculling_coning(np.tile(f[1], (3, 1)), np.tile(w[1], (3, 1)), np.full(3, 0.01),
                            np.tile(f[1], (3, 1)), np.tile(w[1], (3, 1)), np.full(3, 0.01))
    assert np.allclose(const[0], f[1], rtol=0, atol=1e-15) and np.allclose(const[1], w[1], rtol=0, atol=1e-15)
