"""Rotation conversions: ZYX Euler angles <-> quaternion / DCM, quaternion product (vectorised, Python level).

Conventions (``bootnav.CONVENTIONS``): quaternions scalar first ``q = [w, x, y, z]``; ``q_nb`` rotates body to
navigation frame, ``v_n = C_nb v_b``; ZYX (yaw-pitch-roll, intrinsic) Euler angles

    C_nb = Rz(yaw) Ry(pitch) Rx(roll)        [Groves2013, §2.2]

The conversions go through ``scipy.spatial.transform.Rotation`` (its quaternions are scalar last; converted
here). The per-sample kernels of the filter (numba) keep their own scalar code; nothing at Python level
converts Euler angles any other way.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def _angles(roll, pitch, yaw) -> tuple[np.ndarray, tuple[int, ...]]:
    r, p, y = np.broadcast_arrays(*(np.asarray(a, dtype=np.float64) for a in (roll, pitch, yaw)))
    return np.stack([y, p, r], axis=-1).reshape(-1, 3), r.shape


def quat_from_euler_zyx(roll, pitch, yaw=0.0, *, canonical: bool = True) -> np.ndarray:
    """Quaternion ``q_nb`` (wxyz) of ``C_nb = Rz(yaw) Ry(pitch) Rx(roll)``.

    Parameters
    ----------
    roll, pitch, yaw : float or array_like
        Angles (rad), broadcast together.
    canonical : bool
        True: sign chosen so that ``w >= 0`` (q and -q are the same rotation). False: the half-angle product
        ``q_z(yaw) ⊗ q_y(pitch) ⊗ q_x(roll)`` as is, continuous in the angles (for a trajectory whose yaw
        grows past ±π).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions, scalar first.
    """
    ypr, shape = _angles(roll, pitch, yaw)
    xyzw = Rotation.from_euler("ZYX", ypr).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    if canonical:
        q[q[:, 0] < 0] *= -1.0
    return q.reshape(shape + (4,))


def dcm_from_euler_zyx(roll, pitch, yaw=0.0) -> np.ndarray:
    """Direction-cosine matrix ``C_nb = Rz(yaw) Ry(pitch) Rx(roll)``, shape (..., 3, 3) (angles in rad)."""
    ypr, shape = _angles(roll, pitch, yaw)
    return Rotation.from_euler("ZYX", ypr).as_matrix().reshape(shape + (3, 3))


def euler_zyx_from_quat(q_nb) -> np.ndarray:
    """ZYX Euler angles ``[roll, pitch, yaw]`` (rad), shape (..., 3), of quaternions ``q_nb`` (wxyz, (..., 4)).

    Pitch is in [-π/2, π/2], roll and yaw in (-π, π] (inverse of ``quat_from_euler_zyx`` on that range).
    """
    q = np.asarray(q_nb, dtype=np.float64)
    flat = q.reshape(-1, 4)
    ypr = Rotation.from_quat(np.concatenate([flat[:, 1:], flat[:, :1]], axis=1)).as_euler("ZYX")
    return ypr[:, ::-1].reshape(q.shape[:-1] + (3,))


def quat_multiply(p, q) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of wxyz quaternions, broadcasting over leading axes (any norm)."""
    pw, px, py, pz = np.moveaxis(np.asarray(p, dtype=np.float64), -1, 0)
    qw, qx, qy, qz = np.moveaxis(np.asarray(q, dtype=np.float64), -1, 0)
    return np.stack([pw * qw - px * qx - py * qy - pz * qz, pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx, pw * qz + px * qy - py * qx + pz * qw], axis=-1)


def quat_conjugate(q) -> np.ndarray:
    """``[w, -x, -y, -z]``: the inverse rotation of a unit quaternion."""
    return np.asarray(q, dtype=np.float64) * np.array([1.0, -1.0, -1.0, -1.0])
