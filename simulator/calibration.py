"""Hand-held calibration session (scenario ``calibration``): a boot turned by hand through static poses.

What a person does with the boot on a table and no equipment: hold it still in 12 or more poses (flat, on
its sides, upside down, nose up / down, and 45 degree tilts between them) for 2-5 s each, turn it by hand
from one pose to the next about one of its axes, and turn it a full 360 degrees on the flat table surface a
few times. Imperfect on purpose: every pose misses its face by a few degrees, every rotation has its own
seeded angle error, axis and peak rate (50-300 deg/s), and the hand trembles throughout.

This is not a foot trajectory. The boot frame f (the foot frame of ``imu_synth``: x toe-ward, y left, z up
when flat) has the attitude

    q_nf(t) = q_base(t) (x) q_d(t)
    q_base  = q_k                                        while pose k is held
            = q_k (x) exp(theta_k S(tau) u_k / 2)        during move k -> k+1, tau = (t - t0) / T_k
    S(tau)  = 35 tau^4 - 84 tau^5 + 70 tau^6 - 20 tau^7  (rest to rest; S', S'', S''' = 0 at both ends)
    q_d     = q_z(gamma) (x) q_y(beta) (x) q_x(alpha)    (hand tremor and drift: small ZYX angles)

with ``u_k`` the move's axis in the boot frame (a hand move: the relative rotation between the two poses;
a table turn: the vertical expressed in the boot frame, constant because the axis is fixed in both frames).
Body rates are exact: ``w_base = theta S'(tau) / T u``, ``w_base' = theta S''(tau) / T^2 u``, the tremor's
``w_d, w_d'`` from the ZYX formula (``imu_synth.euler_zyx_body_rate``), and for the product

    w_f  = R_d^T w_base + w_d,      w_f' = R_d^T w_base' - w_d x (R_d^T w_base) + w_d'.

The boot turns about its centroid ``c_f`` (in the boot frame), which sits at a fixed point plus the hand's
translational tremor and drift ``P(t)`` (sums of sinusoids, derivatives exact); the foot origin is
``P - R_nf c_f`` and the sensor follows from the mount exactly as for a walk (``imu_synth.mounted_kinematics``),
so specific force and angular rate are exact and pass through the same sensor model (``imu_model``).

Targets: a pose is the nominal face (the gravity direction the person aims for, tracked through the nominal
moves) made exactly level, then missed by a seeded rotation of ``pose_error_deg`` per axis; the move between
two poses is their relative rotation (one axis, close to the nominal one). Tremor [Wade1982]: postural hand
tremor has its dominant peak at 6-12 Hz with a modal amplitude of 0.01 g (0.0015-0.035 g) at the hand;
most of the displacement is in the slow band below 3.5 Hz [Carignan2009]. A boot (about 1 kg) is a loaded
hand resting on a table, so the model uses the unloaded figures as an upper range.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from bootnav.core.rotations import quat_conjugate, quat_multiply
from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from bootnav.simulator.imu_synth import Kinematics, Mount, euler_zyx_body_rate, mounted_kinematics


@dataclass(frozen=True)
class CalibrationPlan:
    """Every number of the hand-held session (saved with the recording; [ENG] = engineering choice)."""

    hold_s: tuple[float, float] = (2.0, 5.0)  # each pose held (brief of issue 23)
    first_last_hold_s: float = 5.0  # the first and last pose: the longest hold
    peak_rate_dps: tuple[float, float] = (50.0, 300.0)  # peak rate of a move, drawn log-uniform
    pose_error_deg: float = 3.0  # sigma per axis of the miss of a face [ENG]
    table_turn_error_deg: float = 10.0  # sigma of a full turn's angle around 360 deg [ENG]
    centroid_f_m: tuple[float, float, float] = (0.03, 0.0, 0.06)  # boot centroid in the boot frame [ENG]
    # hand tremor (ZYX angles, rad; position, m): physiological band and slow drift, per axis
    tremor_hz: tuple[float, float] = (8.0, 12.0)  # [Wade1982], [Lakie2015]: peak 6-12 Hz
    tremor_acc_mps2: tuple[float, float] = (0.002 * STANDARD_GRAVITY, 0.01 * STANDARD_GRAVITY)  # per component
    tremor_lever_m: float = 0.3  # angular tremor = linear tremor / forearm lever [ENG]
    drift_hz: tuple[float, float] = (0.1, 1.0)  # slow sway [Carignan2009] (most displacement < 3.5 Hz)
    drift_angle_deg: float = 0.1  # amplitude per axis of each of 3 components [ENG] (a few tenths in all)
    drift_pos_m: float = 0.001  # amplitude per axis of each of 3 components [ENG] (a few mm in all)


# Nominal session: (kind, boot-frame axis or None, angle deg). "hand": rotation about a boot axis by hand,
# ending on a held pose; "turn": a full turn on the table about the vertical. 23 held poses, of which 14
# distinct gravity directions (6 faces, 8 tilts of 45 deg) and every boot axis turned about.
NOMINAL_MOVES: tuple[tuple[str, int | None, float], ...] = (
    *(("hand", 0, 45.0),) * 8,  # roll over about x in 45 deg steps: flat, tilt, side, ..., upside down, ..., flat
    ("turn", None, 360.0),
    ("hand", 1, -45.0), ("hand", 1, -45.0),  # nose up in two steps
    ("hand", 1, 135.0), ("hand", 1, 45.0),  # over to nose down 45, then nose down
    ("hand", 1, -90.0),  # back flat
    ("turn", None, -360.0),
    ("hand", 0, -90.0),  # onto the other side
    ("hand", 2, 45.0), ("hand", 2, 45.0),  # on its side, about z: nose 45 up, nose up
    ("hand", 2, -135.0),  # nose 45 down
    ("hand", 2, 45.0),  # back to the side
    ("hand", 0, 90.0),  # flat
    ("turn", None, 360.0),
)


def _septic(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S, dS/dtau, d2S/dtau2 of the rest-to-rest septic (module doc)."""
    t2 = tau * tau
    s = t2 * t2 * (35.0 - 84.0 * tau + 70.0 * t2 - 20.0 * t2 * tau)
    u = tau * (1.0 - tau)
    return s, 140.0 * u**3, 420.0 * u * u * (1.0 - 2.0 * tau)


