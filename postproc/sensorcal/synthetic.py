"""Exact synthetic calibration sessions (tests, and the benchmark's check of the fit itself).

Not a sensor simulator (that is ``bootnav.simulator``, with the MPU6050's filter, quantisation and clock):
a sequence of poses held by a trembling hand and single-axis rotations between them, whose body rates and
orientations are exact in closed form, read through y = S x + b + k (T − T_ref) + white noise. So a fit can
be checked against known C = S⁻¹, b, k to its own 1σ, free of every other error.

Motion between poses i and i+1: R(t) = R_i Exp(s(t) φ_i), s = (1 − cos(π t/T))/2, so ω_b = ṡ φ_i exactly.
Tremor during a hold: R(t) = R_i Exp(τ(t) e_i), τ = a sin(2π f t) sin²(π t/T_h), ω_b = τ̇ e_i exactly
(zero at both ends of the hold, so poses join without a jump).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from bootnav.core.conventions import STANDARD_GRAVITY_MPS2

from .fit import Session

G_STD = STANDARD_GRAVITY_MPS2
D = math.pi / 2
# (body-frame rotation vector of the motion into the next pose); starts sole down (z up)
STANDARD_MOTIONS = [
    (D, 0, 0), (D, 0, 0), (D, 0, 0), (D, 0, 0),  # roll through both sides and upside down, back to sole
    (0, D, 0), (0, D, 0), (0, D, 0), (0, D, 0),  # pitch: toe, upside down, heel, back
    (D, 0, 0), (0, 0, D), (0, 0, D), (0, 0, -2 * D), (-D, 0, 0),  # on its side: turn about z (horizontal)
    (0, 0, 2 * math.pi), (0, 0, -2 * math.pi),  # two full turns flat on the table
    (0.9, 0.9, 0.0), (0.0, -0.8, 0.8), (-0.6, 0.0, -0.9), (0.5, 0.7, 0.3),  # oblique poses
]
# a person following the guided live mode's PROCEDURE (x toe-ward, y left, z up; one motion per instruction)
PROCEDURE_MOTIONS = [(D / 2, 0, 0), (D / 2, 0, 0), (D, 0, 0), (D, 0, 0), (D, 0, 0),  # roll through the sides
                     (0, -D, 0), (0, D, 0), (0, D, 0), (0, -D / 2, 0), (0, -D / 2, 0),  # heel, toe, 45° toe down
                     (0, 0, 2 * math.pi),  # a full turn on the table
                     (D, 0, 0), (0, 0, D), (0, 0, -D / 2), (0, 0, -1.5 * D), (0, 0, D),  # on its side, about z
                     (-D, 0, 0), (-D / 2, 0, 0), (D / 2, 0, 0)]  # flat, 45° on the right side, flat

# every face reached by turns about y and z only (z is horizontal after the first pitch): no rotation about x
NO_X_MOTIONS = [(0, D, 0), (0, 0, D), (0, 0, D), (0, 0, D), (0, 0, D), (0, D, 0), (0, D, 0), (0, D, 0),
                (0, 0, 2 * math.pi), (0, 0.6, 0), (0, 0, 0.7), (0, -0.6, 0), (0, 0, -0.7), (0, -D, 0),
                (0, 0, 0.8), (0, 0, -0.8), (0, D, 0)]


@dataclass
class SynthTruth:
    s_acc: np.ndarray
    b_acc: np.ndarray
    k_acc: np.ndarray
    s_gyro: np.ndarray
    b_gyro: np.ndarray
    k_gyro: np.ndarray
    temp_ref_degc: float

    @property
    def c_acc(self):
        return np.linalg.inv(self.s_acc)

    @property
    def c_gyro(self):
        return np.linalg.inv(self.s_gyro)


def draw_truth(seed: int, temp_ref_degc: float = 25.0, with_temp: bool = True) -> SynthTruth:
    """Datasheet-sized errors (scale σ 1 %, cross-axis σ 0.67 %, ZRO σ 6.7 °/s, zero-g σ 17/27 mg); the
    accelerometer's S upper triangular (the body frame is its own, as the fit's convention)."""
    rng = np.random.default_rng(seed)
    s_acc = np.eye(3) + np.diag(rng.normal(0, 0.01, 3)) + np.triu(rng.normal(0, 0.0067, (3, 3)), 1)
    s_gyro = np.eye(3) + np.diag(rng.normal(0, 0.01, 3)) + (1 - np.eye(3)) * rng.normal(0, 0.0067, (3, 3))
    b_acc = rng.normal(0, 1, 3) * np.array([50, 50, 80]) / 3 * 1e-3 * G_STD
    b_gyro = rng.normal(0, math.radians(20 / 3), 3)
    k_acc = rng.normal(0, 0.35e-3 * G_STD, 3) if with_temp else np.zeros(3)  # datasheet ±0.35 mg/°C
    k_gyro = rng.normal(0, math.radians(0.05), 3) if with_temp else np.zeros(3)
    return SynthTruth(s_acc, b_acc, k_acc, s_gyro, b_gyro, k_gyro, temp_ref_degc)


def make_session(truth: SynthTruth, seed: int, motions=None, *, rate_hz: float = 100.0, hold_s: float = 3.0,
                 rate_radps: float = 1.2, tremor_rad: float = 3e-4, temp_start_degc: float = 25.0,
                 temp_rise_degc: float = 3.0, turn_return_sigma_rad: float = math.radians(0.5),
                 acc_noise: float = 0.026, gyro_noise: float = 5.7e-4, gravity: float = G_STD,
                 name: str = "synthetic.h5", device_id: str | None = "0x0000CA11") -> Session:
    """One session (see module docstring); returns a ``fit.Session`` with ``truth`` = ``{"orientation"...}``."""
    rng = np.random.default_rng(seed)
    motions = STANDARD_MOTIONS if motions is None else motions
    dt = 1.0 / rate_hz
    rot = Rotation.identity()
    rots, rates = [], []

    def hold():
        n = int(round(hold_s * rate_hz * rng.uniform(0.8, 1.2)))
        t = np.arange(n) * dt
        e = rng.normal(size=3)
        e /= np.linalg.norm(e)
        f, T, ph = rng.uniform(8, 12), n * dt, rng.uniform(0, 2 * math.pi)
        w = np.sin(math.pi * t / T) ** 2
        tau = tremor_rad * np.sin(2 * math.pi * f * t + ph) * w
        dtau = tremor_rad * (2 * math.pi * f * np.cos(2 * math.pi * f * t + ph) * w
                             + np.sin(2 * math.pi * f * t + ph) * math.pi / T * np.sin(2 * math.pi * t / T))
        tau -= tremor_rad * math.sin(ph) * w * 0  # tau(0) = tau(T) = 0 through the window
        rots.append(rot * Rotation.from_rotvec(tau[:, None] * e))
        rates.append(dtau[:, None] * e)

    for phi in motions:
        hold()
        phi = np.asarray(phi, dtype=np.float64)
        ang = float(np.linalg.norm(phi))
        if abs(ang - 2 * math.pi) < 1e-9:  # a full turn: put back by hand, imperfectly
            phi = phi * (1 + rng.normal(0, turn_return_sigma_rad) / ang)
            ang = float(np.linalg.norm(phi))
        T = ang / rate_radps * 2 / math.pi * math.pi / 2 + 0.4
        n = int(math.ceil(T * rate_hz))
        T = n * dt
        t = np.arange(n) * dt
        s = (1 - np.cos(math.pi * t / T)) / 2
        ds = math.pi / (2 * T) * np.sin(math.pi * t / T)
        rots.append(rot * Rotation.from_rotvec(s[:, None] * phi))
        rates.append(ds[:, None] * phi)
        rot = rot * Rotation.from_rotvec(phi)
    hold()
    r_all = Rotation.concatenate(rots)
    w_b = np.vstack(rates)
    n = w_b.shape[0]
    t = np.arange(n) * dt
    f_b = r_all.inv().apply(np.array([0.0, 0.0, gravity]))
    temp = temp_start_degc + temp_rise_degc * (1 - np.exp(-t / 300.0))
    dT = (temp - truth.temp_ref_degc)[:, None]
    acc = f_b @ truth.s_acc.T + truth.b_acc + dT * truth.k_acc + rng.normal(0, acc_noise, (n, 3))
    gyro = w_b @ truth.s_gyro.T + truth.b_gyro + dT * truth.k_gyro + rng.normal(0, gyro_noise, (n, 3))
    info = {"file": name, "duration_s": float(t[-1]), "temp_range_degc": [float(temp.min()), float(temp.max())]}
    return Session(name=name, t_s=t, acc=acc, gyro=gyro, temp_degc=temp, saturated=None, device_id=device_id,
                   info=info, truth={"orientation": r_all, "rate_b": w_b})


def write_session(ses: Session, path, *, counts: bool = True) -> None:
    """Write a synthetic session as a recording (int16 counts at ±16 g / ±2000 °/s like the boot, or SI).

    Crash-safe through ``RecordingWriter``'s own temporary-then-rename; refuses an existing file.
    """
    from pathlib import Path

    from bootnav.logger import mpu6050
    from bootnav.logger.recording import counts_channel, si_channel, write_recording

    path = Path(path)
    if path.exists():
        raise FileExistsError(path)
    rate = 1.0 / float(np.median(np.diff(ses.t_s)))
    meta = {"device": "MPU6050 (synthetic calibration session)", "device_id": ses.device_id or "",
            "rate_nominal_hz": rate, "accel_range_g": 16, "gyro_range_dps": 2000, "mount": "hand-held"}
    temp_c = (ses.temp_degc - mpu6050.TEMP_OFFSET_DEGC) * mpu6050.TEMP_LSB_PER_DEGC
    if counts:
        sa, sg = mpu6050.accel_scale_mps2(3), mpu6050.gyro_scale_radps(3)
        acc = np.clip(np.rint(ses.acc / sa), -32768, 32767).astype(np.int16)
        gyro = np.clip(np.rint(ses.gyro / sg), -32768, 32767).astype(np.int16)
        write_recording(path, ses.t_s, acc, gyro, acc_channel=counts_channel("acc", sa),
                        gyro_channel=counts_channel("gyro", sg), meta=meta,
                        temp=np.rint(temp_c).astype(np.int16),
                        temp_channel=counts_channel("temp", 1.0 / mpu6050.TEMP_LSB_PER_DEGC))
    else:
        write_recording(path, ses.t_s, ses.acc, ses.gyro, meta=meta, temp=ses.temp_degc,
                        temp_channel=si_channel("temp"))
