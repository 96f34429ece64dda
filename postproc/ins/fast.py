"""Fast engine: the whole ZUPT error-state filter (+ segment RTS smoother) as one numba kernel.

No per-sample Python loop: Python only slices the record into a few chunks (for the progress callback).
The algebra is exactly ``filterpy_engine.py``'s, written for speed:

* mechanization with scalar locals (no small-array allocation per sample);
* covariance propagation P ← F P Fᵀ + Q_d in place with the block structure of
  F = I + A Δt, A = [[0, I, 0, 0, 0], [0, 0, −[f_n×], −C_nb, 0], [0, 0, 0, 0, −C_nb], 0, 0]
  (rows then columns; the 9-state case touches 6 + 9 rows/columns instead of a dense 9×9×9 product);
* the measurement models of ``measurements.py`` (the same jitted functions the reference engine calls),
  applied sequentially in registry order; the loop over the registry is unrolled at compile time, so each
  model's H = [0 I 0] is a constant index block (``kalman.py``: no H matrix, closed-form 3×3 innovation
  inverse or a scalar gain, Joseph form (I − KH) P (I − KH)ᵀ + K R Kᵀ by blocks).

Error-state conventions (shared with filterpy_engine.py, see ``bootnav.postproc.ins.filter``): δx = x_true − x̂, so
the ZUPT pseudo-measurement is z = 0 − v̂ = δv + noise, δx = K z, then p̂ += δp, v̂ += δv, q̂ ← exp(δθ/2) ⊗ q̂,
b̂ += δb, δx ← 0. The "+ k_n v_n" of [Heidari2019, eq. 3] is this with the minus sign of z absorbed in k_n.

Python drives the kernel through ``stream.StreamNavigator`` (the one incremental engine; ``stream.run_fast``
pushes a whole record through it): ``filter_chunk`` filters a chunk and carries the filter state and the
smoother's open segment to the next call; it lists every segment it closes, ``close_segment`` ends the
record's last one, and ``smooth_segments`` runs the RTS backward pass over listed segments. A closed segment
depends on nothing the filter still writes, so the navigator smooths batches of them in a second thread
while the filter goes on (a pipeline over two cores). All three release the GIL (``nogil``), so independent
runs in threads use separate cores too (the two timing probes of ``selftune.level_timing_offset``).

Numba's on-disk cache of a function is stamped with the hash of its own source file only, while the cached
code contains the jitted functions it calls from other modules (``measurements.py``, ``kalman.py``,
``kernels.py``, ``riccati.py``, ``smoother.py``, ...): editing one of those would leave a stale kernel.
``key_cache_on_sources`` stamps the kernels' cache with the hash of this file and of every module of this
package it imports, transitively (``kernel_sources``), so an edit of any of them recompiles the kernels
(once; ``ensure_compiled`` tells the registered ``compile_notice`` listeners first).
"""

from __future__ import annotations

import hashlib
import math
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np
from typing import NamedTuple

from numba import literal_unroll, njit

from bootnav.postproc.ins.kernels import exp_times_quat, quat_times_exp, rotmat_into
from bootnav.postproc.ins.layout import BIAS_ACC, BIAS_GYRO, DBA, DBG, DP, DTH, DV, N_NOMINAL, POS, QUAT, VEL
from bootnav.postproc.ins.kalman import innovation_weight, joseph3, sequential_update
from bootnav.postproc.ins.measurements import KERNEL_REGISTRY, MAX_ROWS, N_KINDS, ZUPT, measure, zupt
from bootnav.postproc.ins.riccati import gain_into
from bootnav.postproc.ins.smoother import rts_backward, tri_index


def _no_refcount_option() -> dict:
    """``{"_nrt": False}``: numba's private option that compiles a function without
    reference counting, for the allocation-free loop of the kernel (``_filter_rows``); {} where a numba release
    no longer has it (the loop is then ~20 % slower; the results are the same)."""
    try:
        from numba.core.options import DefaultOptions
    except ImportError:
        return {}
    return {"_nrt": False} if hasattr(DefaultOptions, "_nrt") else {}


NO_REFCOUNT = _no_refcount_option()

