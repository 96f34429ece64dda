"""Rauch–Tung–Striebel smoothing of the error-state ZUPT filter over segments between stance phases.

Why segments: a full-record RTS needs every per-sample covariance (1 h at 200 Hz, 15 states: 2 GB).
The ZUPT filter forgets almost everything at each stance phase (velocity is pinned), so smoothing each
*segment* — from the first swing sample after a stance phase to the last sample of the next stance phase —
captures nearly all of the benefit: the velocity error revealed at heel strike is spread back over the swing
it accumulated in (position during the swing is corrected, stride length and height change improve).
Memory is bounded by a fixed ring of twice ``FilterSettings.smoother_max_segment_s`` worth of buffered samples
(one half filled while the other is smoothed, ``stream.py``); a longer segment (a very long swing or stance)
is closed early and smoothed in pieces (each piece ends on the filtered estimate, so the path stays
continuous).

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
The numba kernel computes P⁻(j+1)⁻¹ (…) without factorising P⁻: from the gain K and the weighted innovation
S⁻¹ν of each measurement update the filter made at j+1 (the modified Bryson–Frazier form, ``rts_backward``;
the same path as the Cholesky solve it replaced to ~1e-15 relative, docs/tuning-log.md). Only a sample with an
update from outside (``StreamNavigator.apply_measurement``, any H) is solved with the Cholesky factor of its
stored P⁻ (the lower triangle only: the factor reads nothing else; P is not exactly symmetric in floating
point, so P⁺, used whole, is stored whole).

``rts_backward`` is the numba kernel used by ``fast.py``; ``rts_backward_numpy`` is the same algorithm in
readable NumPy used by ``filterpy_engine.py``, which also takes its error dynamics A from ``error_dynamics`` here.
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


@njit(cache=True, inline="always")
def tri_index(i, c):
    """Position of element (i, c), c ≤ i, in a lower triangle packed row by row."""
    return i * (i + 1) // 2 + c


@njit(cache=True)
def _cholesky_pair(ap, bp, a, b, n):
    """Lower Cholesky factors of two SPD n×n matrices, whose lower triangles ``ap`` and ``bp`` hold (packed
    row by row, ``tri_index``), into the lower triangles of a and b. Returns (a is positive definite, b is).

    The two factorisations run interleaved, each with exactly the operations it would do alone: one
    factorisation is a chain of dependent divisions and square roots, two independent ones fill the
    processor's idle cycles (~30 % less time per matrix). A matrix found not positive definite is left
    half-done while the other one goes on."""
    ok_a, ok_b = True, True
    for j in range(n):
        sa, sb = ap[tri_index(j, j)], bp[tri_index(j, j)]
        for k in range(j):
            sa -= a[j, k] * a[j, k]
            sb -= b[j, k] * b[j, k]
        ok_a = ok_a and not sa <= 0.0
        ok_b = ok_b and not sb <= 0.0
        if not (ok_a or ok_b):
            break
        da = math.sqrt(sa) if ok_a else 1.0
        db = math.sqrt(sb) if ok_b else 1.0
        a[j, j], b[j, j] = da, db
        for i in range(j + 1, n):
            sa, sb = ap[tri_index(i, j)], bp[tri_index(i, j)]
            for k in range(j):
                sa -= a[i, k] * a[j, k]
                sb -= b[i, k] * b[j, k]
            a[i, j], b[i, j] = sa / da, sb / db
    return ok_a, ok_b


@njit(cache=True)
def _chol_solve(lf, b, n):
    """Solve (L Lᵀ) x = b in place in b (n,)."""
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= lf[i, k] * b[k]
        b[i] = s / lf[i, i]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for k in range(i + 1, n):
            s -= lf[k, i] * b[k]
        b[i] = s / lf[i, i]


@njit(cache=True)
def _transition_t_times(fpar, y, n, out):
    """out ← Fᵀ y with F = I + A Δt from fpar = (Δt, f_n(3), C_nb row-major(9)) (``build_transition``).

    Only the structurally non-zero entries of F enter, each summed in ascending row order from 0.0: the same
    floating-point result as the dense product over every row (a skipped term is an exact zero times a
    finite y, which leaves a sum started at +0.0 unchanged)."""
    dt = fpar[0]
    fx, fy, fz = fpar[1], fpar[2], fpar[3]
    for i in range(3):
        out[DP + i] = 0.0 + y[DP + i]
        out[DV + i] = (0.0 + dt * y[DP + i]) + y[DV + i]
    # column DTH + b: rows DV + a of −[f×] Δt, then the identity
    out[DTH] = ((0.0 + (-fz * dt) * y[DV + 1]) + (fy * dt) * y[DV + 2]) + y[DTH]
    out[DTH + 1] = ((0.0 + (fz * dt) * y[DV]) + (-fx * dt) * y[DV + 2]) + y[DTH + 1]
    out[DTH + 2] = ((0.0 + (-fy * dt) * y[DV]) + (fx * dt) * y[DV + 1]) + y[DTH + 2]
    if n == 15:
        for b in range(3):
            # column DBA + b: rows DV + a hold −C_nb[a, b] Δt; column DBG + b: rows DTH + a the same
            s = 0.0
            for a in range(3):
                s += (-fpar[4 + 3 * a + b] * dt) * y[DV + a]
            out[DBA + b] = s + y[DBA + b]
            s = 0.0
            for a in range(3):
                s += (-fpar[4 + 3 * a + b] * dt) * y[DTH + a]
            out[DBG + b] = s + y[DBG + b]


@njit(cache=True)
def rts_backward(bufs, b0, m, n, start, pos, vel, q, ba, bg):
    """Numba backward pass over one segment; corrects its output rows start..start+m−1 in place.

    ``bufs`` (``fast.SmootherBuffers``): the segment's m samples are the buffer rows (b0 + j) mod capacity,
    j = 0..m−1 (a ring: ``fast.py``), with the filter's posterior covariance P⁺ (n×n), the transition's
    parameters, the correction δx_upd and each measurement update the filter made there (its gain K, its
    weighted innovation S⁻¹ν and the states it measures). The vector recursion [RTS1965] in its modified
    Bryson–Frazier form [Bierman1977]: δx_s(j) = P⁺(j) Fᵀ y_j with y_j = P⁻(j+1)⁻¹ (δx_s(j+1) + δx_upd(j+1)),
    and with δx_s(j+1) = P⁺(j+1) w (w = Fᵀ y_{j+1} of the step before; 0 at the segment's end) and
    P⁺ = (I − K_r H_r) … (I − K_1 H_1) P⁻ for the sequential updates 1..r of that sample:

        y_j = (I − K_1 H_1)ᵀ ( … ((I − K_r H_r)ᵀ w + H_rᵀ S_r⁻¹ ν_r) … ) + H_1ᵀ S_1⁻¹ ν_1

    (a sample without update: y_j = w): no factorisation, a few dot products per update. At a sample with an
    update from outside (``updates`` −1, any H) y_j is solved with the Cholesky factor of P⁻(j+1), stored for
    it (packed lower triangle, ``tri_index``). Returns the number of steps where that P⁻ was not positive
    definite (the recursion restarts from zero there).
    """
    p_post, p_pred_tri, fpar, dx_upd, updates, gains, weights, blocks = bufs
    cap = p_post.shape[0]
    lf = np.empty((n, n))
    lg = np.empty((n, n))
    y = np.empty(n)
    fty = np.zeros(n)
    dxs = np.zeros(n)
    t = np.empty(3)
    bad = 0
    have_fty = False  # fty holds Fᵀ y of the step before, which δx_s(j+1) = P⁺(j+1) fty came from
    have_lg = False  # lg holds the factor of P⁻(j+1) (made with the step before's)
    ok_lg = False
    j = m - 2
    while j >= 0:
        jn = (b0 + j + 1) % cap
        r = updates[jn]
        if r >= 0:
            for i in range(n):
                y[i] = fty[i] if have_fty else 0.0
            for u in range(r - 1, -1, -1):  # the updates in reverse order
                first, mu = blocks[jn, u, 0], blocks[jn, u, 1]
                for c in range(mu):
                    s = 0.0
                    for i in range(n):
                        s += gains[jn, u, c, i] * y[i]
                    t[c] = s
                for c in range(mu):
                    y[first + c] += weights[jn, u, c] - t[c]
            have_lg = False
        else:
            if have_lg:
                lf, lg = lg, lf
                ok = ok_lg
                have_lg = False
            elif j > 0 and updates[(b0 + j) % cap] < 0:
                # the next step will need P⁻(j)'s factor too: both together (``_cholesky_pair``)
                ok, ok_lg = _cholesky_pair(p_pred_tri[jn], p_pred_tri[(b0 + j) % cap], lf, lg, n)
                have_lg = True
            else:
                ok, _ = _cholesky_pair(p_pred_tri[jn], p_pred_tri[jn], lf, lg, n)
            if not ok:
                for i in range(n):
                    dxs[i] = 0.0
                bad += 1
                have_fty = False
                j -= 1
                continue
            for i in range(n):
                y[i] = (dxs[i] if have_fty else 0.0) + dx_upd[jn, i]
            _chol_solve(lf, y, n)
        _backward_step(p_post, fpar, b0, cap, j, n, start, pos, vel, q, ba, bg, y, fty, dxs)
        have_fty = True
        j -= 1
    return bad


@njit(cache=True)
def _backward_step(p_post, fpar, b0, cap, j, n, start, pos, vel, q, ba, bg, y, fty, dxs):
    """One step of ``rts_backward``: δx_s(j) = P⁺(j) Fᵀ y into ``dxs`` (y: P⁻(j+1)⁻¹ (δx_s(j+1) +
    δx_upd(j+1)); Fᵀ y is left in ``fty``), and the correction of output row start + j."""
    jb = (b0 + j) % cap
    jn = (b0 + j + 1) % cap
    _transition_t_times(fpar[jn], y, n, fty)
    for i in range(n):
        s = 0.0
        for k in range(n):
            s += p_post[jb, i, k] * fty[k]
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


@njit(cache=True)
def _rotate_left(q, kk, tx, ty, tz):
    """q[kk] ← exp(δθ/2) ⊗ q[kk], normalised with w ≥ 0 (same algebra as quaternion.correct_attitude)."""
    q[kk, 0], q[kk, 1], q[kk, 2], q[kk, 3] = exp_times_quat(q[kk, 0], q[kk, 1], q[kk, 2], q[kk, 3], tx, ty, tz)
