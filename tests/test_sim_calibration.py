"""The hand-held calibration scenario (simulator/calibration.py): physics of the truth, and the recording.

Tolerances come from the drawn tremor amplitudes (a bound on the acceleration they can add) or from the
integrator's truncation error, never from the output.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bootnav.core.rotations import quat_multiply
from bootnav.logger.mpu6050 import STANDARD_GRAVITY
from bootnav.simulator import simulate
from bootnav.simulator.calibration import make_session
from bootnav.simulator.imu_synth import MOUNTS

MOUNT = MOUNTS["right_boot_tilted"]  # sensor axes differ from the boot axes: the frames must be kept apart


@pytest.fixture(scope="module")
def session():
    return make_session(np.random.default_rng(11))


@pytest.fixture(scope="module")
def result():
    return simulate("calibration", seed=4, rate_hz=100.0, device=77)  # the interface calibrate relies on


def _dcm(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_at_rest_the_specific_force_is_gravity_within_the_tremor(session):
    """|f| = g while a pose is held, within the largest acceleration the hand's sinusoids can add."""
    t = np.arange(0.0, session.t, 0.002)
    kin = session.kinematics(t, MOUNT)
    held = kin.stance
    assert held.mean() > 0.5
    sp, sa = session.sines_pos, session.sines_ang
    w = 2 * np.pi
    acc_lin = np.linalg.norm((sp.amp * (w * sp.freq_hz) ** 2).sum(1))  # |P''| bound
    rate = math.sqrt(3) * (sa.amp * w * sa.freq_hz).sum(1).max()  # |omega_d| bound (small angles)
    dw = math.sqrt(3) * (sa.amp * (w * sa.freq_hz) ** 2).sum(1).max() * 1.01 + rate**2  # |omega_d'| bound
    r = np.linalg.norm(np.asarray(MOUNT.lever_arm_m) - np.asarray(session.plan.centroid_f_m))
    bound = acc_lin + r * (dw + rate**2)
    dev = np.abs(np.linalg.norm(kin.f_b[held], axis=1) - STANDARD_GRAVITY)
    assert dev.max() <= bound
    assert bound < 0.5  # a hand on a table, not a walk: the bound itself is physically small
    # and a move is a move: somewhere between poses the rate exceeds 50 deg/s
    assert np.degrees(np.linalg.norm(kin.omega_b[~held], axis=1)).max() > 50.0


def _rk4_attitude(session, q0, t0, t1, h=0.002):
    """Integrate q' = q (x) [0, omega_b] / 2 with RK4 from q0 (the exact gyro of the truth)."""
    n = max(2, int(math.ceil((t1 - t0) / h)))
    h = (t1 - t0) / n
    nodes = t0 + h * np.arange(2 * n + 1) / 2.0
    w = session.kinematics(nodes, MOUNT).omega_b
    wq = np.concatenate([np.zeros((w.shape[0], 1)), w], axis=1)
    q = q0.copy()
    f = lambda q, i: 0.5 * quat_multiply(q, wq[i])  # noqa: E731
    for i in range(n):
        k1 = f(q, 2 * i)
        k2 = f(q + 0.5 * h * k1, 2 * i + 1)
        k3 = f(q + 0.5 * h * k2, 2 * i + 1)
        k4 = f(q + h * k3, 2 * i + 2)
        q = q + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return q / np.linalg.norm(q)


def test_integrated_gyro_carries_gravity_from_pose_to_pose(session):
    """Tedaldi's principle on the exact signals: the rate integral maps one pose's gravity to the next."""
    ends, starts = session.hold_t[:-1, 1], session.hold_t[1:, 0]
    kin_a = session.kinematics(ends, MOUNT)
    kin_b = session.kinematics(starts, MOUNT)
    worst = 0.0
    for i in range(len(ends)):
        q = _rk4_attitude(session, kin_a.q_nb[i], ends[i], starts[i])
        g_pred = _dcm(q).T @ [0.0, 0.0, 1.0]
        g_true = kin_b.f_b[i] / np.linalg.norm(kin_b.f_b[i])  # at rest-with-tremor: up in the body
        g_att = _dcm(kin_b.q_nb[i]).T @ [0.0, 0.0, 1.0]
        worst = max(worst, float(np.linalg.norm(g_pred - g_att)))
        assert np.degrees(np.arccos(np.clip(g_true @ g_att, -1, 1))) < 1.0  # f at a pose ~ gravity
    assert worst < 1e-6


def test_poses_and_rotation_axes(session):
    up = session.tables(MOUNT)["pose_up_b"]
    # distinct gravity directions: more than 20 deg apart
    distinct = []
    for u in up:
        if all(np.degrees(np.arccos(np.clip(u @ d, -1, 1))) > 20.0 for d in distinct):
            distinct.append(u)
    assert len(distinct) >= 12
    holds = np.diff(session.hold_t, axis=1)[:, 0]
    assert np.all((holds >= 2.0 - 1e-12) & (holds <= 5.0 + 1e-12))
    # poses are not exactly axis-aligned (imperfect on purpose): no face is level to 0.1 deg
    up_f = np.array([_dcm(q).T @ [0.0, 0.0, 1.0] for q in session.q_pose])
    assert np.degrees(np.arccos(np.clip(np.abs(up_f).max(axis=1), -1, 1))).mean() > 1.0  # sigma 3 deg/axis
    axes_f = session.move_axis_f
    for k in range(3):  # rotations about every boot axis
        assert np.any(np.abs(axes_f[:, k]) > 0.95), k
    turns = session.move_kind == 1
    assert turns.sum() >= 2 and np.all(np.abs(session.move_angle[turns]) > math.radians(300))
    peak = np.degrees(session.move_peak_rate)
    assert np.all((peak >= 50.0 - 1e-9) & (peak <= 300.0 + 1e-9))


def test_simulated_recording_has_the_calibration_truth(result):
    tr = result.truth
    n = result.n
    assert tr["pose_index"].shape == (n,)
    held = tr["pose_index"] >= 0
    assert np.array_equal(held, tr["stance"].astype(bool))
    assert tr["pose_q_nb"].shape == (len(tr["pose_t_start_s"]), 4) and len(tr["pose_t_start_s"]) >= 12
    assert 90.0 <= tr["t_s"][-1] <= 180.0  # 1.5-3 min
    # the delivered static accelerometer reads gravity within the datasheet's errors (3 sigma of scale,
    # cross-axis and zero-g offset: a few percent of g), i.e. the signal went through the sensor model
    acc = result.acc_mps2[held]
    assert np.all(np.abs(np.linalg.norm(acc, axis=1) - STANDARD_GRAVITY) < 0.1 * STANDARD_GRAVITY)
    assert not np.array_equal(result.acc_mps2, tr["f_b_mps2"])
    assert result.attrs["device_id"] == 77 and tr["acc_sensitivity_matrix"].shape == (3, 3)
