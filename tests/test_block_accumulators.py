"""The accumulators the block passes make whole-record decisions with (``passes.BlockPasses``) give what the
whole-array functions give, for any chunking."""

import numpy as np
import pytest

from bootnav.postproc.selftune import (GaitPeriodAccumulator, SelfTuneSettings, StrideQualityAccumulator,
                                       gait_period, stride_quality)


def _gait(n, rate, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    gyro = np.column_stack((3 + 2 * np.sin(2 * np.pi * t / 1.1) + rng.normal(0, 0.3, n), rng.normal(0, 0.3, n),
                            rng.normal(0, 0.3, n)))  # ‖ω‖ with a 1.1 s rhythm
    return t, gyro


@pytest.mark.parametrize("chunk", [1, 7, 299, 301, 10**6])
def test_gait_period_over_chunks(chunk):
    t, gyro = _gait(4000, 100.0, 1)
    acc = GaitPeriodAccumulator(0.01)
    for i in range(0, len(t), chunk):
        acc.push(gyro[i:i + chunk])
    assert acc.finish() == pytest.approx(gait_period(t, gyro), abs=1e-9)  # the same lag (its period 1.1 s)
    assert acc.finish() == pytest.approx(1.1, abs=0.02)


def test_no_gait_over_chunks_is_nan():
    t, _ = _gait(4000, 100.0, 2)
    gyro = np.random.default_rng(3).normal(0, 0.01, (4000, 3))
    acc = GaitPeriodAccumulator(0.01)
    for i in range(0, 4000, 333):
        acc.push(gyro[i:i + 333])
    assert np.isnan(gait_period(t, gyro)) and np.isnan(acc.finish())


@pytest.mark.parametrize("chunk", [1, 13, 500, 10**6])
def test_stride_flags_over_chunks(chunk):
    """Strides of random lengths and turns: the flags, durations and stance-phase medians of stride_quality."""
    rng = np.random.default_rng(4)
    rate, n = 100.0, 6000
    t = np.arange(n) / rate
    stance = (np.arange(n) % 110) < 45
    phase = np.cumsum(np.r_[0, np.diff(stance.astype(int)) == 1])
    step = rng.uniform(0.2, 2.5, phase.max() + 1)
    pos = np.column_stack((np.cumsum(np.where(stance, 0.0, step[phase] / 65)), np.zeros(n),
                           rng.normal(0, 0.02, n)))
    gyro = rng.normal(0, 0.4, (n, 3))
    bias = np.array([0.01, -0.02, 0.005])
    rates = stride_quality(t, pos, stance, gyro, bias, 1.1).stance_rate_radps
    limits = SelfTuneSettings(max_stride_m=1.5, max_stance_rate_radps=float(np.median(rates)))  # FAST, ROLLING
    whole = stride_quality(t, pos, stance, gyro, bias, 1.1, limits)
    acc = StrideQualityAccumulator()
    for i in range(0, n, chunk):
        acc.push(t[i:i + chunk], pos[i:i + chunk], stance[i:i + chunk], gyro[i:i + chunk], bias)
    mine = acc.finish(1.1, limits)
    assert whole.flags.any() and not whole.flags.all()  # the limits decide something here
    np.testing.assert_array_equal(mine.flags, whole.flags)
    np.testing.assert_array_equal(mine.stance_rate_radps, whole.stance_rate_radps)
    np.testing.assert_allclose(mine.duration_s, whole.duration_s, rtol=0, atol=1e-12)
    assert mine.bad_fraction == whole.bad_fraction


@pytest.mark.parametrize("m", [1, 2, 7, 601, 8191])
@pytest.mark.parametrize("c", [0, 1, 601])
def test_the_gait_period_convolution_is_scipys_bit_for_bit(m, c):
    """``selftune._convolve_full`` (no ``scipy.signal`` import) equals ``scipy.signal.fftconvolve``, every bit."""
    from scipy.signal import fftconvolve

    from bootnav.postproc.selftune.gait import _convolve_full

    z = np.random.default_rng(m + c).random(c + m)
    x = z[c:]
    np.testing.assert_array_equal(_convolve_full(z, x[::-1]), fftconvolve(z, x[::-1]))


def test_order_statistics_keep_at_most_cap_values():
    """The exact median and 99th percentile the block passes take over a whole record (Δt₀, ‖ω‖'s p99, the
    adaptive γ), with memory bounded by ``cap`` and one piece, not by the record: 40 pieces of 10⁵ values
    (32 MB in all) with cap 2¹⁶ (0.5 MB) stay under 8 MB traced (ten pieces; keeping them all is 32 MB)."""
    import tracemalloc

    from bootnav.postproc import passes

    def pieces():
        for i in range(40):
            yield np.random.default_rng(i).normal(size=100_000)

    whole = np.concatenate(list(pieces()))
    m = len(whole)
    tracemalloc.start()
    try:
        med = passes._order_statistics(pieces, ((m - 1) // 2, m // 2), cap=1 << 16)
        p99 = passes._percentile(pieces, 99, cap=1 << 16)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.mean(med) == np.median(whole)
    assert p99 == np.percentile(whole, 99)
    assert peak < 8e6
