"""Rauch–Tung–Striebel smoothing of the error-state ZUPT filter over segments between stance phases.

Why segments: a full-record RTS needs every per-sample covariance (1 h at 200 Hz, 15 states: 2 GB).
The ZUPT filter forgets almost everything at each stance phase (velocity is pinned), so smoothing each
*segment* — from the first swing sample after a stance phase to the last sample of the next stance phase —
captures nearly all of the benefit: the velocity error revealed at heel strike is spread back over the swing
it accumulated in (position during the swing is corrected, stride length and height change improve).
Memory is bounded by ``FilterSettings.smoother_max_segment_s`` worth of buffered samples; a longer segment
(a very long swing or stance) is closed early and smoothed in pieces (each piece ends on the filtered estimate,
so the path stays continuous).

Backward recursion on the error state [RTS1965]; error-state form as in [Colomar2012] (Colomar, Nilsson &
Händel, "Smoothing for ZUPT-aided INSs", IPIN 2012). For the buffered samples j = 0..m−1:

    δx_s(m−1) = 0                                               (segment end: the filtered estimate)
    G_j       = P⁺(j) F_{j+1}ᵀ P⁻(j+1)⁻¹
    δx_s(j)   = G_j (δx_s(j+1) + δx_upd(j+1))                  (δx_upd: the correction the filter applied
                                                                at j+1, since its nominal was reset there)

and the nominal state at sample j is corrected like a filter update (p, v, biases additive; q ← exp(δθ/2) ⊗ q).
The smoothed covariance P_s is not computed (it would cost two n×n×n products per sample):
``NavSolution.pos_sigma_n`` stays the filter's sigma, an upper bound of the smoothed one.
``F_{j+1}`` is rebuilt from the stored (Δt, f_n, C_nb) of the step into j+1 (13 numbers, not n² numbers).

``rts_backward`` is the numba kernel used by ``fast.py``; ``rts_backward_numpy`` is the same algorithm in
readable NumPy used by ``reference.py``, which also takes its error dynamics A from ``error_dynamics`` here.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bootnav.postproc.ins.kernels import exp_times_quat
from bootnav.postproc.ins.layout import DBA, DBG, DP, DTH, DV, ERR_BA, ERR_BG, ERR_P, ERR_TH, ERR_V
from bootnav.postproc.ins.quaternion import correct_attitude


_I3 = np.eye(3)


def skew(v: np.ndarray) -> np.ndarray:
    """[v×], the cross-product matrix."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def error_dynamics(f_n: np.ndarray, c_nb: np.ndarray, n: int) -> np.ndarray:
    """Continuous-time A of the error state (``filter.py`` docstring; readable form, ``fast.py`` has the blocks)."""
    a = np.zeros((n, n))
    a[ERR_P, ERR_V] = _I3
    a[ERR_V, ERR_TH] = -skew(f_n)
    if n == 15:
        a[ERR_V, ERR_BA] = -c_nb
        a[ERR_TH, ERR_BG] = -c_nb
    return a


def build_transition(fpar: np.ndarray, n: int) -> np.ndarray:
    """Discrete error-state transition F = I + A Δt from fpar = (Δt, f_n(3), C_nb row-major(9))."""
    return np.eye(n) + error_dynamics(fpar[1:4], fpar[4:13].reshape(3, 3), n) * fpar[0]


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
    pos += dx[ERR_P]
    vel += dx[ERR_V]
    q[:] = correct_attitude(q, dx[ERR_TH])
    if dx.shape[0] == 15:
        ba += dx[ERR_BA]
        bg += dx[ERR_BG]


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
        f[DP + i, DV + i] = dt
    # −[f×] Δt
    f[DV, DTH + 1] = fz * dt
    f[DV, DTH + 2] = -fy * dt
    f[DV + 1, DTH] = -fz * dt
    f[DV + 1, DTH + 2] = fx * dt
    f[DV + 2, DTH] = fy * dt
    f[DV + 2, DTH + 1] = -fx * dt
    if n == 15:
        for i in range(3):
            for j in range(3):
                f[DV + i, DBA + j] = -fpar[4 + 3 * i + j] * dt
                f[DTH + i, DBG + j] = -fpar[4 + 3 * i + j] * dt


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
            pos[kk, i] += dxs[DP + i]
            vel[kk, i] += dxs[DV + i]
        if n == 15:
            for i in range(3):
                ba[kk, i] += dxs[DBA + i]
                bg[kk, i] += dxs[DBG + i]
        _rotate_left(q, kk, dxs[DTH], dxs[DTH + 1], dxs[DTH + 2])
    return bad


@njit(cache=True)
def _rotate_left(q, kk, tx, ty, tz):
    """q[kk] ← exp(δθ/2) ⊗ q[kk], normalised with w ≥ 0 (same algebra as quaternion.correct_attitude)."""
    q[kk, 0], q[kk, 1], q[kk, 2], q[kk, 3] = exp_times_quat(q[kk, 0], q[kk, 1], q[kk, 2], q[kk, 3], tx, ty, tz)
