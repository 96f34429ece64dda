"""The column-wise numpy helpers of the detectors (``row_norm``, ``row_dot``, ``rows_finite``, ``clipped_axes``)
give exactly, bit for bit, what the numpy expressions they replace give: the filter's output must not move."""

from __future__ import annotations

import numpy as np

from bootnav.postproc.checks import clipping_bits
from bootnav.core.arrays import clipped_axes, clipped_samples, row_dot, row_norm, rows_finite


def _rows(seed: int, n: int = 20000) -> np.ndarray:
    """(n, 3) values over 16 decades, both signs, with a few NaN / inf."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-8, 8, size=(n, 1))
    x[rng.integers(0, n, 5), rng.integers(0, 3, 5)] = np.nan
    x[rng.integers(0, n, 5), rng.integers(0, 3, 5)] = -np.inf
    return x


def test_row_helpers_are_bit_identical_to_numpy():
    x, y = _rows(0), _rows(1)
    assert np.array_equal(row_norm(x), np.linalg.norm(x, axis=1), equal_nan=True)
    assert np.array_equal(row_dot(x, y), np.sum(x * y, axis=1), equal_nan=True)
    assert np.array_equal(rows_finite(x), np.all(np.isfinite(x), axis=1))
    assert not rows_finite(x).all() and rows_finite(x).any()


def test_clipped_axes_per_axis_rails():
    """Integer counts: axis 0 pinned at ±25000, axis 2 at both rails of a two's-complement range (−25000,
    +24999), axis 1 free (its extremes are reached once each): the masks are exactly the pinned samples, and
    ``clipping_bits`` puts them at the axes' bits."""
    free = np.round(30000.0 * np.sin(np.linspace(0.0, 20.0, 400)))
    acc = np.column_stack([np.clip(free, -25000.0, 25000.0), 0.5 * free, np.clip(free, -25000.0, 24999.0)])
    masks = clipped_axes(acc)
    assert sorted(masks) == [0, 2]
    assert np.array_equal(masks[0], np.abs(free) >= 25000.0)
    assert np.array_equal(masks[2], (free <= -25000.0) | (free >= 24999.0))
    assert np.array_equal(clipped_samples(acc), masks[0] | masks[2])
    bits = clipping_bits(acc, acc[:, ::-1])
    for k, axis in ((0, 0), (2, 2), (3, 2), (5, 0)):  # gyro = acc with its axes reversed
        assert np.array_equal((bits >> k) & 1 == 1, masks[axis])
    assert not (bits & 0b010010).any()