# smoother bookkeeping counters
SMOOTHER_SKIPPED, SMOOTHER_SEGMENTS = 0, 1
# the smoother's state ``seg``: open segment's length, its first output row, its first buffer row (absolute: the
# buffer row is this modulo the ring's capacity), the oldest buffer row still needed (absolute), closed
# segments waiting in ``closed``
SEG_LEN, SEG_ROW, SEG_RING, SEG_TAIL, SEG_N_CLOSED = 0, 1, 2, 3, 4
N_SEG = 5
# a closed segment (row of ``closed``): its first buffer row (absolute), its length, its first output row
CL_RING, CL_LEN, CL_ROW = 0, 1, 2


@njit(cache=True, inline="always")
def _rows_times_f(P, n, dt, fx, fy, fz, c):
    """P ← F P in place, row by row (F = I + A Δt, block form; see module docstring).

    Each row operation runs along contiguous rows (vectorised); every entry gets the same operations in the
    same order as the entry-by-entry form, and each reads the rows it needs before they change."""
    for i in range(3):
        for m in range(n):
            P[DP + i, m] += dt * P[DV + i, m]
    for m in range(n):
        t0, t1, t2 = P[DTH, m], P[DTH + 1, m], P[DTH + 2, m]
        P[DV, m] += dt * (fz * t1 - fy * t2)
        P[DV + 1, m] += dt * (fx * t2 - fz * t0)
        P[DV + 2, m] += dt * (fy * t0 - fx * t1)
    if n == 15:
        c00, c01, c02 = c[0, 0], c[0, 1], c[0, 2]
        c10, c11, c12 = c[1, 0], c[1, 1], c[1, 2]
        c20, c21, c22 = c[2, 0], c[2, 1], c[2, 2]
        for m in range(n):
            b0, b1, b2 = P[DBA, m], P[DBA + 1, m], P[DBA + 2, m]
            P[DV, m] -= dt * (c00 * b0 + c01 * b1 + c02 * b2)
            P[DV + 1, m] -= dt * (c10 * b0 + c11 * b1 + c12 * b2)
            P[DV + 2, m] -= dt * (c20 * b0 + c21 * b1 + c22 * b2)
        for m in range(n):
            b0, b1, b2 = P[DBG, m], P[DBG + 1, m], P[DBG + 2, m]
            P[DTH, m] -= dt * (c00 * b0 + c01 * b1 + c02 * b2)
            P[DTH + 1, m] -= dt * (c10 * b0 + c11 * b1 + c12 * b2)
            P[DTH + 2, m] -= dt * (c20 * b0 + c21 * b1 + c22 * b2)


@njit(cache=True)
def _propagate_cov(P, n, dt, fx, fy, fz, c, qa, qg, qba, qbg):
    """P ← F P Fᵀ + Q_d in place (F = I + A Δt, block form; see module docstring): F P by rows
    (``_rows_times_f``, contiguous inner loops), then (F P) Fᵀ row by row."""
    _rows_times_f(P, n, dt, fx, fy, fz, c)
    for m in range(n):  # columns: (F P) Fᵀ
        for i in range(3):
            P[m, DP + i] += dt * P[m, DV + i]
        t0, t1, t2 = P[m, DTH], P[m, DTH + 1], P[m, DTH + 2]
        P[m, DV] += dt * (fz * t1 - fy * t2)
        P[m, DV + 1] += dt * (fx * t2 - fz * t0)
        P[m, DV + 2] += dt * (fy * t0 - fx * t1)
        if n == 15:
            for i in range(3):
                P[m, DV + i] -= dt * (c[i, 0] * P[m, DBA] + c[i, 1] * P[m, DBA + 1] + c[i, 2] * P[m, DBA + 2])
            for i in range(3):
                P[m, DTH + i] -= dt * (c[i, 0] * P[m, DBG] + c[i, 1] * P[m, DBG + 1] + c[i, 2] * P[m, DBG + 2])
    for i in range(3):
        P[DV + i, DV + i] += qa * dt
        P[DTH + i, DTH + i] += qg * dt
    if n == 15:
        for i in range(3):
            P[DBA + i, DBA + i] += qba * dt
            P[DBG + i, DBG + i] += qbg * dt


@njit(cache=True, inline="always")
def _store_prior(buf_pred, j, P, n):
    """Buffer row j of P⁻ ← the lower triangle of P, packed (``smoother.tri_index``)."""
    for a_ in range(n):
        for b_ in range(a_ + 1):
            buf_pred[j, tri_index(a_, b_)] = P[a_, b_]


