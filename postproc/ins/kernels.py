"""Scalar quaternion kernels shared by the numba filter and smoother (wxyz, normalised, w >= 0).

``rotmat_into`` is also the reference engine's DCM: ``quaternion.quat_to_rotmat`` runs its ``py_func``.

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
    """q ⊗ exp(θ/2): body-frame rotation increment (strapdown attitude update, [Heidari2019, eq. 1] row 3)."""
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


@njit(cache=True, inline="always")
def rotmat_into(c, qw, qx, qy, qz):
    """Write the direction-cosine matrix ``C_nb`` of the unit quaternion ``q_nb`` into ``c`` (v_n = C_nb v_b)."""
    c[0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    c[0, 1] = 2.0 * (qx * qy - qw * qz)
    c[0, 2] = 2.0 * (qx * qz + qw * qy)
    c[1, 0] = 2.0 * (qx * qy + qw * qz)
    c[1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    c[1, 2] = 2.0 * (qy * qz - qw * qx)
    c[2, 0] = 2.0 * (qx * qz - qw * qy)
    c[2, 1] = 2.0 * (qy * qz + qw * qx)
    c[2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)
