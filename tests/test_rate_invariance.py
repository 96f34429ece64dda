"""Rate invariance through the whole pipeline (issue 28 point 3): a simulated walk sampled at 400 Hz and its
copies at 200 and 100 Hz, each output sample the mean over its output interval (what a lower-rate sensor's
averaging stage delivers; ``benchmarks/rates.py``'s block mean), close the loop at the same place, for every
grouping of the rows into output intervals (the phases).

The tolerance is how precisely a footfall's position is defined at all: the floor's flatness and the sole's
landing point, ``FilterSettings.sigma_level_m`` (5 mm [DIN18202]). The copies carry the same velocity and
angle increments as the native samples, so what the rate may change is below that; the strapdown step that
rotates f with the attitude at the end of its interval ("endpoint", a Δt/2 timing error) moves the 100 Hz
loop's end by 6-7 mm horizontally (and by 23 mm vertically without the height hold), so the check can fail.
"""

from __future__ import annotations

import numpy as np
import pytest

import bootnav
from bootnav import simulator as sim
from bootnav.postproc.evaluate.metrics import stance_positions
from bootnav.postproc.ins import FilterSettings

FOOTPRINT_M = FilterSettings().sigma_level_m


def interval_mean(t: np.ndarray, x: np.ndarray, k: int, phase: int) -> tuple[np.ndarray, np.ndarray]:
    """Every k-th row's time from row ``phase`` on, and the mean of x over each interval between them (row j
    stands for (t_{j−1}, t_j], as the filter integrates it); the first row as it is."""
    t, x = t[phase:], x[phase:]
    cum = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(x[1:] * np.diff(t)[:, None], axis=0)])
    idx = np.arange(0, len(t), k)
    return t[idx], np.vstack([x[:1], np.diff(cum[idx], axis=0) / np.diff(t[idx])[:, None]])


@pytest.fixture(scope="module")
def walk():
    """A closed 32 m rectangle, MPU6050 noise (no turn-on errors), 400 Hz."""
    res = sim.simulate("rectangle", seed=1, profile="mpu6050-noise-only", rate_hz=400.0)
    return res.t_s, np.hstack([np.asarray(res.acc_mps2, float), np.asarray(res.gyro_radps, float)])


def _closure(t, x, **settings) -> np.ndarray:
    """End minus start of the loop: the last stance phase's mean position minus the first's (METRICS.md)."""
    r = bootnav.process(t, x[:, :3], x[:, 3:], **settings)
    p = stance_positions(r.pos_n_m, r.stance)
    return p[-1] - p[0]


def test_the_loop_closes_at_the_same_place_at_every_rate(walk):
    t, x = walk
    native = _closure(t, x)
    assert np.hypot(*native[:2]) < 0.005 * 32.0  # the native run itself closes within 0.5 % of the distance
    for k in (2, 4):
        for phase in range(k):
            c = _closure(*interval_mean(t, x, k, phase))
            assert np.hypot(*(c - native)[:2]) < FOOTPRINT_M, (k, phase, c, native)
            assert abs(c[2] - native[2]) < FOOTPRINT_M, (k, phase, c, native)


def test_the_end_of_interval_step_moves_the_low_rate_loop(walk):
    """The same check fails for the "endpoint" strapdown step: the tolerance is tight enough to see it."""
    t, x = walk
    endpoint = {"filter": {"strapdown": "endpoint"}}
    native = _closure(t, x, **endpoint)
    c = _closure(*interval_mean(t, x, 4, 0), **endpoint)
    assert np.hypot(*(c - native)[:2]) > FOOTPRINT_M, (c, native)


def test_adaptive_detector_sees_one_rest_level_at_every_rate_with_average_s(walk):
    """``AdaptiveDetector.average_s``: a k-fold mean of white noise has 1/k of its variance, so without it the
    rest level of log10 T (the noise floor F) falls by up to log10 4 = 0.6 decades from 400 to 100 Hz while the
    swing peak does not; averaging every rate over the same 10 ms leaves the same noise at all three. The
    tolerance is a sixth of that white-noise fall (0.1 decade)."""
    from bootnav.postproc.detectors import DetectorSettings, detect_stance

    t, x = walk
    tol = np.log10(4.0) / 6.0

    def floor(k, average_s):
        tk, xk = interval_mean(t, x, k, 0)
        res = detect_stance(tk, xk[:, :3], xk[:, 3:], DetectorSettings().with_params(average_s=average_s), 9.80665)
        return res.info["noise_floor_log10"]

    with_avg = {k: floor(k, 0.01) for k in (1, 2, 4)}
    assert all(abs(with_avg[k] - with_avg[1]) < tol for k in (2, 4)), with_avg
    assert floor(1, 0.0) - floor(4, 0.0) > tol  # without it the rest level falls with the rate