def _quat_exp(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternion (wxyz) of rotation vectors (..., 3)."""
    rotvec = np.asarray(rotvec, dtype=float)
    ang = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * ang
    k = np.where(ang > 1e-300, np.sin(half) / np.where(ang > 0, ang, 1.0), 0.5)
    return np.concatenate([np.cos(half), k * rotvec], axis=-1)


def _quat_log(q: np.ndarray) -> np.ndarray:
    """Rotation vector (angle in [0, pi]) of a unit quaternion."""
    q = np.asarray(q, dtype=float)
    q = q if q[0] >= 0 else -q
    s = np.linalg.norm(q[1:])
    if s < 1e-15:
        return 2.0 * q[1:]
    return 2.0 * math.atan2(s, q[0]) * q[1:] / s


def _dcm(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4), wxyz, body -> nav."""
    w, x, y, z = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def _level(q_nf: np.ndarray, up_f: np.ndarray) -> np.ndarray:
    """``q_nf`` turned (about a horizontal nav axis) so that the boot-frame direction ``up_f`` points up."""
    a = _dcm(q_nf) @ up_f
    axis = np.cross(a, [0.0, 0.0, 1.0])
    s = np.linalg.norm(axis)
    ang = math.atan2(s, float(a[2]))
    if s < 1e-15:
        return q_nf
    return quat_multiply(_quat_exp(axis / s * ang), q_nf)


@dataclass
class _Sines:
    """Sum of sinusoids per channel: value and two exact derivatives."""

    amp: np.ndarray  # (C, K)
    freq_hz: np.ndarray  # (C, K)
    phase: np.ndarray  # (C, K)

    def __call__(self, t: np.ndarray):
        w = 2.0 * math.pi * self.freq_hz  # (C, K)
        arg = t[:, None, None] * w[None] + self.phase[None]
        s, c = np.sin(arg), np.cos(arg)
        return ((self.amp * s).sum(-1), (self.amp * w * c).sum(-1), (-self.amp * w * w * s).sum(-1))


@dataclass
class CalibrationSession:
    """The drawn session: held poses, moves between them, tremor. ``kinematics(t, mount)`` gives the truth.

    Stands in for a ``PathBuilder`` in ``simulate`` (``build``, ``step_table``, ``gait_list``).
    """

    plan: CalibrationPlan
    q_pose: np.ndarray  # (P, 4) boot-frame attitude of each held pose (without tremor)
    hold_t: np.ndarray  # (P, 2) start, end of each hold, s
    move_axis_f: np.ndarray  # (P-1, 3) unit axis of each move, boot frame
    move_angle: np.ndarray  # (P-1,) rad (signed about move_axis_f; table turns carry +-2 pi)
    move_kind: np.ndarray  # (P-1,) 0 hand rotation, 1 turn on the table
    move_peak_rate: np.ndarray  # (P-1,) rad/s
    sines_ang: _Sines = field(repr=False, default=None)
    sines_pos: _Sines = field(repr=False, default=None)

    # -- PathBuilder stand-ins ------------------------------------------------------------------
    @property
    def t(self) -> float:
        return float(self.hold_t[-1, 1])

    def build(self) -> "CalibrationSession":
        return self

    @property
    def t_knots(self) -> np.ndarray:  # the duration as ``simulate`` reads it from a trajectory
        return np.array([0.0, self.t])

    def mirrored_roll(self) -> "CalibrationSession":
        return self  # a hand-held boot is not a foot: left and right boot are turned alike

    def step_table(self) -> dict[str, np.ndarray]:
        keys = ("t_start_s", "t_toe_off_s", "t_heel_strike_s", "t_end_s", "length_m", "dz_m", "heading_rad",
                "turn_rad", "chord_heading_rad", "gait", "kind")
        return {k: np.zeros(0, dtype=np.int16 if k in ("gait", "kind") else float) for k in keys}

    def gait_list(self) -> list[dict]:
        return []

    # -- kinematics -----------------------------------------------------------------------------
    def base_attitude(self, t: np.ndarray):
        """q_base (N, 4), w_base and w_base' (N, 3, boot frame) and pose index (-1 while moving)."""
        t = np.asarray(t, dtype=float)
        starts = self.hold_t[:, 0]
        k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
        pose = np.where(t <= self.hold_t[k, 1], k, -1)
        q = self.q_pose[k].copy()
        w = np.zeros((t.size, 3))
        dw = np.zeros((t.size, 3))
        mv = np.flatnonzero(pose < 0)
        if mv.size:
            km = k[mv]
            t0, t1 = self.hold_t[km, 1], self.hold_t[km + 1, 0]
            T = t1 - t0
            s, ds, dds = _septic((t[mv] - t0) / T)
            u, th = self.move_axis_f[km], self.move_angle[km]
            q[mv] = quat_multiply(self.q_pose[km], _quat_exp(u * (th * s)[:, None]))
            w[mv] = u * (th * ds / T)[:, None]
            dw[mv] = u * (th * dds / T**2)[:, None]
        return q, w, dw, pose

    def kinematics(self, t: np.ndarray, mount: Mount, g: float = STANDARD_GRAVITY) -> Kinematics:
        """Exact sensor signals at times ``t`` (module doc); ``stance`` = a pose is held."""
        t = np.asarray(t, dtype=float)
        q_b, w_b, dw_b, pose = self.base_attitude(t)
        ang, d1, d2 = self.sines_ang(t)  # columns: yaw, pitch, roll
        w_d, dw_d = euler_zyx_body_rate(ang, d1, d2)
        half = 0.5 * ang
        cy, sy, cp, sp, cr, sr = (np.cos(half[:, 0]), np.sin(half[:, 0]), np.cos(half[:, 1]), np.sin(half[:, 1]),
                                  np.cos(half[:, 2]), np.sin(half[:, 2]))
        q_d = np.stack([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr, cy * sp * cr + sy * cp * sr,
                        sy * cp * cr - cy * sp * sr], axis=-1)  # q_z(yaw) q_y(pitch) q_x(roll)
        R_d = _dcm(q_d)
        wb_d = np.einsum("nji,nj->ni", R_d, w_b)  # R_d^T w_base
        w_f = wb_d + w_d
        dw_f = np.einsum("nji,nj->ni", R_d, dw_b) - np.cross(w_d, wb_d) + dw_d
        q_nf = quat_multiply(q_b, q_d)
        R_nf = _dcm(q_nf)
        P, dP, ddP = self.sines_pos(t)
        c = np.asarray(self.plan.centroid_f_m, dtype=float)
        # foot origin o = P - R c: velocity dP - R (w x c), acceleration ddP - R (w' x c + w x (w x c))
        wxc = np.cross(w_f, c)
        p_f = P - R_nf @ c
        v_f = dP - np.einsum("nij,nj->ni", R_nf, wxc)
        a_f = ddP - np.einsum("nij,nj->ni", R_nf, np.cross(dw_f, c) + np.cross(w_f, wxc))
        return mounted_kinematics(t, p_f, v_f, a_f, R_nf, q_nf, w_f, dw_f, mount, pose >= 0, g)

    def synthesize(self, t: np.ndarray, mount: Mount) -> Kinematics:
        return self.kinematics(t, mount)

    # -- truth ----------------------------------------------------------------------------------
    def per_sample_truth(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """``pose_index`` per sample (-1 while moving)."""
        return {"pose_index": self.base_attitude(t)[3].astype(np.int16)}

    def tables(self, mount: Mount) -> dict[str, np.ndarray]:
        """Per pose and per move truth in the sensor (body) frame b of ``mount``."""
        R_fs = mount.R_fs
        q_nb = quat_multiply(self.q_pose, mount.q_fs)
        up_b = np.einsum("nji,j->ni", _dcm(q_nb), np.array([0.0, 0.0, 1.0]))
        return {
            "pose_t_start_s": self.hold_t[:, 0], "pose_t_end_s": self.hold_t[:, 1], "pose_q_nb": q_nb,
            "pose_up_b": up_b,
            "move_t_start_s": self.hold_t[:-1, 1], "move_t_end_s": self.hold_t[1:, 0],
            "move_axis_b": self.move_axis_f @ R_fs, "move_angle_rad": self.move_angle,
            "move_kind": self.move_kind.astype(np.int16), "move_peak_rate_radps": self.move_peak_rate,
        }

    def describe(self) -> dict:
        return {"calibration_plan": asdict(self.plan), "n_poses": int(len(self.q_pose)),
                "move_kind_codes": {"hand": 0, "table_turn": 1}}


TRUTH_UNITS = {
    "pose_index": "1 (-1 while moving)", "pose_t_start_s": "s", "pose_t_end_s": "s",
    "pose_q_nb": "1 (wxyz, body->nav, without tremor)", "pose_up_b": "1 (unit vector, body frame)",
    "move_t_start_s": "s", "move_t_end_s": "s", "move_axis_b": "1 (unit vector, body frame)",
    "move_angle_rad": "rad", "move_kind": "1 (0 hand, 1 table turn)", "move_peak_rate_radps": "rad/s",
}


def _sines(rng: np.random.Generator, channels: int, slow_amp: float, slow_hz, fast_amp_fn, fast_hz) -> _Sines:
    """3 slow components of amplitude ``slow_amp`` and 2 tremor components per channel, seeded phases."""
    k_slow, k_fast = 3, 2
    f_slow = rng.uniform(*slow_hz, (channels, k_slow))
    a_slow = slow_amp * rng.uniform(0.5, 1.0, (channels, k_slow))
    f_fast = rng.uniform(*fast_hz, (channels, k_fast))
    a_fast = fast_amp_fn(f_fast, rng.uniform(0.0, 1.0, (channels, k_fast)))
    phase = rng.uniform(0.0, 2 * math.pi, (channels, k_slow + k_fast))
    return _Sines(np.concatenate([a_slow, a_fast], 1), np.concatenate([f_slow, f_fast], 1), phase)


def make_session(rng: np.random.Generator, duration=None, plan: CalibrationPlan = CalibrationPlan(),
                 moves=NOMINAL_MOVES) -> CalibrationSession:
    """Draw one hand-held session (module doc). ``duration`` is ignored: the poses set the length."""
    p = plan
    yaw0 = rng.uniform(-math.pi, math.pi)
    err = lambda: _quat_exp(rng.normal(0.0, math.radians(p.pose_error_deg), 3))  # noqa: E731
    q = quat_multiply(_quat_exp([0.0, 0.0, yaw0]), err())
    up = np.array([0.0, 0.0, 1.0])  # nominal up direction in the boot frame
    poses, axes, angles, kinds, rates = [q], [], [], [], []
    for kind, axis, deg in moves:
        if kind == "turn":
            ang = math.radians(deg) + math.copysign(1.0, deg) * rng.normal(0.0, math.radians(p.table_turn_error_deg))
            u = _dcm(q).T @ np.array([0.0, 0.0, 1.0])  # the vertical in the boot frame
            q_next = quat_multiply(q, _quat_exp(u * ang))
        else:
            e = np.zeros(3)
            e[axis] = 1.0
            R_move = _dcm(_quat_exp(e * math.radians(deg)))
            up = R_move.T @ up
            target = _level(quat_multiply(q, _quat_exp(e * math.radians(deg))), up)
            q_next = quat_multiply(target, err())
            rv = _quat_log(quat_multiply(quat_conjugate(q), q_next))
            ang = float(np.linalg.norm(rv))
            u = rv / ang
        q_next = q_next / np.linalg.norm(q_next)
        axes.append(u / np.linalg.norm(u))
        angles.append(ang)
        kinds.append(1 if kind == "turn" else 0)
        rates.append(math.radians(math.exp(rng.uniform(*np.log(p.peak_rate_dps)))))
        poses.append(q_next)
        q = q_next
    n = len(poses)
    holds = rng.uniform(*p.hold_s, n)
    holds[0] = holds[-1] = p.first_last_hold_s
    durations = 35.0 / 16.0 * np.abs(angles) / np.asarray(rates)  # peak of S' is 35/16
    t, hold_t = 0.0, np.empty((n, 2))
    for i in range(n):
        hold_t[i] = t, t + holds[i]
        t += holds[i] + (durations[i] if i < n - 1 else 0.0)
    a_lo, a_hi = p.tremor_acc_mps2

    def tremor_amp(f, r):  # displacement amplitude of an acceleration amplitude drawn in [a_lo, a_hi]
        return (a_lo + r * (a_hi - a_lo)) / (2 * math.pi * f) ** 2

    sines_pos = _sines(rng, 3, p.drift_pos_m, p.drift_hz, tremor_amp, p.tremor_hz)
    sines_ang = _sines(rng, 3, math.radians(p.drift_angle_deg), p.drift_hz,
                       lambda f, r: tremor_amp(f, r) / p.tremor_lever_m, p.tremor_hz)
    return CalibrationSession(p, np.array(poses), hold_t, np.array(axes), np.array(angles), np.array(kinds),
                              np.array(rates), sines_ang, sines_pos)
