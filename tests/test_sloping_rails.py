"""Gyro rails that a calibrated output makes slope (``bootnav.core.arrays.sloping_rails``): found on a clipped
swing, not on smooth swing peaks however regular, and flagging them keeps the heading that an unflagged rail
loses (``FilterSettings.sloping_rails``)."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.core.arrays import GYRO_MIN_FULL_SCALE_RADPS as FS, RAIL_LEVEL_TOL, clipped_axes, sloping_rails
from bootnav.core.runs import runs
from bootnav.postproc.checks import ClipRails, clipping_bits

RATE_HZ = 200.0


def _swings(amplitudes, power: float = 2.0, seed: int = 0) -> np.ndarray:
    """(N, 3) rad/s: one swing per amplitude on axis 1 (a maximum shaped 1 − |t/w|^power near its top, 0.4 s
    wide), a smaller lateral rate on axes 0 and 2, and white noise of a MEMS gyro at 200 Hz (5 mrad/s)."""
    rng = np.random.default_rng(seed)
    t = np.arange(-0.5, 0.5, 1.0 / RATE_HZ)
    shape = np.clip(1.0 - np.abs(t / 0.2) ** power, 0.0, None)
    y = np.concatenate([a * shape for a in amplitudes])
    side = np.concatenate([0.3 * a * np.roll(shape, 15) for a in amplitudes])
    w = np.column_stack([side, y, -0.5 * side])
    return w + rng.normal(0.0, 0.005, w.shape)


def _calibrated_rail(w: np.ndarray, rail: float, cross: float = 0.01) -> np.ndarray:
    """What a sensor that clips its raw axes and then applies a calibration with cross-axis terms outputs:
    the railed axis slopes by ``cross`` times the other axes' rates (no value repeats)."""
    out = np.clip(w, -rail, rail)
    out[:, 1] += cross * (out[:, 0] + out[:, 2])
    return out


@pytest.mark.parametrize("power", [2.0, 3.0])
def test_smooth_swing_peaks_are_no_rail(power):
    """A parabola-like top (power 2) or a flatter one (3) is no rail, even when every swing peaks at the same
    rate (a regular gait piles up its maxima like a rail does: only the flat top tells them apart)."""
    rng = np.random.default_rng(1)
    for amplitudes in (np.full(30, 9.0), rng.uniform(7.0, 11.0, 30)):
        w = _swings(amplitudes, power)
        assert sloping_rails(w, FS) == {}
        assert not clipping_bits(w, w, sloping=True).any()


def test_sloping_rail_is_found_where_exact_repeats_are_not():
    rng = np.random.default_rng(2)
    true = _swings(rng.uniform(7.0, 11.0, 30))
    rail = 8.7
    w = _calibrated_rail(true, rail)
    assert clipped_axes(w) == {}, "a sloping rail repeats no value: the exact test cannot see it"
    masks = sloping_rails(w, FS)
    assert sorted(masks) == [1]
    beyond = np.abs(true[:, 1]) > rail
    assert np.count_nonzero(masks[1] & beyond) >= 0.9 * np.count_nonzero(beyond)
    # flagged samples are on the rail: the true rate is within the rail's band (level wander and the band h)
    assert np.all(np.abs(true[masks[1], 1]) >= rail * (1.0 - 2.0 * RAIL_LEVEL_TOL))
    bits = clipping_bits(w, w, sloping=True)
    assert np.array_equal((bits >> 4) & 1 == 1, masks[1]) and not (bits & 0b101000).any()
    assert not clipping_bits(w, w).any()  # off by default


def test_block_passes_flag_the_sloping_rail_as_the_whole_record_does():
    """``bootnav process`` reads in blocks (``ClipRails``): over one block it must flag exactly what
    ``clipping_bits(..., sloping=True)`` flags on the whole record (it flagged nothing before, 0.58 m apart on
    a railed pyshoe trial), and nothing sloping when the setting is off."""
    rng = np.random.default_rng(3)
    w = _calibrated_rail(_swings(rng.uniform(7.0, 11.0, 30)), 8.7)
    acc = np.zeros_like(w)
    acc[:, 2] = 9.81
    for sloping in (True, False):
        rails = ClipRails(sloping)
        rails.add_peaks(acc, w)
        rails.add_counts(acc, w)
        rails.finish()
        expected = clipping_bits(acc, w, sloping=sloping)
        assert expected.any() == sloping
        assert np.array_equal(rails.bits(acc, w), expected)
        assert np.array_equal(rails.bits(acc, w), expected)  # again from its kept block


def test_flagged_sloping_rail_keeps_the_heading(tmp_path):
    """A simulated walk (noise-only MPU6050, level mount) whose y gyro rails at 7 rad/s with a sloping,
    calibrated-output top. Each plateau misses one angle (the area above the rail); flagged, the filter may
    lose at most about one plateau's angle of heading, not accumulate them: the heading error at the last
    stance stays below the largest angle missed on a single plateau. Unflagged, the missed angles add up past
    it (the check fails without the rail test)."""
    from bootnav import simulator as sim
    from bootnav.logger.recording import write_recording
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    res = sim.simulate("rectangle", seed=0, profile="mpu6050-noise-only")
    t, acc, true = res.t_s, res.acc_mps2, res.gyro_radps
    rail = 7.0
    w = _calibrated_rail(true, rail)
    excess = np.maximum(np.abs(true[:, 1]) - rail, 0.0)
    a, b = runs(excess > 0)
    dt = float(np.median(np.diff(t)))
    worst_plateau_rad = max(float(excess[i:j].sum()) * dt for i, j in zip(a, b))
    path = write_recording(tmp_path / "railed.h5", t, acc, w)

    def yaw(q):
        return np.arctan2(2.0 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]), 1.0 - 2.0 * (q[:, 2] ** 2 + q[:, 3] ** 2))

    last_stance = np.flatnonzero(res.truth["stance"].astype(bool))[-1]
    errors = {}
    for flag in (False, True):
        s = ProcessSettings()
        s.filter.sloping_rails = flag
        s.output.plots = False
        r = process(path, s)
        e = yaw(np.asarray(r.q_nb)) - yaw(res.truth["q_nb"])
        errors[flag] = abs((e[last_stance] + np.pi) % (2.0 * np.pi) - np.pi)
        on_rail = np.count_nonzero(r.saturated & (excess > 0))
        if flag:
            assert on_rail >= 0.9 * np.count_nonzero(excess), "the railed samples must be flagged"
    assert errors[True] < worst_plateau_rad < errors[False]
