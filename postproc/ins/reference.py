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

from bootnav.postproc.ins.fast import hde_error
from bootnav.postproc.ins.mechanization import strapdown_step
from bootnav.postproc.ins.quaternion import correct_attitude, quat_to_rotmat
from bootnav.postproc.ins.smoother import apply_smoothed_correction, rts_backward_numpy


def skew(v: np.ndarray) -> np.ndarray:
    """[v×], the cross-product matrix."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def error_dynamics(f_n: np.ndarray, c_nb: np.ndarray, n: int) -> np.ndarray:
    """Continuous-time A of the error state (filter.py docstring)."""
    a = np.zeros((n, n))
    a[0:3, 3:6] = np.eye(3)
    a[3:6, 6:9] = -skew(f_n)
    if n == 15:
        a[3:6, 9:12] = -c_nb
        a[6:9, 12:15] = -c_nb
    return a


def process_noise(settings, dt: float, dt_nom: float, n: int, f_b=None, omega_b=None, extra=None,
                  c_nb=None) -> np.ndarray:
    """Q_d for a step of length dt (settings.py: per-sample sigmas at the nominal period, bias random walks).

    With ``acc_scale_noise`` / ``gyro_scale_noise`` κ the per-sample variance is σ² + κ² |signal|²
    (f_b, omega_b: the bias-corrected sample of this step). ``extra`` (6,) = per-sample variance of the
    body axes ax..gz of a saturated sample (filter.saturation_variance), acting along those body axes:
    Q_v += C diag(extra_acc) Cᵀ Δt₀ Δt, Q_θ += C diag(extra_gyro) Cᵀ Δt₀ Δt (c_nb: attitude of the step).
    """
    var_a = settings.sigma_acc_mps2**2 * dt_nom
    var_g = settings.sigma_gyro_radps**2 * dt_nom
    if f_b is not None:
        var_a += settings.acc_scale_noise**2 * dt_nom * float(f_b @ f_b)
    if omega_b is not None:
        var_g += settings.gyro_scale_noise**2 * dt_nom * float(omega_b @ omega_b)
    var = [var_a * dt] * 3 + [var_g * dt] * 3
    if n == 15:
        var += [settings.sigma_acc_bias_rw**2 * dt] * 3 + [settings.sigma_gyro_bias_rw**2 * dt] * 3
    q = np.diag([0.0] * 3 + var)
    if extra is not None:
        q[3:6, 3:6] += c_nb @ np.diag(extra[:3]) @ c_nb.T * dt_nom * dt
        q[6:9, 6:9] += c_nb @ np.diag(extra[3:6]) @ c_nb.T * dt_nom * dt
    return q


def run_reference(t_s, acc_b, gyro_b, stance, q0_nb, gyro_bias0_b, acc_bias0_b, gravity, settings, tb, P0,
                  zupt_gain, smooth: bool, progress=None, extra_var=None):
    n = settings.n_states
    N = t_s.shape[0]
    dt_nom = tb.nominal_dt_s
    maxseg = max(16, int(np.ceil(settings.smoother_max_segment_s / dt_nom)))
    kf = KalmanFilter(dim_x=n, dim_z=3)
    kf.P = P0.copy()
    H_zupt = np.zeros((3, n))
    H_zupt[:, 3:6] = np.eye(3)
    R_zupt = np.eye(3) * settings.sigma_zupt_mps**2
    H_zaru = np.zeros((3, n))
    if n == 15:
        H_zaru[:, 12:15] = np.eye(3)
    R_zaru = np.eye(3) * settings.sigma_zaru_radps**2

    pos, vel, q = np.zeros(3), np.zeros(3), np.asarray(q0_nb, dtype=float).copy()
    ba, bg = np.asarray(acc_bias0_b, float).copy(), np.asarray(gyro_bias0_b, float).copy()
    out = {k: np.empty((N, 3)) for k in ("pos_n", "vel_n", "acc_bias_b", "gyro_bias_b", "pos_sigma_n")}
    out["q_nb"] = np.empty((N, 4))
    seg = []  # per buffered sample: (P_pred, P_post, fpar, dx)
    seg_start = 0
    n_updates = 0
    segments = 0
    prev_stance_xy, ref_heading, hde_updates = None, None, 0
    t0 = time.perf_counter()
    for k in range(N):
        dt = tb.dt_s[k] if k > 0 else 0.0
        # --- time update: eq. 1 and P ← F P Fᵀ + Q
        f_b, omega_b = acc_b[k] - ba, gyro_b[k] - bg
        pos, vel, q, f_n = strapdown_step(pos, vel, q, f_b, omega_b, dt, gravity)
        c_nb = quat_to_rotmat(q)
        if dt > 0:
            kf.F = np.eye(n) + error_dynamics(f_n, c_nb, n) * dt
            kf.Q = process_noise(settings, dt, dt_nom, n, f_b, omega_b,
                                 None if extra_var is None else extra_var[k], c_nb)
            kf.predict()
        p_pred = kf.P.copy()
        # --- measurement update in stance (eq. 3: z = 0 − v̂)
        dx = np.zeros(n)
        if stance[k]:
            z = -vel.reshape(3, 1)  # filterpy wants a column when H is passed
            if zupt_gain is None:
                # rolling-foot ZUPT noise: R_k = σ_zupt² + (r |ω_k − b̂_g|)² (settings.py)
                w_b = gyro_b[k] - bg
                r_k = R_zupt + np.eye(3) * (settings.zupt_lever_arm_m**2 * float(w_b @ w_b))
                kf.update(z, R=r_k, H=H_zupt)
                if settings.zaru and n == 15:
                    # R_k = σ_zaru² + (c |ω_k − b̂_g|)² (the foot's own rate counts as noise: quiet core only)
                    kf.update((gyro_b[k] - bg).reshape(3, 1), R=R_zaru + np.eye(3) * (settings.zaru_rate_factor**2 * float(w_b @ w_b)),
                              H=H_zaru)
                n_updates += 1
            elif dt > 0:
                # paper mode: constant Riccati gain, Joseph form with that gain
                gain = zupt_gain.discrete(dt)
                kf.x = gain @ z
                ikh = np.eye(n) - gain @ H_zupt
                kf.P = ikh @ kf.P @ ikh.T + gain @ R_zupt @ gain.T
                n_updates += 1
            if settings.heading_aid == "dominant_directions" and (k == 0 or not stance[k - 1]):
                # OPTIONAL heuristic heading aid: yaw pseudo-measurement from the stride heading
                x_now = np.asarray(kf.x, dtype=float).reshape(-1)
                here = pos[:2] + x_now[:2]
                if prev_stance_xy is not None:
                    stride = here - prev_stance_xy
                    if np.hypot(*stride) >= settings.hde_min_stride_m:
                        if ref_heading is None:
                            ref_heading = float(np.arctan2(stride[1], stride[0]))
                        else:
                            e = hde_error(stride[0], stride[1], ref_heading)
                            if abs(e) < settings.hde_threshold_rad:
                                H_yaw = np.zeros((1, n))
                                H_yaw[0, 8] = 1.0
                                kf.update(np.array([[-e]]), R=np.array([[settings.sigma_hde_rad**2]]), H=H_yaw)
                                hde_updates += 1
                prev_stance_xy = here
            dx = np.asarray(kf.x, dtype=float).reshape(-1).copy()
            # --- reset: apply δx to the nominal state, δx ← 0
            pos = pos + dx[0:3]
            vel = vel + dx[3:6]
            q = correct_attitude(q, dx[6:9])
            if n == 15:
                ba = ba + dx[9:12]
                bg = bg + dx[12:15]
            kf.x = np.zeros((n, 1))
        out["pos_n"][k], out["vel_n"][k], out["q_nb"][k] = pos, vel, q
        out["acc_bias_b"][k], out["gyro_bias_b"][k] = ba, bg
        out["pos_sigma_n"][k] = np.sqrt(np.maximum(np.diag(kf.P)[:3], 0.0))
        if smooth:
            seg.append((p_pred, kf.P.copy(), np.concatenate([[dt], f_n, c_nb.ravel()]), dx))
            end_of_stance = stance[k] and (k + 1 == N or not stance[k + 1])
            if len(seg) >= maxseg or k + 1 == N or end_of_stance:
                _smooth_segment(seg, seg_start, n, out)
                segments += 1
                seg = []
                seg_start = k + 1
        if progress is not None and N >= 10 and k % (N // 10) == 0:
            progress(k / N)
    if progress is not None:
        progress(1.0)
    info = {"run_s": time.perf_counter() - t0, "n_updates": n_updates, "smoother_segments": segments,
            "heading_aid_updates": hde_updates,
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
