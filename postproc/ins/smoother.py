"""Rauch–Tung–Striebel smoothing of the error-state ZUPT filter over segments between stance phases.

Why segments: a full-record RTS needs every per-sample covariance (1 h at 200 Hz, 15 states: 2 GB).
The ZUPT filter forgets almost everything at each stance phase (velocity is pinned), so smoothing each
*segment* — from the first swing sample after a stance phase to the last sample of the next stance phase —
captures nearly all of the benefit: the velocity error revealed at heel strike is spread back over the swing
it accumulated in (position during the swing is corrected, stride length and height change improve).
Memory is bounded by ``FilterSettings.smoother_max_segment_s`` worth of buffered samples; a longer segment
(a very long swing or stance) is closed early and smoothed in pieces (each piece ends on the filtered estimate,
so the path stays continuous).

Backward recursion on the error state (Rauch, Tung & Striebel 1965; error-state form as in e.g.
Colomar, Nilsson & Händel, "Smoothing for ZUPT-aided INSs", IPIN 2012). For the buffered samples j = 0..m−1:

    δx_s(m−1) = 0                                               (segment end: the filtered estimate)
    G_j       = P⁺(j) F_{j+1}ᵀ P⁻(j+1)⁻¹
    δx_s(j)   = G_j (δx_s(j+1) + δx_upd(j+1))                  (δx_upd: the correction the filter applied
                                                                at j+1, since its nominal was reset there)

and the nominal state at sample j is corrected like a filter update (p, v, biases additive; q ← exp(δθ/2) ⊗ q).
The smoothed covariance P_s is not computed (it would cost two n×n×n products per sample):
``NavSolution.pos_sigma_n`` stays the filter's sigma, an upper bound of the smoothed one.
``F_{j+1}`` is rebuilt from the stored (Δt, f_n, C_nb) of the step into j+1 (13 numbers, not n² numbers).

``rts_backward`` is the numba kernel used by ``fast.py``; ``rts_backward_numpy`` is the same algorithm in
readable NumPy used by ``reference.py``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bootnav.postproc.ins.kernels import exp_times_quat
from bootnav.postproc.ins.quaternion import correct_attitude


def build_transition(fpar: np.ndarray, n: int) -> np.ndarray:
    """Discrete error-state transition F = I + A Δt (readable form, see ``fast.py`` for A)."""
    dt = fpar[0]
    f_n = fpar[1:4]
    c_nb = fpar[4:13].reshape(3, 3)
    a = np.zeros((n, n))
    a[0:3, 3:6] = np.eye(3)
    a[3:6, 6:9] = -np.array([[0.0, -f_n[2], f_n[1]], [f_n[2], 0.0, -f_n[0]], [-f_n[1], f_n[0], 0.0]])
    if n == 15:
        a[3:6, 9:12] = -c_nb
        a[6:9, 12:15] = -c_nb
    return np.eye(n) + a * dt


def rts_backward_numpy(p_post, p_pred, fpar, dx_upd, m, n):
    """Readable backward pass. Returns δx_s (m, n)."""
    dxs = np.zeros((m, n))
    for j in range(m - 2, -1, -1):
        f = build_transition(fpar[j + 1], n)
        g = p_post[j] @ f.T @ np.linalg.inv(p_pred[j + 1])  # RTS gain G_j
        dxs[j] = g @ (dxs[j + 1] + dx_upd[j + 1])
    return dxs


def apply_smoothed_correction(pos, vel, q, ba, bg, dx):
    """Add a smoothed error estimate to one sample's nominal state (readable form)."""
    pos += dx[0:3]
    vel += dx[3:6]
    q[:] = correct_attitude(q, dx[6:9])
    if dx.shape[0] == 15:
        ba += dx[9:12]
        bg += dx[12:15]


# ---------------------------------------------------------------------------------------------- numba kernel


