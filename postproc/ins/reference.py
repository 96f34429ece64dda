"""Reference engine: the ZUPT error-state filter as a textbook per-sample loop on filterpy's ``KalmanFilter``.

Transparent on purpose (slow: a Python loop): every step reads like the equations in ``filter.py``'s
docstring, so the fast numba engine can be checked against it (tests/test_ins_engines.py: same trajectory to
1e-9 m). The error state lives in ``kf.x`` (zero after every reset), the covariance in ``kf.P``;
``kf.predict()`` does P ← F P Fᵀ + Q and ``kf.update()`` does the Joseph-form update.
"""

from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import KalmanFilter

from bootnav.postproc.ins.layout import (BIAS_ACC, BIAS_GYRO, ERR_BA, ERR_BG, ERR_P, ERR_TH, ERR_V, POS, QUAT, VEL,
                                         initial_nominal_state)
from bootnav.postproc.ins.measurements import N_KINDS, ZuptMeasurement, active_measurements
from bootnav.postproc.ins.mechanization import strapdown_step
from bootnav.postproc.ins.quaternion import correct_attitude, quat_to_rotmat
from bootnav.postproc.ins.smoother import apply_smoothed_correction, error_dynamics, rts_backward_numpy


def process_noise(prm, dt: float, dt_nom: float, n: int, f_b=None, omega_b=None, extra=None,
                  c_nb=None) -> np.ndarray:
    """Q_d for a step of length dt (settings.py: per-sample sigmas at the nominal period, bias random walks).

    With ``acc_scale_noise`` / ``gyro_scale_noise`` κ the per-sample variance is σ² + κ² |signal|²
    (f_b, omega_b: the bias-corrected sample of this step). ``extra`` (6,) = per-sample variance of the
    body axes ax..gz of a saturated sample (filter.saturation_variance), acting along those body axes:
    Q_v += C diag(extra_acc) Cᵀ Δt₀ Δt, Q_θ += C diag(extra_gyro) Cᵀ Δt₀ Δt (c_nb: attitude of the step).
    ``prm``: ``params.KernelParams``.
    """
    var_a = prm.var_acc
    var_g = prm.var_gyro
    if f_b is not None:
        var_a += prm.var_acc_scale * float(f_b @ f_b)
    if omega_b is not None:
        var_g += prm.var_gyro_scale * float(omega_b @ omega_b)
    var = np.zeros(n)  # position: no noise of its own
    var[ERR_V] = var_a * dt
    var[ERR_TH] = var_g * dt
    if n == 15:
        var[ERR_BA] = prm.var_acc_bias_rw * dt
        var[ERR_BG] = prm.var_gyro_bias_rw * dt
    q = np.diag(var)
    if extra is not None:
        q[ERR_V, ERR_V] += c_nb @ np.diag(extra[:3]) @ c_nb.T * dt_nom * dt
        q[ERR_TH, ERR_TH] += c_nb @ np.diag(extra[3:6]) @ c_nb.T * dt_nom * dt
    return q