class KernelInputs(NamedTuple):
    """The input rows of a ``filter_chunk`` call (row 0 is the sample before the chunk)."""

    dt_s: np.ndarray  # (L+1,) s, step to each row
    acc: np.ndarray  # (L+1, 3) m/s², specific force
    gyro: np.ndarray  # (L+1, 3) rad/s
    stance: np.ndarray  # (L+1,) bool, the ZUPT mask
    xvar: np.ndarray  # (L+1, 6) extra process variance of saturated rows
    ric_tau: np.ndarray  # (L+1,) s, the open-loop interval a ZUPT run closes (paper mode)


class RiccatiGain(NamedTuple):
    """The paper mode's constant ZUPT gain factors (``riccati.ZuptGain``; identity and zeros otherwise)."""

    u: np.ndarray  # (3, 3)
    lam: np.ndarray  # (3,)
    t: np.ndarray  # (6, 3)


class PathRows(NamedTuple):
    """The output rows the filter writes and the smoother corrects in place."""

    pos: np.ndarray  # (M, 3) m
    vel: np.ndarray  # (M, 3) m/s
    q: np.ndarray  # (M, 4) wxyz
    ba: np.ndarray  # (M, 3) m/s²
    bg: np.ndarray  # (M, 3) rad/s


class SmootherBuffers(NamedTuple):
    """The ring of the smoother's open and closed segments (``filter_chunk`` docstring)."""

    post: np.ndarray  # (cap, n, n) P⁺
    pred: np.ndarray  # (cap, n(n+1)/2) P⁻, packed lower triangle, written only at the last row a call filters
    #                   (``StreamNavigator.apply_measurement`` updates the last filtered sample) if it has updates
    fpar: np.ndarray  # (cap, 13) the transition's parameters
    dx: np.ndarray  # (cap, n) the error-state correction
    updates: np.ndarray  # (cap,) int64, the row's measurement updates listed below (0: none, P⁺ = P⁻, dx = 0;
    #                      −1: an update from outside, ``StreamNavigator.apply_measurement``: the smoother factorises P⁻)
    gains: np.ndarray  # (cap, N_KINDS, 3, n) the gain Kᵀ of each update, in the order made
    weights: np.ndarray  # (cap, N_KINDS, 3) S⁻¹ ν of each update (``kalman.innovation_weight``)
    blocks: np.ndarray  # (cap, N_KINDS, 2) int64, the states each update measures: first, count


class FilterModel(NamedTuple):
    """What a run's filter computes with, fixed for the run (``StreamNavigator.kernel_model``)."""

    prm: object  # params.KernelParams
    active: np.ndarray  # (N_KINDS,) bool, which measurement models run (``measurements.active_flags``)
    n: int  # error states, 9 or 15
    ric: RiccatiGain  # the paper mode's ZUPT gain


class FilterState(NamedTuple):
    """The filter's state at the last filtered sample, updated in place and carried from call to call."""

    nominal: np.ndarray  # (N_NOMINAL,) the nominal state (``layout.py``)
    cov: np.ndarray  # (n, n) the error-state covariance P


class PathUncertainty(NamedTuple):
    """The filter's (not smoothed) position uncertainty of each output row."""

    pos_sigma: np.ndarray  # (M, 3) m, 1-σ per axis
    pos_cov_en: np.ndarray  # (M,) m², the east-north covariance P_EN (the horizontal ellipse, ``strides.ellipse``)


class SegmentBook(NamedTuple):
    """The smoother's bookkeeping of its segments in the ring of ``SmootherBuffers``."""

    seg: np.ndarray  # (N_SEG,) int64, the open segment and the ring's tail (SEG_* indices)
    closed: np.ndarray  # (c, 3) int64, the closed segments waiting to be smoothed (CL_* columns)
    batch_rows: int  # hand closed segments on once they hold this many buffer rows; 0: smooth each one in the kernel


class RunCounts(NamedTuple):
    """Counters of a run, incremented in place."""

    applied: np.ndarray  # (N_KINDS,) int64, updates of each measurement model
    smoother: np.ndarray  # (2,) int64, SMOOTHER_SKIPPED steps and SMOOTHER_SEGMENTS


@njit(cache=True, nogil=True)
def close_segment(seg, closed, counters, next_row):
    """End the open segment: list it in ``closed`` to be smoothed (``smooth_segments``; one sample needs no
    smoothing) and open the next one at output row ``next_row``, in the buffer rows that follow."""
    m = seg[SEG_LEN]
    if m > 1:
        c = seg[SEG_N_CLOSED]
        closed[c, CL_RING] = seg[SEG_RING]
        closed[c, CL_LEN] = m
        closed[c, CL_ROW] = seg[SEG_ROW]
        seg[SEG_N_CLOSED] = c + 1
    counters[SMOOTHER_SEGMENTS] += 1
    seg[SEG_LEN] = 0
    seg[SEG_ROW] = next_row
    seg[SEG_RING] += m


