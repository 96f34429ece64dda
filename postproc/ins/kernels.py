"""Scalar quaternion kernels shared by the numba filter and smoother (wxyz, normalised, w >= 0).

Kept as tiny @njit functions that numba inlines, so the hot loops call one definition instead of
repeating the algebra. ``exp(θ/2)`` is the unit quaternion of the rotation vector θ; for |θ| < 1e-8 the
sin(|θ|/2)/|θ| factor uses its series 1/2 − |θ|²/48.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, inline="always")
def _exp_half(tx, ty, tz):
    a = math.sqrt(tx * tx + ty * ty + tz * tz)
    cw = math.cos(0.5 * a)
    s = math.sin(0.5 * a) / a if a > 1e-8 else 0.5 - a * a / 48.0
    return cw, s * tx, s * ty, s * tz


@njit(cache=True, inline="always")
def _normalised(nw, nx, ny, nz):
    nn = math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
    if nw < 0.0:
        nn = -nn
    return nw / nn, nx / nn, ny / nn, nz / nn


@njit(cache=True, inline="always")
def quat_times_exp(qw, qx, qy, qz, tx, ty, tz):
    """q ⊗ exp(θ/2): body-frame rotation increment (strapdown attitude update, seed-004 eq. 1 row 3)."""
    cw, px, py, pz = _exp_half(tx, ty, tz)
    return _normalised(qw * cw - qx * px - qy * py - qz * pz,
                       qw * px + qx * cw + qy * pz - qz * py,
                       qw * py - qx * pz + qy * cw + qz * px,
                       qw * pz + qx * py - qy * px + qz * cw)


@njit(cache=True, inline="always")
def exp_times_quat(qw, qx, qy, qz, tx, ty, tz):
    """exp(δθ/2) ⊗ q: navigation-frame attitude correction of the error-state filter (eq. 3)."""
    cw, px, py, pz = _exp_half(tx, ty, tz)
    return _normalised(cw * qw - px * qx - py * qy - pz * qz,
                       cw * qx + px * qw + py * qz - pz * qy,
                       cw * qy - px * qz + py * qw + pz * qx,
                       cw * qz + px * qy - py * qx + pz * qw)
