"""Fast engine: the whole ZUPT error-state filter (+ segment RTS smoother) as one numba kernel.

No per-sample Python loop: Python only slices the record into a few chunks (for the progress callback).
The algebra is exactly ``reference.py``'s, written for speed:

* mechanization with scalar locals (no small-array allocation per sample);
* covariance propagation P ← F P Fᵀ + Q_d in place with the block structure of
  F = I + A Δt, A = [[0, I, 0, 0, 0], [0, 0, −[f_n×], −C_nb, 0], [0, 0, 0, 0, −C_nb], 0, 0]
  (rows then columns; the 9-state case touches 6 + 9 rows/columns instead of a dense 9×9×9 product);
* the measurement models of ``measurements.py`` (the same jitted functions the reference engine calls),
  applied sequentially in registry order; the loop over the registry is unrolled at compile time, so each
  model's H = [0 I 0] is a constant index block (``kalman.py``: no H matrix, closed-form 3×3 innovation
  inverse or a scalar gain, Joseph form (I − KH) P (I − KH)ᵀ + K R Kᵀ by blocks).

Error-state conventions (shared with reference.py, see ``bootnav.postproc.ins.filter``): δx = x_true − x̂, so
the ZUPT pseudo-measurement is z = 0 − v̂ = δv + noise, δx = K z, then p̂ += δp, v̂ += δv, q̂ ← exp(δθ/2) ⊗ q̂,
b̂ += δb, δx ← 0. The "+ k_n v_n" of [Heidari2019, eq. 3] is this with the minus sign of z absorbed in k_n.

Numba's on-disk cache of ``filter_chunk`` is keyed on this file only, and the cached code contains the jitted
functions it calls: after editing one of those modules (``measurements.py``, ``kalman.py``, ``kernels.py``,
``layout.py``, ``riccati.py``, ``smoother.py``) delete ``__pycache__/*.nbi`` and ``*.nbc`` here, or touch this file.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import literal_unroll, njit

from bootnav.postproc.ins.kernels import exp_times_quat, quat_times_exp, rotmat_into
from bootnav.postproc.ins.layout import (BIAS_ACC, BIAS_GYRO, DBA, DBG, DP, DTH, DV, POS, QUAT, VEL,
                                         initial_nominal_state)
from bootnav.postproc.ins.kalman import joseph3, sequential_update
from bootnav.postproc.ins.measurements import (KERNEL_REGISTRY, MAX_ROWS, N_KINDS, ZUPT, active_flags, measure,
                                               zupt)
from bootnav.postproc.ins.riccati import gain_into
from bootnav.postproc.ins.smoother import rts_backward

# smoother bookkeeping counters
SMOOTHER_SKIPPED, SMOOTHER_SEGMENTS = 0, 1


@njit(cache=True)
def _propagate_cov(P, n, dt, fx, fy, fz, c, qa, qg, qba, qbg):
    """P ← F P Fᵀ + Q_d in place (F = I + A Δt, block form; see module docstring)."""
    for side in range(2):  # 0: rows (F P), 1: columns ((F P) Fᵀ)
        for m in range(n):
            if side == 0:
                for i in range(3):
                    P[DP + i, m] += dt * P[DV + i, m]
                t0, t1, t2 = P[DTH, m], P[DTH + 1, m], P[DTH + 2, m]
                P[DV, m] += dt * (fz * t1 - fy * t2)
                P[DV + 1, m] += dt * (fx * t2 - fz * t0)
                P[DV + 2, m] += dt * (fy * t0 - fx * t1)
                if n == 15:
                    for i in range(3):
                        P[DV + i, m] -= dt * (c[i, 0] * P[DBA, m] + c[i, 1] * P[DBA + 1, m] + c[i, 2] * P[DBA + 2, m])
                    for i in range(3):
                        P[DTH + i, m] -= dt * (c[i, 0] * P[DBG, m] + c[i, 1] * P[DBG + 1, m] + c[i, 2] * P[DBG + 2, m])
            else:
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


@njit(cache=True)
def filter_chunk(k0, k1, dt_s, acc, gyro, stance, xvar, prm, active, n, ric_u, ric_lam, ric_t, ric_tau, st, P,
                 pos, vel, q, ba, bg, pos_sig, buf_post, buf_pred, buf_fpar, buf_dx, seg, applied, counters):
    """Run samples k0..k1−1; ``st`` = nominal state (layout.py) and ``P`` are updated in place.

    ``prm``: ``KernelParams``; ``active``: (N_KINDS,) bool, which measurement models run
    (``measurements.active_flags``); ``applied[kind]`` counts each model's updates, ``counters`` the
    smoother's bookkeeping.
    """
    N = dt_s.shape[0]
    ip, iv, iq, iba, ibg = POS.start, VEL.start, QUAT.start, BIAS_ACC.start, BIAS_GYRO.start
    K = np.zeros((n, 3))
    A = np.empty((n, n))
    dx = np.zeros(n)
    z = np.zeros(MAX_ROWS)
    c = np.empty((3, 3))
    for k in range(k0, k1):
        dt = dt_s[k]
        qw, qx, qy, qz = st[iq], st[iq + 1], st[iq + 2], st[iq + 3]
        if dt > 0.0:
            # [Heidari2019, eq. 1] row 3: q ← q ⊗ exp(ωΔt/2)
            tx = (gyro[k, 0] - st[ibg]) * dt
            ty = (gyro[k, 1] - st[ibg + 1]) * dt
            tz = (gyro[k, 2] - st[ibg + 2]) * dt
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, tx, ty, tz)
            st[iq], st[iq + 1], st[iq + 2], st[iq + 3] = qw, qx, qy, qz
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
        j = seg[0]
        if prm.smooth:
            for a_ in range(n):
                for b_ in range(n):
                    buf_pred[j, a_, b_] = P[a_, b_]
            buf_fpar[j, 0] = dt
            buf_fpar[j, 1], buf_fpar[j, 2], buf_fpar[j, 3] = fx, fy, fz
            for a_ in range(3):
                for b_ in range(3):
                    buf_fpar[j, 4 + 3 * a_ + b_] = c[a_, b_]
        for i in range(n):
            dx[i] = 0.0
        updated = False
        if prm.riccati:
            if stance[k] and dt > 0.0:
                # paper mode: the constant Riccati gain per step (riccati.gain_into) on the ZUPT's z = −v̂;
                # Joseph form with the paper's constant R = σ_zupt² I
                gain_into(K, n, dt, ric_tau[k], c, ric_u, ric_lam, ric_t)
                zupt(st, dx, acc, gyro, stance, k, prm, z)
                for i in range(n):
                    dx[i] = K[i, 0] * z[0] + K[i, 1] * z[1] + K[i, 2] * z[2]
                joseph3(P, K, DV, prm.var_zupt, n, A)
                applied[ZUPT] += 1
                updated = True
        else:
            for entry in literal_unroll(KERNEL_REGISTRY):  # one specialised copy per model, registry order
                if active[entry.kind]:
                    mrows, first, r = measure(entry.kind, st, dx, acc, gyro, stance, k, prm, z)
                    if mrows > 0:
                        sequential_update(P, dx, z, mrows, first, r, n, K, A)
                        applied[entry.kind] += 1
                        updated = True
        if updated:
            # apply the error estimate to the nominal state and reset it ([Heidari2019, eq. 3])
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
        for i in range(3):
            pos[k, i] = st[ip + i]
            vel[k, i] = st[iv + i]
            ba[k, i] = st[iba + i]
            bg[k, i] = st[ibg + i]
            pos_sig[k, i] = math.sqrt(max(P[DP + i, DP + i], 0.0))
        for i in range(4):
            q[k, i] = st[iq + i]
        if prm.smooth:
            for a_ in range(n):
                buf_dx[j, a_] = dx[a_]
                for b_ in range(n):
                    buf_post[j, a_, b_] = P[a_, b_]
            seg[0] = j + 1
            end_of_stance = stance[k] and (k + 1 == N or not stance[k + 1])
            if seg[0] >= prm.max_segment or k + 1 == N or end_of_stance:
                if seg[0] > 1:
                    counters[SMOOTHER_SKIPPED] += rts_backward(buf_post, buf_pred, buf_fpar, buf_dx, seg[0], n,
                                                               seg[1], pos, vel, q, ba, bg)
                counters[SMOOTHER_SEGMENTS] += 1
                seg[0] = 0
                seg[1] = k + 1


def run_fast(t_s, acc_b, gyro_b, stance, q0_nb, gyro_bias0_b, acc_bias0_b, settings, tb, P0, zupt_gain, prm,
             progress=None, extra_var=None):
    """Drive ``filter_chunk`` over the record in a few chunks (arguments as ``filter.run_filter`` prepares them).

    Returns
    -------
    (arrays dict pos_n, vel_n, q_nb, acc_bias_b, gyro_bias_b, pos_sigma_n; info dict)
    """
    n = settings.n_states
    N = t_s.shape[0]
    dt_nom = tb.nominal_dt_s
    active = active_flags(settings)
    if zupt_gain is not None:
        ric_u, ric_lam, ric_t, ric_tau = zupt_gain.U.copy(), zupt_gain.lam.copy(), zupt_gain.T.copy(), zupt_gain.tau
    else:
        ric_u, ric_lam, ric_t, ric_tau = np.eye(3), np.zeros(3), np.zeros((6, 3)), np.zeros(N)
    st = initial_nominal_state(q0_nb, acc_bias0_b, gyro_bias0_b)
    P = P0.copy()
    out = {name: np.empty((N, 3)) for name in ("pos_n", "vel_n", "acc_bias_b", "gyro_bias_b", "pos_sigma_n")}
    out["q_nb"] = np.empty((N, 4))
    nb = prm.max_segment if prm.smooth else 1
    buf_post = np.empty((nb, n, n))
    buf_pred = np.empty((nb, n, n))
    buf_fpar = np.empty((nb, 13))
    buf_dx = np.empty((nb, n))
    seg = np.zeros(2, dtype=np.int64)
    applied = np.zeros(N_KINDS, dtype=np.int64)
    counters = np.zeros(2, dtype=np.int64)
    stance_u8 = np.ascontiguousarray(stance, dtype=np.bool_)
    xvar = np.zeros((N, 6)) if extra_var is None else np.ascontiguousarray(extra_var, dtype=np.float64) * dt_nom
    n_chunks = 1 if progress is None else max(1, min(10, N // 100_000))
    bounds = np.linspace(0, N, n_chunks + 1).astype(np.int64)

    def chunk(a, b):
        filter_chunk(a, b, tb.dt_s, acc_b, gyro_b, stance_u8, xvar, prm, active, n, ric_u, ric_lam, ric_t, ric_tau,
                     st, P, out["pos_n"], out["vel_n"], out["q_nb"], out["acc_bias_b"], out["gyro_bias_b"],
                     out["pos_sigma_n"], buf_post, buf_pred, buf_fpar, buf_dx, seg, applied, counters)

    # a zero-length call compiles (or loads from the numba cache) this signature: timed separately
    tc = time.perf_counter()
    chunk(0, 0)
    compile_s = time.perf_counter() - tc
    t0 = time.perf_counter()
    for a, b in zip(bounds[:-1], bounds[1:]):
        chunk(int(a), int(b))
        if progress is not None:
            progress(float(b) / N)
    info = {
        "run_s": time.perf_counter() - t0,
        "compile_s": compile_s,
        "applied": applied,
        "smoother_segments": int(counters[SMOOTHER_SEGMENTS]),
        "smoother_skipped_steps": int(counters[SMOOTHER_SKIPPED]),
        "smoother_max_segment_samples": prm.max_segment,
        "final_P": P,
    }
    return out, info