@njit(cache=True, nogil=True)
def smooth_segments(closed, n, rows, bufs):
    """Smooth the closed segments listed in ``closed`` (rows CL_RING, CL_LEN, CL_ROW; ``smoother.rts_backward``
    corrects their output rows in place). Returns the smoother's skipped steps.

    Closed segments are independent of each other and of the forward filter (which only writes buffer rows
    after the oldest one still listed, ``seg[SEG_TAIL]``, and output rows after theirs), so this may run in
    another thread while ``filter_chunk`` goes on."""
    pos, vel, q, ba, bg = rows
    bad = 0
    for i in range(closed.shape[0]):
        bad += rts_backward(bufs, closed[i, CL_RING], closed[i, CL_LEN], n, closed[i, CL_ROW], pos, vel, q, ba, bg)
    return bad


@njit(cache=True, inline="always")
def _segment_ended(seg, stance, k, max_segment):
    """Whether input row k shows that the smoother's open segment ended: after the last sample of a stance
    phase, or at ``max_segment`` samples."""
    return seg[SEG_LEN] > 0 and (seg[SEG_LEN] >= max_segment or (stance[k - 1] and not stance[k]))


@njit(cache=True)
def _close_ended_segment(r, prm, n, rows, bufs, book, counters):
    """Close the open segment, ended before output row r; smooth it here without a smoothing thread
    (``book.batch_rows`` 0). Returns whether ``filter_chunk`` must return to let its caller smooth (or hand
    on) the closed segments (``filter_chunk`` docstring)."""
    seg, closed, batch_rows = book
    close_segment(seg, closed, counters, r)
    nc = seg[SEG_N_CLOSED]
    if batch_rows == 0:  # no smoothing thread: smooth it now, while its buffers are in the cache
        if nc > 0:
            counters[SMOOTHER_SKIPPED] += smooth_segments(closed[:nc], n, rows, bufs)
            seg[SEG_N_CLOSED] = 0
        seg[SEG_TAIL] = seg[SEG_RING]
        return False
    return (nc == closed.shape[0] or (nc > 0 and seg[SEG_RING] - closed[0, CL_RING] >= batch_rows)
            or seg[SEG_RING] + prm.max_segment - seg[SEG_TAIL] > bufs.post.shape[0])


@njit(cache=True, inline="always")
def _strapdown(st, c, acc, gyro, k, dt, prm):
    """Mechanization of input row k over the step ``dt``: attitude, C_nb into ``c``, then velocity and position
    (a step of 0, a repeated time, only rotates f_b). Returns f_n and the bias-corrected f_b (x, y, z each)."""
    ip, iv, iq, iba, ibg = POS.start, VEL.start, QUAT.start, BIAS_ACC.start, BIAS_GYRO.start
    qw, qx, qy, qz = st[iq], st[iq + 1], st[iq + 2], st[iq + 3]
    if dt > 0.0:
        # [Heidari2019, eq. 1] row 3: q ← q ⊗ exp(ωΔt/2)
        tx = (gyro[k, 0] - st[ibg]) * dt
        ty = (gyro[k, 1] - st[ibg + 1]) * dt
        tz = (gyro[k, 2] - st[ibg + 2]) * dt
        if prm.midpoint:  # f_b rotated with the attitude at the middle of the step (mechanization.py)
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, 0.5 * tx, 0.5 * ty, 0.5 * tz)
            rotmat_into(c, qw, qx, qy, qz)
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, 0.5 * tx, 0.5 * ty, 0.5 * tz)
        else:
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, tx, ty, tz)
        st[iq], st[iq + 1], st[iq + 2], st[iq + 3] = qw, qx, qy, qz
    if not (prm.midpoint and dt > 0.0):
        rotmat_into(c, qw, qx, qy, qz)
    fbx, fby, fbz = acc[k, 0] - st[iba], acc[k, 1] - st[iba + 1], acc[k, 2] - st[iba + 2]
    fx = c[0, 0] * fbx + c[0, 1] * fby + c[0, 2] * fbz
    fy = c[1, 0] * fbx + c[1, 1] * fby + c[1, 2] * fbz
    fz = c[2, 0] * fbx + c[2, 1] * fby + c[2, 2] * fbz
    if dt > 0.0:
        ax, ay, az = fx, fy, fz - prm.gravity
        hdt2 = 0.5 * dt * dt
        st[ip] += st[iv] * dt + ax * hdt2
        st[ip + 1] += st[iv + 1] * dt + ay * hdt2
        st[ip + 2] += st[iv + 2] * dt + az * hdt2
        st[iv] += ax * dt
        st[iv + 1] += ay * dt
        st[iv + 2] += az * dt
    return fx, fy, fz, fbx, fby, fbz


