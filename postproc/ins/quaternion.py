"""Unit-quaternion helpers (wxyz, scalar first; ``q_nb`` rotates body -> nav).

Plain NumPy on small arrays, used by the reference engine, the mechanization check and the tests. The
fast engine uses the scalar kernels of ``kernels.py``; the DCM has one definition there
(``kernels.rotmat_into``), which ``quat_to_rotmat`` runs as plain Python. Euler angles: ``bootnav.core.rotations``.

Conventions (bootnav.CONVENTIONS): ``q_nb = [w, x, y, z]``; ``v_n = C(q_nb) v_b``;
body angular rate integrates on the right, ``q_nb(t+dt) = q_nb(t) ⊗ exp(ω_b dt / 2)``; a nav-frame
correction rotation integrates on the left, ``q_nb ← exp(δθ_n / 2) ⊗ q_nb``.
"""

from __future__ import annotations

import math

import numpy as np

from bootnav.postproc.ins.kernels import rotmat_into


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` (wxyz)."""
    out = np.empty(4)
    out[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    out[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
    out[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
    out[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]
    return out


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternion with non-negative scalar part (q and -q are the same rotation)."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[0] < 0.0:
        n = -n
    out = np.empty(4)
    for i in range(4):
        out[i] = q[i] / n
    return out


def rotvec_to_quat(theta: np.ndarray) -> np.ndarray:
    """``exp(θ/2)`` for a rotation vector θ (rad): ``[cos(|θ|/2), sin(|θ|/2) θ/|θ|]``.

    This is the closed form behind OpenShoe's Ω(ωΔt) matrix [Skog2010; Heidari2019, eq. 1, a(·)]:
    ``Ω(θ) = cos(|θ|/2) I₄ + (2/|θ|) sin(|θ|/2) Ω̃(θ/2)`` applied to q equals ``q ⊗ exp(θ/2)``.
    For |θ| < 1e-8 the series ``sin(x/2)/x ≈ 1/2 − x²/48`` avoids 0/0.
    """
    a = math.sqrt(theta[0] * theta[0] + theta[1] * theta[1] + theta[2] * theta[2])
    out = np.empty(4)
    out[0] = math.cos(0.5 * a)
    s = math.sin(0.5 * a) / a if a > 1e-8 else 0.5 - a * a / 48.0
    out[1] = s * theta[0]
    out[2] = s * theta[1]
    out[3] = s * theta[2]
    return out


def quat_to_rotmat(q: np.ndarray) -> np.ndarray:
    """Direction-cosine matrix ``C_nb`` of a unit quaternion ``q_nb`` (v_n = C_nb v_b)."""
    c = np.empty((3, 3))
    rotmat_into.py_func(c, q[0], q[1], q[2], q[3])
    return c


def attitude_step(q_nb: np.ndarray, omega_b: np.ndarray, dt: float) -> np.ndarray:
    """Eq. 1 row 3: ``ψ_n = a(ω_n Δt) ψ_{n−1}``, i.e. ``q ⊗ exp(ω Δt / 2)``, renormalised."""
    th = np.empty(3)
    for i in range(3):
        th[i] = omega_b[i] * dt
    return quat_normalize(quat_multiply(q_nb, rotvec_to_quat(th)))


def correct_attitude(q_nb: np.ndarray, dtheta_n: np.ndarray) -> np.ndarray:
    """ZUPT attitude reset ([Heidari2019, eq. 3], ``ψ ← a(dθ) ψ``): ``q ← exp(δθ_n/2) ⊗ q`` (nav frame), renormalised.

    δθ_n is the small nav-frame rotation that takes the estimated attitude to the true one
    (``C_true ≈ (I + [δθ×]) C_est``). The exact rotation is used rather than OpenShoe's first-order
    ``R ← (I − [dθ×]) R`` (whose sign reflects OpenShoe's opposite error definition); both agree to O(δθ²).
    """
    return quat_normalize(quat_multiply(rotvec_to_quat(dtheta_n), q_nb))
