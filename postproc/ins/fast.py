"""Fast engine: the whole ZUPT error-state filter (+ segment RTS smoother) as one numba kernel.

No per-sample Python loop: Python only slices the record into a few chunks (for the progress callback).
The algebra is exactly ``reference.py``'s, written for speed:

* mechanization with scalar locals (no small-array allocation per sample);
* covariance propagation P ← F P Fᵀ + Q_d in place with the block structure of
  F = I + A Δt, A = [[0, I, 0, 0, 0], [0, 0, −[f_n×], −C_nb, 0], [0, 0, 0, 0, −C_nb], 0, 0]
  (rows then columns; the 9-state case touches 6 + 9 rows/columns instead of a dense 9×9×9 product);
* the ZUPT update only in stance, H = [0 I 0] as an index offset (no H matrix), 3×3 innovation inverse
  in closed form, Joseph form (I − KH) P (I − KH)ᵀ + K R Kᵀ by blocks.

Error-state conventions (shared with reference.py, see ``bootnav.postproc.ins.filter``): δx = x_true − x̂, so the ZUPT
pseudo-measurement is z = 0 − v̂ = δv + noise, δx = K z, then p̂ += δp, v̂ += δv, q̂ ← exp(δθ/2) ⊗ q̂,
b̂ += δb, δx ← 0. The paper's "+ k_n v_n" (eq. 3) is this with the minus sign of z absorbed in k_n.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit

from bootnav.postproc.ins.kernels import exp_times_quat, quat_times_exp, rotmat_into
from bootnav.postproc.ins.smoother import rts_backward

# parameter vector layout (kept in one float64 array so the kernel signature stays short)
(P_DT_NOM, P_QA, P_QG, P_QBA, P_QBG, P_RZ, P_RW, P_ZARU, P_G, P_RIC, P_SMOOTH, P_MAXSEG,
 P_HDE, P_HDE_THR, P_HDE_R, P_HDE_MIN, P_KA, P_KG, P_LEVER, P_ZARU_C) = range(20)
N_PRM = 20
# nominal-state vector layout: p 0:3, v 3:6, q 6:10, b_a 10:13, b_g 13:16, heading-aid memory 16:20
# (previous stance-start x, y; have-previous flag; reference heading or NaN)
N_ST = 20


@njit(cache=True)
def _propagate_cov(P, n, dt, fx, fy, fz, c, qa, qg, qba, qbg):
    """P ← F P Fᵀ + Q_d in place (F = I + A Δt, block form; see module docstring)."""
    for side in range(2):  # 0: rows (F P), 1: columns ((F P) Fᵀ)
        for m in range(n):
            if side == 0:
                for i in range(3):
                    P[i, m] += dt * P[3 + i, m]
                p6, p7, p8 = P[6, m], P[7, m], P[8, m]
                P[3, m] += dt * (fz * p7 - fy * p8)
                P[4, m] += dt * (fx * p8 - fz * p6)
                P[5, m] += dt * (fy * p6 - fx * p7)
                if n == 15:
                    for i in range(3):
                        P[3 + i, m] -= dt * (c[i, 0] * P[9, m] + c[i, 1] * P[10, m] + c[i, 2] * P[11, m])
                    for i in range(3):
                        P[6 + i, m] -= dt * (c[i, 0] * P[12, m] + c[i, 1] * P[13, m] + c[i, 2] * P[14, m])
            else:
                for i in range(3):
                    P[m, i] += dt * P[m, 3 + i]
                p6, p7, p8 = P[m, 6], P[m, 7], P[m, 8]
                P[m, 3] += dt * (fz * p7 - fy * p8)
                P[m, 4] += dt * (fx * p8 - fz * p6)
                P[m, 5] += dt * (fy * p6 - fx * p7)
                if n == 15:
                    for i in range(3):
                        P[m, 3 + i] -= dt * (c[i, 0] * P[m, 9] + c[i, 1] * P[m, 10] + c[i, 2] * P[m, 11])
                    for i in range(3):
                        P[m, 6 + i] -= dt * (c[i, 0] * P[m, 12] + c[i, 1] * P[m, 13] + c[i, 2] * P[m, 14])
    for i in range(3):
        P[3 + i, 3 + i] += qa * dt
        P[6 + i, 6 + i] += qg * dt
    if n == 15:
        for i in range(3):
            P[9 + i, 9 + i] += qba * dt
            P[12 + i, 12 + i] += qbg * dt


@njit(cache=True)
def _joseph(P, K, off, r, n, A):
    """P ← (I − K H) P (I − K H)ᵀ + r K Kᵀ for H selecting states off..off+2 (block form)."""
    for i in range(n):
        for c in range(n):
            A[i, c] = P[i, c] - (K[i, 0] * P[off, c] + K[i, 1] * P[off + 1, c] + K[i, 2] * P[off + 2, c])
    for i in range(n):  # the result is symmetric: compute the upper triangle, mirror it
        for c in range(i, n):
            v = (A[i, c] - (A[i, off] * K[c, 0] + A[i, off + 1] * K[c, 1] + A[i, off + 2] * K[c, 2])
                 + r * (K[i, 0] * K[c, 0] + K[i, 1] * K[c, 1] + K[i, 2] * K[c, 2]))
            P[i, c] = v
            P[c, i] = v


@njit(cache=True)
def _kalman_gain(P, off, r, n, K):
    """K = P Hᵀ (H P Hᵀ + r I)⁻¹ for H selecting states off..off+2 (closed-form 3×3 inverse)."""
    a, b, c = P[off, off] + r, P[off, off + 1], P[off, off + 2]
    d, e = P[off + 1, off + 1] + r, P[off + 1, off + 2]
    f = P[off + 2, off + 2] + r
    b2, c2, e2 = P[off + 1, off], P[off + 2, off], P[off + 2, off + 1]
    # general 3×3 inverse (S is symmetric up to rounding; use all entries so it equals numpy's inverse)
    m00, m01, m02 = d * f - e * e2, c * e2 - b * f, b * e - c * d
    m10, m11, m12 = e * c2 - b2 * f, a * f - c * c2, c * b2 - a * e
    m20, m21, m22 = b2 * e2 - d * c2, b * c2 - a * e2, a * d - b * b2
    det = a * m00 + b * m10 + c * m20
    for i in range(n):
        p0, p1, p2 = P[i, off], P[i, off + 1], P[i, off + 2]
        K[i, 0] = (p0 * m00 + p1 * m10 + p2 * m20) / det
        K[i, 1] = (p0 * m01 + p1 * m11 + p2 * m21) / det
        K[i, 2] = (p0 * m02 + p1 * m12 + p2 * m22) / det


@njit(cache=True)
def _scalar_update(P, idx, r, n, K, A):
    """Gain (into K[:, 0]) and Joseph update for a scalar measurement of state idx with variance r."""
    s = P[idx, idx] + r
    for i in range(n):
        K[i, 0] = P[i, idx] / s
    for i in range(n):
        for c in range(n):
            A[i, c] = P[i, c] - K[i, 0] * P[idx, c]
    for i in range(n):
        for c in range(i, n):
            v = A[i, c] - A[i, idx] * K[c, 0] + r * K[i, 0] * K[c, 0]
            P[i, c] = v
            P[c, i] = v


@njit(cache=True)
def hde_error(dx_m, dy_m, ref_rad):
    """Stride heading minus the nearest of the four directions ref + m·90° (rad, in (−45°, 45°])."""
    e = math.atan2(dy_m, dx_m) - ref_rad
    e = math.atan2(math.sin(e), math.cos(e))
    return e - math.floor(e / (0.5 * math.pi) + 0.5) * (0.5 * math.pi)


@njit(cache=True)
def filter_chunk(k0, k1, dt_s, acc, gyro, stance, xvar, prm, n, ric_u, ric_lam, ric_t, st, P,
                 pos, vel, q, ba, bg, pos_sig, buf_post, buf_pred, buf_fpar, buf_dx, seg, counters):
    """Run samples k0..k1−1. ``st`` = nominal state (p 0:3, v 3:6, q 6:10, b_a 10:13, b_g 13:16), updated in place."""
    N = dt_s.shape[0]
    g = prm[P_G]
    riccati = prm[P_RIC] > 0.5
    smooth = prm[P_SMOOTH] > 0.5
    zaru = prm[P_ZARU] > 0.5
    maxseg = int(prm[P_MAXSEG])
    rz, rw = prm[P_RZ], prm[P_RW]
    K = np.zeros((n, 3))
    A = np.empty((n, n))
    dx = np.zeros(n)
    c = np.empty((3, 3))
    for k in range(k0, k1):
        dt = dt_s[k]
        qw, qx, qy, qz = st[6], st[7], st[8], st[9]
        if dt > 0.0:
            # eq. 1 row 3: q ← q ⊗ exp(ωΔt/2)
            tx = (gyro[k, 0] - st[13]) * dt
            ty = (gyro[k, 1] - st[14]) * dt
            tz = (gyro[k, 2] - st[15]) * dt
            qw, qx, qy, qz = quat_times_exp(qw, qx, qy, qz, tx, ty, tz)
            st[6], st[7], st[8], st[9] = qw, qx, qy, qz
        rotmat_into(c, qw, qx, qy, qz)
        fbx, fby, fbz = acc[k, 0] - st[10], acc[k, 1] - st[11], acc[k, 2] - st[12]
        fx = c[0, 0] * fbx + c[0, 1] * fby + c[0, 2] * fbz
        fy = c[1, 0] * fbx + c[1, 1] * fby + c[1, 2] * fbz
        fz = c[2, 0] * fbx + c[2, 1] * fby + c[2, 2] * fbz
        if dt > 0.0:
            ax, ay, az = fx, fy, fz - g
            hdt2 = 0.5 * dt * dt
            st[0] += st[3] * dt + ax * hdt2
            st[1] += st[4] * dt + ay * hdt2
            st[2] += st[5] * dt + az * hdt2
            st[3] += ax * dt
            st[4] += ay * dt
            st[5] += az * dt
            # signal-proportional (scale-factor) noise: σ_k² = σ² + (κ |signal_k|)² (settings.py)
            qa = prm[P_QA] + prm[P_KA] * (fbx * fbx + fby * fby + fbz * fbz)
            wx, wy, wz = gyro[k, 0] - st[13], gyro[k, 1] - st[14], gyro[k, 2] - st[15]
            qg = prm[P_QG] + prm[P_KG] * (wx * wx + wy * wy + wz * wz)
            _propagate_cov(P, n, dt, fx, fy, fz, c, qa, qg, prm[P_QBA], prm[P_QBG])
            # saturated axes (xvar: extra per-sample variance × Δt₀ per body axis ax..gz): the unknown part of
            # a clipped sample acts along that body axis only, i.e. along column a of C_nb in the nav frame
            for ax_ in range(6):
                qx_ = xvar[k, ax_]
                if qx_ > 0.0:
                    o = 3 if ax_ < 3 else 6
                    col = ax_ % 3
                    for i in range(3):
                        for m in range(3):
                            P[o + i, o + m] += qx_ * dt * c[i, col] * c[m, col]
        j = seg[0]
        if smooth:
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
        if stance[k]:
            if riccati:
                if dt > 0.0:
                    # K_d,v = U diag(1 − e^{−λΔt}) Uᵀ ; K_d,θ = T K_d,v (riccati.py)
                    for i in range(n):
                        K[i, 0] = 0.0
                        K[i, 1] = 0.0
                        K[i, 2] = 0.0
                    for i in range(3):
                        for m in range(3):
                            s = 0.0
                            for l in range(3):
                                s += ric_u[i, l] * (1.0 - math.exp(-ric_lam[l] * dt)) * ric_u[m, l]
                            K[3 + i, m] = s
                    for i in range(2):
                        for m in range(3):
                            K[6 + i, m] = ric_t[i, 0] * K[3, m] + ric_t[i, 1] * K[4, m] + ric_t[i, 2] * K[5, m]
                    z0, z1, z2 = -st[3], -st[4], -st[5]
                    for i in range(n):
                        dx[i] = K[i, 0] * z0 + K[i, 1] * z1 + K[i, 2] * z2
                    _joseph(P, K, 3, rz, n, A)
                    counters[0] += 1
            else:
                # rolling-foot ZUPT noise: R_k = σ_zupt² + (r |ω_k − b̂_g|)² (settings.zupt_lever_arm_m)
                wx, wy, wz = gyro[k, 0] - st[13], gyro[k, 1] - st[14], gyro[k, 2] - st[15]
                rzk = rz + prm[P_LEVER] * (wx * wx + wy * wy + wz * wz)
                _kalman_gain(P, 3, rzk, n, K)
                z0, z1, z2 = -st[3], -st[4], -st[5]
                for i in range(n):
                    dx[i] = K[i, 0] * z0 + K[i, 1] * z1 + K[i, 2] * z2
                _joseph(P, K, 3, rzk, n, A)
                counters[0] += 1
                if zaru and n == 15:
                    # ZARU: z = 0 − (ω_m − b̂_g) with the sign of δb_g = b_g − b̂_g: z = ω_m − b̂_g;
                    # sequential update: innovation z − H dx
                    # R_k = σ_zaru² + (c |ω_k − b̂_g|)²: a rolling foot's own rate counts as noise, so the
                    # update only bites in the quiet core of a stance phase
                    rwk = rw + prm[P_ZARU_C] * (wx * wx + wy * wy + wz * wz)
                    _kalman_gain(P, 12, rwk, n, K)
                    z0 = gyro[k, 0] - st[13] - dx[12]
                    z1 = gyro[k, 1] - st[14] - dx[13]
                    z2 = gyro[k, 2] - st[15] - dx[14]
                    for i in range(n):
                        dx[i] += K[i, 0] * z0 + K[i, 1] * z1 + K[i, 2] * z2
                    _joseph(P, K, 12, rwk, n, A)
            if prm[P_HDE] > 0.5 and (k == 0 or not stance[k - 1]):
                # OPTIONAL heuristic heading aid (settings.py): stride heading vs dominant directions
                px, py = st[0] + dx[0], st[1] + dx[1]
                if st[18] > 0.5:
                    sx, sy = px - st[16], py - st[17]
                    if math.sqrt(sx * sx + sy * sy) >= prm[P_HDE_MIN]:
                        if math.isnan(st[19]):
                            st[19] = math.atan2(sy, sx)
                        else:
                            e = hde_error(sx, sy, st[19])
                            if abs(e) < prm[P_HDE_THR]:
                                _scalar_update(P, 8, prm[P_HDE_R], n, K, A)
                                zi = -e - dx[8]
                                for i in range(n):
                                    dx[i] += K[i, 0] * zi
                                counters[3] += 1
                st[16], st[17], st[18] = px, py, 1.0
            # apply the error estimate to the nominal state and reset it (eq. 3)
            for i in range(6):
                st[i] += dx[i]
            if n == 15:
                for i in range(6):
                    st[10 + i] += dx[9 + i]
            st[6], st[7], st[8], st[9] = exp_times_quat(st[6], st[7], st[8], st[9], dx[6], dx[7], dx[8])
        for i in range(3):
            pos[k, i] = st[i]
            vel[k, i] = st[3 + i]
            ba[k, i] = st[10 + i]
            bg[k, i] = st[13 + i]
            pos_sig[k, i] = math.sqrt(max(P[i, i], 0.0))
        for i in range(4):
            q[k, i] = st[6 + i]
        if smooth:
            for a_ in range(n):
                buf_dx[j, a_] = dx[a_]
                for b_ in range(n):
                    buf_post[j, a_, b_] = P[a_, b_]
            seg[0] = j + 1
            end_of_stance = stance[k] and (k + 1 == N or not stance[k + 1])
            if seg[0] >= maxseg or k + 1 == N or end_of_stance:
                if seg[0] > 1:
                    counters[1] += rts_backward(buf_post, buf_pred, buf_fpar, buf_dx, seg[0], n, seg[1],
                                                pos, vel, q, ba, bg)
                counters[2] += 1
                seg[0] = 0
                seg[1] = k + 1


def run_fast(t_s, acc_b, gyro_b, stance, q0_nb, gyro_bias0_b, acc_bias0_b, gravity, settings, tb, P0, zupt_gain,
             smooth: bool, progress=None, extra_var=None):
    """Drive ``filter_chunk`` over the record in a few chunks. Returns (arrays dict, info dict)."""
    n = settings.n_states
    N = t_s.shape[0]
    dt_nom = tb.nominal_dt_s
    maxseg = max(16, int(math.ceil(settings.smoother_max_segment_s / dt_nom)))
    prm = np.zeros(N_PRM)
    prm[P_DT_NOM] = dt_nom
    prm[P_QA] = settings.sigma_acc_mps2**2 * dt_nom
    prm[P_QG] = settings.sigma_gyro_radps**2 * dt_nom
    prm[P_QBA] = settings.sigma_acc_bias_rw**2
    prm[P_QBG] = settings.sigma_gyro_bias_rw**2
    prm[P_RZ] = settings.sigma_zupt_mps**2
    prm[P_RW] = settings.sigma_zaru_radps**2
    prm[P_ZARU] = 1.0 if settings.zaru else 0.0
    prm[P_G] = gravity
    prm[P_RIC] = 1.0 if zupt_gain is not None else 0.0
    prm[P_SMOOTH] = 1.0 if smooth else 0.0
    prm[P_MAXSEG] = maxseg
    prm[P_HDE] = 1.0 if settings.heading_aid == "dominant_directions" else 0.0
    prm[P_HDE_THR] = settings.hde_threshold_rad
    prm[P_HDE_R] = settings.sigma_hde_rad**2
    prm[P_HDE_MIN] = settings.hde_min_stride_m
    prm[P_KA] = settings.acc_scale_noise**2 * dt_nom
    prm[P_KG] = settings.gyro_scale_noise**2 * dt_nom
    prm[P_LEVER] = settings.zupt_lever_arm_m**2
    prm[P_ZARU_C] = settings.zaru_rate_factor**2
    if zupt_gain is not None:
        ric_u, ric_lam, ric_t = zupt_gain.U.copy(), zupt_gain.lam.copy(), zupt_gain.T.copy()
    else:
        ric_u, ric_lam, ric_t = np.eye(3), np.zeros(3), np.zeros((2, 3))
    st = np.zeros(N_ST)
    st[19] = np.nan
    st[6:10] = q0_nb
    st[10:13] = acc_bias0_b
    st[13:16] = gyro_bias0_b
    P = P0.copy()
    out = {name: np.empty((N, 3)) for name in ("pos_n", "vel_n", "acc_bias_b", "gyro_bias_b", "pos_sigma_n")}
    out["q_nb"] = np.empty((N, 4))
    nb = maxseg if smooth else 1
    buf_post = np.empty((nb, n, n))
    buf_pred = np.empty((nb, n, n))
    buf_fpar = np.empty((nb, 13))
    buf_dx = np.empty((nb, n))
    seg = np.zeros(2, dtype=np.int64)
    counters = np.zeros(4, dtype=np.int64)
    stance_u8 = np.ascontiguousarray(stance, dtype=np.bool_)
    xvar = np.zeros((N, 6)) if extra_var is None else np.ascontiguousarray(extra_var, dtype=np.float64) * dt_nom
    n_chunks = 1 if progress is None else max(1, min(10, N // 100_000))
    bounds = np.linspace(0, N, n_chunks + 1).astype(np.int64)
    # a zero-length call compiles (or loads from the numba cache) this signature: timed separately
    tc = time.perf_counter()
    filter_chunk(0, 0, tb.dt_s, acc_b, gyro_b, stance_u8, xvar, prm, n, ric_u, ric_lam, ric_t, st, P,
                 out["pos_n"], out["vel_n"], out["q_nb"], out["acc_bias_b"], out["gyro_bias_b"],
                 out["pos_sigma_n"], buf_post, buf_pred, buf_fpar, buf_dx, seg, counters)
    compile_s = time.perf_counter() - tc
    t0 = time.perf_counter()
    for a, b in zip(bounds[:-1], bounds[1:]):
        filter_chunk(int(a), int(b), tb.dt_s, acc_b, gyro_b, stance_u8, xvar, prm, n, ric_u, ric_lam, ric_t, st, P,
                     out["pos_n"], out["vel_n"], out["q_nb"], out["acc_bias_b"], out["gyro_bias_b"],
                     out["pos_sigma_n"], buf_post, buf_pred, buf_fpar, buf_dx, seg, counters)
        if progress is not None:
            progress(float(b) / N)
    info = {
        "run_s": time.perf_counter() - t0,
        "compile_s": compile_s,
        "n_updates": int(counters[0]),
        "smoother_segments": int(counters[2]),
        "smoother_skipped_steps": int(counters[1]),
        "smoother_max_segment_samples": maxseg,
        "heading_aid_updates": int(counters[3]),
        "final_P": P,
    }
    return out, info


_WARM = False


def warm_up() -> float:
    """Compile (or load from the numba cache) every kernel variant; returns seconds spent."""
    global _WARM
    t0 = time.perf_counter()
    if not _WARM:
        from bootnav.postproc.ins.filter import run_filter
        from bootnav.postproc.ins.settings import FilterSettings

        class _Init:
            q_nb = np.array([1.0, 0.0, 0.0, 0.0])
            gyro_bias_b = np.zeros(3)

        t = np.arange(40) * 0.01
        acc = np.tile([0.0, 0.0, 9.81], (40, 1))
        gyr = np.zeros((40, 3))
        st = np.ones(40, bool)
        for n in (9, 15):
            for sm in ("rts", "none"):
                run_filter(t, acc, gyr, st, _Init(), 9.81, FilterSettings(n_states=n, smoother=sm))
        run_filter(t, acc, gyr, st, _Init(), 9.81, FilterSettings(mode="riccati"))
        _WARM = True
    return time.perf_counter() - t0