@njit(cache=True, inline="always")
def _propagate(P, n, dt, c, fx, fy, fz, fbx, fby, fbz, st, gyro, xvar, k, prm):
    """P ← F P Fᵀ + Q_d over the step ``dt`` > 0 of input row k (f_n, f_b from ``_strapdown``), with the
    signal-proportional noise and the extra variance of saturated axes."""
    ibg = BIAS_GYRO.start
    # signal-proportional (scale-factor) noise: σ_k² = σ² + (κ |signal_k|)² (settings.py)
    qa = prm.var_acc + prm.var_acc_scale * (fbx * fbx + fby * fby + fbz * fbz)
    wx, wy, wz = gyro[k, 0] - st[ibg], gyro[k, 1] - st[ibg + 1], gyro[k, 2] - st[ibg + 2]
    qg = prm.var_gyro + prm.var_gyro_scale * (wx * wx + wy * wy + wz * wz)
    _propagate_cov(P, n, dt, fx, fy, fz, c, qa, qg, prm.var_acc_bias_rw, prm.var_gyro_bias_rw)
    # saturated axes (xvar: extra per-sample variance × Δt₀ per body axis ax..gz): the unknown part of
    # a clipped sample acts along that body axis only, i.e. along column a of C_nb in the nav frame
    for ax_ in range(6):
        qx_ = xvar[k, ax_]
        if qx_ > 0.0:
            o = DV if ax_ < 3 else DTH
            col = ax_ % 3
            for i in range(3):
                for m in range(3):
                    P[o + i, o + m] += qx_ * dt * c[i, col] * c[m, col]


@njit(cache=True, inline="always")
def _store_transition(fpar, j, dt, fx, fy, fz, c):
    """Buffer row j of the transition's parameters (Δt, f_n, C_nb: the smoother rebuilds F from them)."""
    fpar[j, 0] = dt
    fpar[j, 1], fpar[j, 2], fpar[j, 3] = fx, fy, fz
    for a_ in range(3):
        for b_ in range(3):
            fpar[j, 4 + 3 * a_ + b_] = c[a_, b_]


@njit(cache=True, inline="always")
def _paper_zupt(k, dt, tau, c, acc, gyro, stance, ric, prm, n, st, P, dx, z, K, A, applied):
    """The paper mode's ZUPT at a stance row: the constant Riccati gain per step (``riccati.gain_into``, ``tau``
    the open-loop interval) on the ZUPT's z = −v̂; Joseph form with the paper's constant R = σ_zupt² I."""
    gain_into(K, n, dt, tau, c, ric.u, ric.lam, ric.t)
    zupt(st, dx, acc, gyro, stance, k, prm, z)
    for i in range(n):
        dx[i] = K[i, 0] * z[0] + K[i, 1] * z[1] + K[i, 2] * z[2]
    joseph3(P, K, DV, prm.var_zupt, n, A)
    applied[ZUPT] += 1


@njit(cache=True, **NO_REFCOUNT)
def _registry_updates(k, last, j, acc, gyro, stance, active, prm, n, st, P, dx, z, K, A, pred, weights, blocks,
                      gains, applied):
    """The active measurement models of ``measurements.KERNEL_REGISTRY`` at input row k, applied sequentially
    in registry order (``kalman.sequential_update``); with the smoother, what it needs of each update is
    buffered in row j (P⁻ in ``pred``, S⁻¹ν in ``weights``, the states measured in ``blocks``, Kᵀ in ``gains``;
    ``last``: k is the call's last row). Returns (whether any updated, how many)."""
    updated = False
    n_upd = 0
    for entry in literal_unroll(KERNEL_REGISTRY):  # one specialised copy per model, registry order
        if active[entry.kind]:
            mrows, first, rr = measure(entry.kind, st, dx, acc, gyro, stance, k, prm, z)
            if mrows > 0:
                if prm.smooth:
                    if not updated and last:  # P⁻ before the first update, at the last sample
                        _store_prior(pred, j, P, n)  # (where an update from outside may come next)
                    innovation_weight(P, dx, z, mrows, first, rr, weights[j, n_upd])
                sequential_update(P, dx, z, mrows, first, rr, n, K, A)
                if prm.smooth:  # what the smoother needs of this update (smoother.rts_backward)
                    blocks[j, n_upd, 0] = first
                    blocks[j, n_upd, 1] = mrows
                    for c_ in range(mrows):
                        for i in range(n):
                            gains[j, n_upd, c_, i] = K[i, c_]
                    n_upd += 1
                applied[entry.kind] += 1
                updated = True
    return updated, n_upd