def run_reference(t_s, acc_b, gyro_b, stance, q0_nb, gyro_bias0_b, acc_bias0_b, settings, tb, P0, zupt_gain, prm,
                  progress=None, extra_var=None):
    """The filter as a per-sample loop (arguments and results as ``fast.run_fast``)."""
    n = settings.n_states
    N = t_s.shape[0]
    dt_nom = tb.nominal_dt_s
    kf = KalmanFilter(dim_x=n, dim_z=3)
    kf.P = P0.copy()
    measurements = active_measurements(settings, prm)
    zupt = ZuptMeasurement(prm, n)  # paper mode: its z, with the constant Riccati gain
    H_zupt = np.zeros((3, n))
    H_zupt[:, ERR_V] = np.eye(3)
    R_zupt = np.eye(3) * prm.var_zupt

    st = initial_nominal_state(q0_nb, acc_bias0_b, gyro_bias0_b)
    out = {k: np.empty((N, 3)) for k in ("pos_n", "vel_n", "acc_bias_b", "gyro_bias_b", "pos_sigma_n")}
    out["q_nb"] = np.empty((N, 4))
    seg = []  # per buffered sample: (P_pred, P_post, fpar, dx)
    seg_start = 0
    applied = np.zeros(N_KINDS, dtype=np.int64)
    segments = 0
    t0 = time.perf_counter()
    for k in range(N):
        dt = tb.dt_s[k] if k > 0 else 0.0
        # --- time update: eq. 1 and P ← F P Fᵀ + Q
        f_b, omega_b = acc_b[k] - st[BIAS_ACC], gyro_b[k] - st[BIAS_GYRO]
        st[POS], st[VEL], st[QUAT], f_n = strapdown_step(st[POS], st[VEL], st[QUAT], f_b, omega_b, dt, prm.gravity)
        c_nb = quat_to_rotmat(st[QUAT])
        if dt > 0:
            kf.F = np.eye(n) + error_dynamics(f_n, c_nb, n) * dt
            kf.Q = process_noise(prm, dt, dt_nom, n, f_b, omega_b,
                                 None if extra_var is None else extra_var[k], c_nb)
            kf.predict()
        p_pred = kf.P.copy()
        # --- measurement updates (measurements.py), sequential: filterpy's innovation is z − H kf.x
        updated = False
        if zupt_gain is None:
            for meas in measurements:
                zhr = meas.evaluate(st, np.asarray(kf.x, dtype=float).reshape(-1), acc_b, gyro_b, stance, k)
                if zhr is not None:
                    z, h, r = zhr
                    kf.update(z.reshape(-1, 1), R=r, H=h)  # filterpy wants a column when H is passed
                    applied[meas.kind] += 1
                    updated = True
        elif stance[k] and dt > 0:
            # paper mode: constant Riccati gain on the ZUPT's z = −v̂, Joseph form with that gain
            z, _, _ = zupt.evaluate(st, np.zeros(n), acc_b, gyro_b, stance, k)
            gain = zupt_gain.discrete(dt, zupt_gain.tau[k], c_nb, n)
            kf.x = gain @ z.reshape(3, 1)
            ikh = np.eye(n) - gain @ H_zupt
            kf.P = ikh @ kf.P @ ikh.T + gain @ R_zupt @ gain.T
            applied[zupt.kind] += 1
            updated = True
        dx = np.asarray(kf.x, dtype=float).reshape(-1).copy()
        if updated:
            # --- reset: apply δx to the nominal state, δx ← 0
            st[POS] += dx[ERR_P]
            st[VEL] += dx[ERR_V]
            st[QUAT] = correct_attitude(st[QUAT], dx[ERR_TH])
            if n == 15:
                st[BIAS_ACC] += dx[ERR_BA]
                st[BIAS_GYRO] += dx[ERR_BG]
            kf.x = np.zeros((n, 1))
        out["pos_n"][k], out["vel_n"][k], out["q_nb"][k] = st[POS], st[VEL], st[QUAT]
        out["acc_bias_b"][k], out["gyro_bias_b"][k] = st[BIAS_ACC], st[BIAS_GYRO]
        out["pos_sigma_n"][k] = np.sqrt(np.maximum(np.diag(kf.P)[ERR_P], 0.0))
        if prm.smooth:
            seg.append((p_pred, kf.P.copy(), np.concatenate([[dt], f_n, c_nb.ravel()]), dx))
            end_of_stance = stance[k] and (k + 1 == N or not stance[k + 1])
            if len(seg) >= prm.max_segment or k + 1 == N or end_of_stance:
                _smooth_segment(seg, seg_start, n, out)
                segments += 1
                seg = []
                seg_start = k + 1
        if progress is not None and N >= 10 and k % (N // 10) == 0:
            progress(k / N)
    if progress is not None:
        progress(1.0)
    info = {"run_s": time.perf_counter() - t0, "applied": applied, "smoother_segments": segments,
            "final_P": kf.P.copy()}
    return out, info


def _smooth_segment(seg, start, n, out):
    m = len(seg)
    if m < 2:
        return
    p_pred = np.array([s[0] for s in seg])
    p_post = np.array([s[1] for s in seg])
    fpar = np.array([s[2] for s in seg])
    dx_upd = np.array([s[3] for s in seg])
    dxs = rts_backward_numpy(p_post, p_pred, fpar, dx_upd, m, n)
    for j in range(m - 1):
        k = start + j
        apply_smoothed_correction(out["pos_n"][k], out["vel_n"][k], out["q_nb"][k], out["acc_bias_b"][k],
                                  out["gyro_bias_b"][k], dxs[j])
