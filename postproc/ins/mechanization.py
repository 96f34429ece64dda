"""Strapdown mechanization [Heidari2019, eq. 1; Skog2010; Nilsson2012 ``Navigation_equations``] on real timestamps.

Per sample n with Δt = t_n − t_{n−1} (nav frame ENU, g_n = [0, 0, −g], specific force f at rest = +g up):

    ψ_n = a(ω_n Δt) ψ_{n−1}                       (row 3; a(·) = closed-form Ω, q ⊗ exp(ωΔt/2), normalised)
    a_n = ψ_n f_n ψ_n⁻¹ + g_n                      (gravity removed on the nav z axis)
    v_n = v_{n−1} + a_n Δt                          (row 2)
    p_n = p_{n−1} + v_{n−1} Δt + ½ a_n Δt²          (row 1 plus OpenShoe's ½aΔt² term)

Ordering (as OpenShoe): the attitude is advanced first and sample n's specific force is rotated with ψ_n,
the attitude at the instant the sample was taken. The paper's literal ψ_{n−1} differs by O(ωΔt).
With this ordering the scheme is exact for constant body rate and constant nav-frame acceleration
(the analytic test in tests/test_ins_mechanization.py).

Timestamps: Δt varies sample to sample (jitter is used as recorded, never resampled). Δt = 0 (duplicate
timestamp): no propagation, the sample may still carry a ZUPT update. A gap (``bootnav.core.timebase``: Δt >
1.5 nominal periods, at least one sample lost) is propagated as one long step (a stance detector will usually
not vouch for it) and flagged. Δt < 0 or non-finite input: ``InputError`` naming the first bad sample index.
"""

from __future__ import annotations

import numpy as np

from bootnav.core.timebase import time_base
from bootnav.errors import InputError
from bootnav.postproc.ins.quaternion import attitude_step, quat_to_rotmat


def validate_imu(t_s, acc_b, gyro_b, stance=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return C-contiguous float64 copies-or-views; raise ``InputError`` for wrong shapes / non-finite values."""
    t_s = np.ascontiguousarray(t_s, dtype=np.float64)
    acc_b = np.ascontiguousarray(acc_b, dtype=np.float64)
    gyro_b = np.ascontiguousarray(gyro_b, dtype=np.float64)
    n = t_s.shape[0]
    if t_s.ndim != 1 or n < 2:
        raise InputError(f"t_s must be a 1-D array of at least 2 samples, got shape {t_s.shape}")
    for name, a in (("acc_b", acc_b), ("gyro_b", gyro_b)):
        if a.shape != (n, 3):
            raise InputError(f"{name} must have shape ({n}, 3) like t_s, got {a.shape}")
    for name, a in (("t_s", t_s), ("acc_b", acc_b), ("gyro_b", gyro_b)):
        bad = ~np.isfinite(a) if a.ndim == 1 else ~np.isfinite(a).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputError(
                f"{name} has a non-finite value (NaN/inf) at sample {i} (t_s={t_s[i]!r}); "
                f"{int(bad.sum())} bad sample(s) in total. Remove or interpolate them before filtering."
            )
    if stance is not None:
        stance = np.asarray(stance)
        if stance.shape != (n,):
            raise InputError(f"stance must have shape ({n},) like t_s, got {stance.shape}")
    return t_s, acc_b, gyro_b


def strapdown_step(pos_n, vel_n, q_nb, f_b, omega_b, dt, gravity):
    """One step of eq. 1 (see module docstring). Returns (pos_n, vel_n, q_nb, f_n). Numba-compatible."""
    if dt <= 0.0:
        c = quat_to_rotmat(q_nb)
        return pos_n.copy(), vel_n.copy(), q_nb.copy(), c @ f_b
    q = attitude_step(q_nb, omega_b, dt)
    c = quat_to_rotmat(q)
    f_n = c @ f_b
    acc_n = f_n.copy()
    acc_n[2] -= gravity
    vel = vel_n + acc_n * dt
    pos = pos_n + vel_n * dt + 0.5 * acc_n * dt * dt
    return pos, vel, q, f_n


def mechanize(t_s, acc_b, gyro_b, q0_nb, gravity: float, vel0_n=None, pos0_n=None):
    """Open-loop strapdown over a whole record (no filter). Returns (pos_n, vel_n, q_nb) arrays (N,3),(N,3),(N,4).

    Used for tests and for the paper's "no ZUPT, errors explode after ~10 s" illustration; a Python loop,
    fine for that purpose (the production path is ``fast.py``).
    """
    t_s, acc_b, gyro_b = validate_imu(t_s, acc_b, gyro_b)
    tb = time_base(t_s)
    n = t_s.shape[0]
    pos = np.zeros((n, 3))
    vel = np.zeros((n, 3))
    q = np.zeros((n, 4))
    pos[0] = 0.0 if pos0_n is None else pos0_n
    vel[0] = 0.0 if vel0_n is None else vel0_n
    q[0] = np.asarray(q0_nb, dtype=float) / np.linalg.norm(q0_nb)
    for k in range(1, n):
        pos[k], vel[k], q[k], _ = strapdown_step(pos[k - 1], vel[k - 1], q[k - 1], acc_b[k], gyro_b[k],
                                                 tb.dt_s[k], gravity)
    return pos, vel, q