@njit(cache=True, inline="always")
def _inject_error(st, dx, n):
    """Apply the error estimate to the nominal state (δx is reset by the caller: [Heidari2019, eq. 3])."""
    ip, iv, iq, iba, ibg = POS.start, VEL.start, QUAT.start, BIAS_ACC.start, BIAS_GYRO.start
    for i in range(3):
        st[ip + i] += dx[DP + i]
    for i in range(3):
        st[iv + i] += dx[DV + i]
    if n == 15:
        for i in range(3):
            st[iba + i] += dx[DBA + i]
        for i in range(3):
            st[ibg + i] += dx[DBG + i]
    st[iq], st[iq + 1], st[iq + 2], st[iq + 3] = exp_times_quat(st[iq], st[iq + 1], st[iq + 2], st[iq + 3],
                                                                dx[DTH], dx[DTH + 1], dx[DTH + 2])


@njit(cache=True, inline="always")
def _store_row(r, st, P, pos, vel, q, ba, bg, pos_sig, pos_cen):
    """Output row r of the path (``PathRows``) ← the nominal state; of its uncertainty (``PathUncertainty``) ←
    the position 1-σ per axis and P_EN."""
    ip, iv, iq, iba, ibg = POS.start, VEL.start, QUAT.start, BIAS_ACC.start, BIAS_GYRO.start
    for i in range(3):
        pos[r, i] = st[ip + i]
        vel[r, i] = st[iv + i]
        ba[r, i] = st[iba + i]
        bg[r, i] = st[ibg + i]
        pos_sig[r, i] = math.sqrt(max(P[DP + i, DP + i], 0.0))
    pos_cen[r] = P[DP, DP + 1]
    for i in range(4):
        q[r, i] = st[iq + i]


@njit(cache=True, inline="always")
def _store_posterior(buf_upd, buf_dx, buf_post, j, n_upd, dx, P, n):
    """Buffer row j of the smoother ← the row's updates (``SmootherBuffers.updates``), its correction δx and
    P⁺."""
    buf_upd[j] = n_upd
    for a_ in range(n):
        buf_dx[j, a_] = dx[a_]
        for b_ in range(n):
            buf_post[j, a_, b_] = P[a_, b_]


@njit(cache=True, nogil=True)
def filter_chunk(k0, k1, inp, o0, model, state, rows, unc, bufs, book, counts):
    """Filter input rows k0..k1−1 (k0 ≥ 1) of ``inp`` (``KernelInputs``, whose ``stance`` is the ZUPT mask) with
    ``model`` (``FilterModel``); ``state`` (``FilterState``: nominal state, layout.py, and P) is updated in place.
    Returns the input row to resume at: k1, or earlier when the smoother's closed segments are due
    (``book.seg``'s SEG_N_CLOSED of them in ``book.closed``; call again from there after handing them on).

    Input row k writes output row o0 + k of ``rows`` (``PathRows``) and of ``unc`` (``PathUncertainty``: the
    filter's position 1-σ per axis and the east-north covariance P_EN, m²). Input row k0 − 1 is the sample
    before (only its ZUPT flag is read: the heading aid's stance onset and the end of a stance phase; a False
    row before the record's first sample). The smoother's open segment (``book``: ``SegmentBook``) starts at
    output row ``seg[SEG_ROW]`` and holds ``seg[SEG_LEN]`` samples; it is closed (listed in ``closed`` for
    ``smooth_segments``) when the next sample shows that it ended: after the last sample of a stance phase, or
    when it reached ``prm.max_segment`` samples (``close_segment`` ends the record's last one). Its buffers
    (``bufs``, ``SmootherBuffers``: P⁺ whole, P⁻'s packed lower triangle, fpar, dx, each update's gain and
    weighted innovation) are a ring of segments:
    sample j of the open one is buffer row (seg[SEG_RING] + j) mod capacity. The kernel returns after a close
    when the closed segments reach ``book.batch_rows`` buffer rows, when ``closed`` is full, or when the next
    segment (at most ``prm.max_segment`` rows) could reach ``seg[SEG_TAIL]``, the oldest buffer row not
    smoothed yet: the caller smooths (or hands on) the closed ones and moves the tail on. With
    ``book.batch_rows`` 0 (no smoothing thread) it smooths each segment itself as it closes (``smooth_segments``,
    the same arithmetic) and never returns early. ``counts``
    (``RunCounts``) counts each measurement model's updates and the smoother's bookkeeping.
    """
    n = model.n
    K, A, dx, z, c = np.zeros((n, 3)), np.empty((n, n)), np.zeros(n), np.zeros(MAX_ROWS), np.empty((3, 3))
    k = k0
    while k < k1:
        k = _filter_rows(k, k1, inp, o0, model, state, rows, unc, bufs, book, counts, K, A, dx, z, c)
        if k < k1 and _close_ended_segment(o0 + k, model.prm, n, rows, bufs, book, counts.smoother):
            return k
    return k1


