"""Strapdown mechanization [Heidari2019, eq. 1; Skog2010; Nilsson2012 ``Navigation_equations``] on real timestamps.

Per sample n with Δt = t_n − t_{n−1} (nav frame ENU, g_n = [0, 0, −g], specific force f at rest = +g up):

    ψ_n = a(ω_n Δt) ψ_{n−1}                       (row 3; a(·) = closed-form Ω, q ⊗ exp(ωΔt/2), normalised)
    a_n = ψ_m f_n ψ_m⁻¹ + g_n,  ψ_m = a(ω_n Δt/2) ψ_{n−1}   (gravity removed on the nav z axis)
    v_n = v_{n−1} + a_n Δt                          (row 2)
    p_n = p_{n−1} + v_{n−1} Δt + ½ a_n Δt²          (row 1 plus OpenShoe's ½aΔt² term)

Which attitude rotates f_n ("midpoint", the default of ``FilterSettings.strapdown``): ψ_m, the attitude at the
middle of the step. The attitude step uses the rate ω_n over the whole interval (t_{n−1}, t_n], so ψ_n is the
attitude at the interval's END whatever the sample is: for a point sample of a rate that changes (a foot
starting from rest) the rectangle step runs half a sample ahead (ψ_n ≈ ψ(t_n + Δt/2)); for a sample that is
the average over its interval (a block mean, a sensor's accumulate-and-dump: the increments Δθ/Δt, Δv/Δt)
the step is exact and f_n belongs to the interval's middle. Either way f_n belongs to ψ_m: the first-order
rotation-compensation term ½ Δθ × Δv of an increment strapdown [Savage1998]. Rotating with ψ_n (OpenShoe's
ordering, "endpoint") pairs f_n with an attitude Δt/2 later, a timing error of the vertical channel that grows
with 1/rate (2.5 ms at 200 Hz: about 0.1 m of vertical drift per ms over a 60-80 m loop; docs/tuning-log.md).
"endpoint" is exact for a constant body rate since the start (the analytic test in
tests/test_ins_mechanization.py); "midpoint" is second order in ωΔt there, and rate-independent on a foot.

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


def strapdown_step(pos_n, vel_n, q_nb, f_b, omega_b, dt, gravity, midpoint: bool = True):
    """One step of eq. 1 (see module docstring). Returns (pos_n, vel_n, q_nb, f_n, C_nb that rotated f_b)."""
    if dt <= 0.0:
        c = quat_to_rotmat(q_nb)
        return pos_n.copy(), vel_n.copy(), q_nb.copy(), c @ f_b, c
    if midpoint:
        q_mid = attitude_step(q_nb, omega_b, 0.5 * dt)
        c = quat_to_rotmat(q_mid)
        q = attitude_step(q_mid, omega_b, 0.5 * dt)
    else:
        q = attitude_step(q_nb, omega_b, dt)
        c = quat_to_rotmat(q)
    f_n = c @ f_b
    acc_n = f_n.copy()
    acc_n[2] -= gravity
    vel = vel_n + acc_n * dt
    pos = pos_n + vel_n * dt + 0.5 * acc_n * dt * dt
    return pos, vel, q, f_n, c


def mechanize(t_s, acc_b, gyro_b, q0_nb, gravity: float, vel0_n=None, pos0_n=None, midpoint: bool = True):
    """Open-loop strapdown over a whole record (no filter). Returns (pos_n, vel_n, q_nb) arrays (N,3),(N,3),(N,4).

    ``midpoint``: which attitude rotates f_b (``FilterSettings.strapdown``: True = "midpoint").

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
        pos[k], vel[k], q[k], _, _ = strapdown_step(pos[k - 1], vel[k - 1], q[k - 1], acc_b[k], gyro_b[k],
                                                    tb.dt_s[k], gravity, midpoint)
    return pos, vel, q
