"""Exact IMU signals of a sensor mounted on the boot, from the foot trajectory.

Frames: n = ENU navigation frame (z up); f = foot frame (x toe-ward, y left, z up when flat);
s = b = sensor (body) frame. Foot attitude from ZYX Euler angles (yaw psi, pitch beta, roll phi):

    R_nf = Rz(psi) Ry(beta) Rx(phi)
    omega_f = [phi' - psi' sin(beta),
               beta' cos(phi) + psi' cos(beta) sin(phi),
               -beta' sin(phi) + psi' cos(beta) cos(phi)]          (body-frame rate, exact)
    omega_f' = d/dt of the above (product rule, uses the angles' second derivatives)

Sensor mount: lever arm r_f (sensor origin in foot coordinates) and fixed rotation R_fs. Rigid body
(R_nf' = R_nf [omega_f x]):

    p_s = p_f + R_nf r_f
    v_s = v_f + R_nf (omega_f x r_f)
    a_s = a_f + R_nf (omega_f' x r_f + omega_f x (omega_f x r_f))
    R_ns = R_nf R_fs,   q_ns = q_z(psi) (x) q_y(beta) (x) q_x(phi) (x) q_fs     (wxyz)
    omega_s = R_fs^T omega_f
    f_s = R_ns^T (a_s - g_n),  g_n = [0, 0, -g]    (specific force: +g on the up axis at rest)

These are the exact continuous-time signals at every sample instant; no numerical differentiation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bootnav.core.rotations import dcm_from_euler_zyx, quat_from_euler_zyx, quat_multiply
from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from bootnav.simulator.trajectory import Trajectory


@dataclass(frozen=True)
class Mount:
    """Where the sensor sits on the boot: lever arm (foot frame, m) and its rotation (ZYX, deg).

    Default: on the instep of the right boot, 6 cm ahead of and 7 cm above the sole origin, sensor
    axes = foot axes. ``rpy_deg`` = (roll, pitch, yaw) of the sensor axes relative to the foot axes.
    """

    name: str = "right_boot"
    lever_arm_m: tuple[float, float, float] = (0.06, 0.0, 0.07)
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    foot: str = "right"  # "left" mirrors the swing roll (inversion turns the sole the other way)

    @property
    def R_fs(self) -> np.ndarray:
        return dcm_from_euler_zyx(*np.radians(self.rpy_deg))

    @property
    def q_fs(self) -> np.ndarray:
        return quat_from_euler_zyx(*np.radians(self.rpy_deg), canonical=False)


MOUNTS = {
    "right_boot": Mount(),
    "left_boot": Mount("left_boot", foot="left"),
    # on the outside of the right boot, x forward, y down, z to the right (rotated about x by -90 deg)
    "right_boot_side": Mount("right_boot_side", (0.0, -0.05, 0.06), (-90.0, 0.0, 0.0)),
    # tilted and skewed mount, to test alignment code
    "right_boot_tilted": Mount("right_boot_tilted", (0.08, 0.01, 0.06), (5.0, -20.0, 10.0)),
}


@dataclass
class Kinematics:
    """Exact sensor truth at times ``t`` (all arrays have N rows)."""

    t_s: np.ndarray
    pos_n: np.ndarray  # sensor position (not shifted)
    vel_n: np.ndarray
    acc_n: np.ndarray
    q_nb: np.ndarray  # wxyz
    f_b: np.ndarray  # specific force, body (sensor) frame
    omega_b: np.ndarray  # angular rate, body frame
    foot_pos_n: np.ndarray
    stance: np.ndarray  # bool


def synthesize(traj: Trajectory, t: np.ndarray, mount: Mount = Mount(), g: float = STANDARD_GRAVITY) -> Kinematics:
    """Exact specific force and angular rate of the mounted sensor at times ``t`` (see module doc)."""
    val, d1, d2, still = traj.evaluate(t)
    yaw, pit, rol = val[:, 3], val[:, 4], val[:, 5]
    w_f, dw_f = euler_zyx_body_rate(val[:, 3:6], d1[:, 3:6], d2[:, 3:6])
    R_nf = dcm_from_euler_zyx(rol, pit, yaw)
    q_nf = quat_from_euler_zyx(rol, pit, yaw, canonical=False)
    return mounted_kinematics(t, val[:, :3], d1[:, :3], d2[:, :3], R_nf, q_nf, w_f, dw_f, mount, still, g)


def euler_zyx_body_rate(ang: np.ndarray, d1: np.ndarray, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body-frame rate and its derivative of ``R = Rz(yaw) Ry(pitch) Rx(roll)``; columns (yaw, pitch, roll).

    ``ang``, ``d1``, ``d2``: (N, 3) angles and their first and second time derivatives (see module doc).
    """
    pit, rol = ang[:, 1], ang[:, 2]
    dy, dp, dr = d1[:, 0], d1[:, 1], d1[:, 2]
    ddy, ddp, ddr = d2[:, 0], d2[:, 1], d2[:, 2]
    sp, cp, sr, cr = np.sin(pit), np.cos(pit), np.sin(rol), np.cos(rol)
    w_f = np.stack([dr - dy * sp, dp * cr + dy * cp * sr, -dp * sr + dy * cp * cr], axis=-1)
    dw_f = np.stack([
        ddr - ddy * sp - dy * cp * dp,
        ddp * cr - dp * sr * dr + ddy * cp * sr - dy * sp * dp * sr + dy * cp * cr * dr,
        -ddp * sr - dp * cr * dr + ddy * cp * cr - dy * sp * dp * cr - dy * cp * sr * dr,
    ], axis=-1)
    return w_f, dw_f


def mounted_kinematics(t, p_f, v_f, a_f, R_nf, q_nf, w_f, dw_f, mount: Mount, still,
                       g: float = STANDARD_GRAVITY) -> Kinematics:
    """Exact signals of the sensor on ``mount`` from the foot (boot) frame's motion (module doc, rigid body).

    ``p_f, v_f, a_f``: foot origin position, velocity, acceleration (N, 3, nav); ``R_nf`` (N, 3, 3) and
    ``q_nf`` (N, 4) its attitude; ``w_f, dw_f`` its body rate and rate derivative (N, 3, foot frame).
    """
    r = np.asarray(mount.lever_arm_m, dtype=float)
    wxr = np.cross(w_f, r)
    rel_acc = np.cross(dw_f, r) + np.cross(w_f, wxr)
    pos = p_f + R_nf @ r
    vel = v_f + np.einsum("nij,nj->ni", R_nf, wxr)
    acc = a_f + np.einsum("nij,nj->ni", R_nf, rel_acc)
    R_fs = mount.R_fs
    R_ns = R_nf @ R_fs
    q_ns = quat_multiply(q_nf, mount.q_fs)
    omega_s = w_f @ R_fs  # R_fs^T w_f, row-wise
    f_s = np.einsum("nji,nj->ni", R_ns, acc + np.array([0.0, 0.0, g]))
    return Kinematics(np.asarray(t, float), pos, vel, acc, q_ns, f_s, omega_s, p_f.copy(), still)


def describe_mount(m: Mount) -> dict:
    return {"mount": m.name, "foot": m.foot, "lever_arm_m": list(m.lever_arm_m), "mount_rpy_deg": list(m.rpy_deg),
            "mount_frame_note": "lever arm in foot frame (x toe-ward, y left, z up); rpy of sensor axes vs foot"}