@njit(cache=True, nogil=True, **NO_REFCOUNT)
def _filter_rows(k0, k1, inp, o0, model, state, rows, unc, bufs, book, counts, K, A, dx, z, c):
    """``filter_chunk``'s loop over input rows k0..k1−1, with its work arrays (gain Kᵀ, a matrix A, δx, z, C_nb)
    allocated by it. Returns k1, or the row before which the smoother's open segment ended (``filter_chunk``
    closes it and calls again from there).

    Compiled without numba's reference counting (``_nrt=False``: it allocates nothing and calls nothing that
    does, so the smoothing stays in ``filter_chunk``): the arrays it hands to its pieces would otherwise be
    counted in and out at every sample, which costs ~20 % of the kernel's time. The pieces are inlined but
    ``_registry_updates``, a call of its own: inlining its unrolled loop over the measurement models would
    double the kernels' first compilation (~25 s → ~60 s on 2 cores) for no measurable speed."""
    prm, active, n, ric = model
    st, P = state
    pos, vel, q, ba, bg = rows
    pos_sig, pos_cen = unc
    seg = book.seg
    applied = counts.applied
    dt_s, acc, gyro, stance, xvar, ric_tau = inp
    buf_post, buf_pred, buf_fpar, buf_dx, buf_upd, buf_gain, buf_w, buf_blk = bufs
    cap = buf_post.shape[0]
    for k in range(k0, k1):
        r = o0 + k
        if prm.smooth and _segment_ended(seg, stance, k, prm.max_segment):
            return k
        dt = dt_s[k]
        fx, fy, fz, fbx, fby, fbz = _strapdown(st, c, acc, gyro, k, dt, prm)
        if dt > 0.0:
            _propagate(P, n, dt, c, fx, fy, fz, fbx, fby, fbz, st, gyro, xvar, k, prm)
        j = (seg[SEG_RING] + seg[SEG_LEN]) % cap
        if prm.smooth:
            _store_transition(buf_fpar, j, dt, fx, fy, fz, c)
        for i in range(n):
            dx[i] = 0.0
        updated = False
        n_upd = 0
        if prm.riccati:
            if stance[k] and dt > 0.0:
                if prm.smooth:
                    _store_prior(buf_pred, j, P, n)
                _paper_zupt(k, dt, ric_tau[k], c, acc, gyro, stance, ric, prm, n, st, P, dx, z, K, A, applied)
                updated = True
            n_upd = -1  # for the smoother: factorise P⁻ at the row
        else:
            updated, n_upd = _registry_updates(k, k == k1 - 1, j, acc, gyro, stance, active, prm, n, st, P, dx, z, K,
                                               A, buf_pred, buf_w, buf_blk, buf_gain, applied)
        if updated:
            _inject_error(st, dx, n)
        _store_row(r, st, P, pos, vel, q, ba, bg, pos_sig, pos_cen)
        if prm.smooth:
            _store_posterior(buf_upd, buf_dx, buf_post, j, n_upd, dx, P, n)
            seg[SEG_LEN] += 1
    return k1