@njit(cache=True)
def _transition_into(fpar, n, f):
    """Fill f (n×n) with I + A Δt from fpar = (Δt, f_n(3), C_nb row-major(9))."""
    for i in range(n):
        for j in range(n):
            f[i, j] = 0.0
        f[i, i] = 1.0
    dt = fpar[0]
    fx, fy, fz = fpar[1], fpar[2], fpar[3]
    for i in range(3):
        f[i, 3 + i] = dt
    # −[f×] Δt
    f[3, 7] = fz * dt
    f[3, 8] = -fy * dt
    f[4, 6] = -fz * dt
    f[4, 8] = fx * dt
    f[5, 6] = fy * dt
    f[5, 7] = -fx * dt
    if n == 15:
        for i in range(3):
            for j in range(3):
                f[3 + i, 9 + j] = -fpar[4 + 3 * i + j] * dt
                f[6 + i, 12 + j] = -fpar[4 + 3 * i + j] * dt


@njit(cache=True)
def _cholesky_inplace(a, n):
    """Lower Cholesky factor in the lower triangle of a (SPD n×n). Returns False if not positive definite."""
    for j in range(n):
        s = a[j, j]
        for k in range(j):
            s -= a[j, k] * a[j, k]
        if s <= 0.0:
            return False
        d = math.sqrt(s)
        a[j, j] = d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= a[i, k] * a[j, k]
            a[i, j] = s / d
    return True


@njit(cache=True)
def _chol_solve(lf, b, n, ncol):
    """Solve (L Lᵀ) X = B in place in b (n×ncol)."""
    for c in range(ncol):
        for i in range(n):
            s = b[i, c]
            for k in range(i):
                s -= lf[i, k] * b[k, c]
            b[i, c] = s / lf[i, i]
        for i in range(n - 1, -1, -1):
            s = b[i, c]
            for k in range(i + 1, n):
                s -= lf[k, i] * b[k, c]
            b[i, c] = s / lf[i, i]


@njit(cache=True)
def rts_backward(p_post, p_pred, fpar, dx_upd, m, n, start, pos, vel, q, ba, bg):
    """Numba backward pass over buffer entries 0..m−1 (= samples start..start+m−1); corrects outputs in place.

    Only the vector recursion is needed: δx_s(j) = P⁺(j) Fᵀ y with P⁻(j+1) y = δx_s(j+1) + δx_upd(j+1)
    (one Cholesky solve per sample, no n×n gain matrix). Returns the number of steps where P⁻ was not
    positive definite (the recursion restarts from zero there).
    """
    f = np.empty((n, n))
    lf = np.empty((n, n))
    y = np.empty((n, 1))
    fty = np.empty(n)
    dxs = np.zeros(n)
    bad = 0
    for j in range(m - 2, -1, -1):
        for i in range(n):
            y[i, 0] = dxs[i] + dx_upd[j + 1, i]
            for c in range(n):
                lf[i, c] = p_pred[j + 1, i, c]
        if not _cholesky_inplace(lf, n):
            bad += 1
            for i in range(n):
                dxs[i] = 0.0
            continue
        _chol_solve(lf, y, n, 1)
        _transition_into(fpar[j + 1], n, f)
        for i in range(n):
            s = 0.0
            for k in range(n):
                s += f[k, i] * y[k, 0]
            fty[i] = s
        for i in range(n):
            s = 0.0
            for k in range(n):
                s += p_post[j, i, k] * fty[k]
            dxs[i] = s
        kk = start + j
        for i in range(3):
            pos[kk, i] += dxs[i]
            vel[kk, i] += dxs[3 + i]
        if n == 15:
            for i in range(3):
                ba[kk, i] += dxs[9 + i]
                bg[kk, i] += dxs[12 + i]
        _rotate_left(q, kk, dxs[6], dxs[7], dxs[8])
    return bad


@njit(cache=True)
def _rotate_left(q, kk, tx, ty, tz):
    """q[kk] ← exp(δθ/2) ⊗ q[kk], normalised with w ≥ 0 (same algebra as quaternion.correct_attitude)."""
    q[kk, 0], q[kk, 1], q[kk, 2], q[kk, 3] = exp_times_quat(q[kk, 0], q[kk, 1], q[kk, 2], q[kk, 3], tx, ty, tz)