def key_cache_on_sources(dispatchers, paths) -> bytes:
    """Stamp the on-disk numba cache of ``dispatchers`` with the hash of the files ``paths`` (module docstring).

    A cached entry is used only if every file is unchanged since it was compiled; an edit to any of them
    recompiles. Returns the combined hash. Dispatchers without an on-disk cache are left alone.
    """
    h = hashlib.sha256()
    for p in sorted(Path(p) for p in paths):
        h.update(p.name.encode() + b"\0" + p.read_bytes())
    digest = h.digest()
    for d in dispatchers:
        cache_file = getattr(getattr(d, "_cache", None), "_cache_file", None)
        if cache_file is not None and hasattr(cache_file, "_source_stamp"):
            cache_file._source_stamp = (cache_file._source_stamp, digest)
    return digest


def kernel_sources(module_file=__file__) -> list[Path]:
    """This module's file and every module of this package it imports, transitively (module-level imports, read
    from the source): the code a cached kernel may contain."""
    import ast

    pkg = Path(module_file).parent
    todo, seen = [Path(module_file)], set()
    while todo:
        p = todo.pop()
        if p in seen or not p.exists():
            continue
        seen.add(p)
        for node in ast.parse(p.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(__package__ + "."):
                todo.append(pkg / (node.module.rsplit(".", 1)[1] + ".py"))
    return sorted(seen)


key_cache_on_sources((filter_chunk, _filter_rows, close_segment, smooth_segments, rts_backward, _propagate_cov,
                      _close_ended_segment, _registry_updates),
                     kernel_sources())

_compile_listeners: list = []
_compile_lock = threading.Lock()  # one compilation (and one notice) when threads start engines at once


@contextmanager
def compile_notice(callback):
    """Within the block, ``callback()`` is called before the fast engine's kernels are compiled (a first run
    on this machine, or after an edit of this package; not when numba loads them from its cache)."""
    _compile_listeners.append(callback)
    try:
        yield
    finally:
        _compile_listeners.remove(callback)


def cached_on_disk(dispatcher) -> bool:
    """Whether numba's on-disk cache holds a valid (source stamp matching) entry of ``dispatcher``."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # numba internals changed: cannot tell, stay quiet
        return True


def _needs_compiling() -> bool:
    """Whether the kernels must be compiled (neither in this process nor in numba's cache)."""
    kernels = (filter_chunk, close_segment, smooth_segments)
    if all(k.signatures for k in kernels):
        return False
    return not all(cached_on_disk(k) for k in kernels)


def ensure_compiled(model: FilterModel) -> float:
    """Compile (or load from numba's cache) the kernels for the argument types a run with ``model`` passes;
    returns the seconds spent. The ``compile_notice`` listeners are told first when a real compilation is
    due."""
    t0 = time.perf_counter()
    with _compile_lock:
        _compile(model)
    return time.perf_counter() - t0


def _compile(model: FilterModel) -> None:
    """``ensure_compiled``'s work (called under ``_compile_lock``): one call of each kernel on empty arrays of
    the types a run passes."""
    if _needs_compiling():
        for cb in list(_compile_listeners):
            cb()
    if not all(k.signatures for k in (filter_chunk, close_segment, smooth_segments)):
        n = model.n
        one3 = np.zeros((1, 3))
        none3, none4 = np.zeros((0, 3)), np.zeros((0, 4))
        book = SegmentBook(np.zeros(N_SEG, dtype=np.int64), np.zeros((1, 3), dtype=np.int64), 1)
        counts = RunCounts(np.zeros(N_KINDS, dtype=np.int64), np.zeros(2, dtype=np.int64))
        inp = KernelInputs(np.zeros(1), one3, one3.copy(), np.zeros(1, dtype=np.bool_), np.zeros((1, 6)), np.zeros(1))
        rows = PathRows(none3, none3.copy(), none4, none3.copy(), none3.copy())
        bufs = SmootherBuffers(np.zeros((1, n, n)), np.zeros((1, n * (n + 1) // 2)), np.zeros((1, 13)), np.zeros((1, n)),
                               np.zeros(1, dtype=np.int64), np.zeros((1, N_KINDS, 3, n)), np.zeros((1, N_KINDS, 3)),
                               np.zeros((1, N_KINDS, 2), dtype=np.int64))
        state = FilterState(np.zeros(N_NOMINAL), np.zeros((n, n)))
        filter_chunk(1, 1, inp, 0, model, state, rows, PathUncertainty(none3.copy(), np.zeros(0)), bufs, book, counts)
        close_segment(book.seg, book.closed, counts.smoother, 0)
        smooth_segments(book.closed[:0], n, rows, bufs)
