"""simulate(): scenario -> exact kinematics -> MPU6050 error model -> SimResult (recording + truth).

The exact signals are evaluated at the internal rate f_i = m * rate_hz (m chosen so f_i is closest to
the profile's 1 kHz; ``ideal``: m = 1), passed through the error model in blocks (the DLPF and the bias
random walk carry their state across blocks, so the result does not depend on the block size) and
decimated to the output rate. One ``numpy.random.Generator(seed)`` makes every random draw, in this
order: scenario choices, turn-on constants, per-block noise and bias walks, timestamps, drops.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from bootnav.core.runs import runs
from bootnav.logger.recording import SATURATION_BITS, make_events
from bootnav.simulator.gait import GAIT_CODES
from bootnav.simulator.imu_model import ErrorModel, SensorProfile, drop_mask, get_profile, quantize, timestamps
from bootnav.simulator.imu_synth import MOUNTS, Mount, describe_mount, synthesize
from bootnav.simulator.scenarios import Scenario, get_scenario
from bootnav.simulator.trajectory import Trajectory

BLOCK_OUT = 1 << 14  # output samples per block (bounded memory for hour-long runs)


@dataclass
class SimResult:
    """A simulated recording: what the sensor delivered plus the exact truth, row-aligned."""

    scenario: str
    seed: int
    profile: SensorProfile
    mount: Mount
    rate_hz: float
    decimation: int
    t_s: np.ndarray  # recorded time since the first sample (device clock), s
    acc: np.ndarray  # (N,3) int16 counts, or float m/s^2 for the ideal profile
    gyro: np.ndarray  # (N,3) int16 counts, or float rad/s
    saturated: np.ndarray  # (N,) uint8 bitmask (bootnav.logger.recording.SATURATION_BITS)
    t_device: np.ndarray | None  # (N,) uint32 us (wraps)
    seq: np.ndarray | None  # (N,) uint16
    temp: np.ndarray | None  # (N,) int16 counts
    events: np.ndarray
    truth: dict  # arrays, row-aligned with the samples (see docs/simulator.md)
    steps: dict  # per-stride table
    attrs: dict = field(default_factory=dict)  # scenario, seed, profile, mount, drawn constants (JSON-able)
    trajectory: Trajectory | None = None

    @property
    def n(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def counts(self) -> bool:
        return not self.profile.ideal

    @property
    def acc_mps2(self) -> np.ndarray:
        return self.acc * self.profile.accel_lsb_mps2 if self.counts else self.acc

    @property
    def gyro_radps(self) -> np.ndarray:
        return self.gyro * self.profile.gyro_lsb_radps if self.counts else self.gyro

    def saturation_counts(self) -> dict[str, int]:
        return {name: int(np.count_nonzero(self.saturated & (1 << bit))) for name, bit in SATURATION_BITS.items()}


def simulate(scenario: str | Scenario, seed: int = 0, profile: str | SensorProfile = "mpu6050-16g-2000dps",
             rate_hz: float = 200.0, duration_s: float | None = None, mount: str | Mount = "right_boot",
             progress=None) -> SimResult:
    """Simulate ``scenario`` and return the recording with its exact truth.

    ``progress(done_fraction)`` is called after each block (long runs).
    """
    if not (rate_hz > 0 and math.isfinite(rate_hz)):
        raise ValueError(f"rate must be a positive number of Hz, got {rate_hz}")
    sc = get_scenario(scenario)
    prof = get_profile(profile)
    mnt = MOUNTS[mount] if isinstance(mount, str) else mount
    rng = np.random.default_rng(seed)
    builder = sc.make(rng, duration_s)
    traj = builder.build()
    if mnt.foot == "left":
        traj = traj.mirrored_roll()
    m = 1 if prof.ideal else max(1, int(round(prof.internal_rate_hz / rate_hz)))
    f_int = rate_hz * m
    n_out = int(math.floor(traj.t_knots[-1] * rate_hz + 1e-9)) + 1
    model = None if prof.ideal else ErrorModel(prof, f_int, rng)

    names = ("pos_n_m", "vel_n_mps", "q_nb", "f_b_mps2", "omega_b_radps", "foot_pos_n_m")
    widths = (3, 3, 4, 3, 3, 3)
    truth = {k: np.empty((n_out, w)) for k, w in zip(names, widths)}
    truth["stance"] = np.empty(n_out, dtype=np.uint8)
    acc_si = np.empty((n_out, 3))
    gyro_si = np.empty((n_out, 3))
    bias_a = np.zeros((n_out, 3))
    bias_g = np.zeros((n_out, 3))
    for j0 in range(0, n_out, BLOCK_OUT):
        j1 = min(n_out, j0 + BLOCK_OUT)
        i_end = (j1 - 1) * m + 1 if j1 == n_out else j1 * m
        t_int = np.arange(j0 * m, i_end) / f_int
        kin = synthesize(traj, t_int, mnt)
        sl = slice(None, None, m)
        for key, arr in zip(names, (kin.pos_n, kin.vel_n, kin.q_nb, kin.f_b, kin.omega_b, kin.foot_pos_n)):
            truth[key][j0:j1] = arr[sl]
        truth["stance"][j0:j1] = kin.stance[sl]
        if model is None:
            acc_si[j0:j1], gyro_si[j0:j1] = kin.f_b, kin.omega_b
        else:
            a, g, ba, bg = model.process(kin.f_b, kin.omega_b)
            acc_si[j0:j1], gyro_si[j0:j1], bias_a[j0:j1], bias_g[j0:j1] = a[sl], g[sl], ba[sl], bg[sl]
        if progress:
            progress(j1 / n_out)
    # truth position of the sensor starts at the origin (the foot origin already does)
    truth["pos_n_m"] -= truth["pos_n_m"][0].copy()
    truth["acc_bias_b_mps2"] = bias_a
    truth["gyro_bias_b_radps"] = bias_g

    t_true, t_us = timestamps(n_out, rate_hz, prof, rng)
    keep = drop_mask(n_out, rate_hz, prof, rng)
    idx = np.flatnonzero(keep)
    events = []
    if prof.ideal:
        acc, gyro = acc_si, gyro_si
        saturated = np.zeros(n_out, dtype=np.uint8)
    else:
        acc, sat_a = quantize(acc_si, prof.accel_lsb_mps2)
        gyro, sat_g = quantize(gyro_si, prof.gyro_lsb_radps)
        saturated = np.zeros(n_out, dtype=np.uint8)
        for ax in range(3):
            saturated |= (sat_a[:, ax].astype(np.uint8) << ax) | (sat_g[:, ax].astype(np.uint8) << (ax + 3))
    saturated = saturated[idx]
    # events in terms of the delivered samples
    kept_t = (t_us[idx] - t_us[idx[0]]) / 1e6
    gap_at = np.flatnonzero(np.diff(idx) > 1) + 1
    for i in gap_at:
        events.append(dict(t_s=kept_t[i], sample_index=int(i), kind="gap", count=int(idx[i] - idx[i - 1] - 1),
                           detail="simulated dropped samples (SD write stall)"))
    for axis in range(6):
        starts, stops = runs((saturated >> axis) & 1)
        for s, L in zip(starts, stops - starts):
            events.append(dict(t_s=kept_t[s], sample_index=int(s), kind="saturation", count=int(L), axis=axis,
                               detail="at full scale"))
    events.sort(key=lambda e: e["sample_index"])

    truth = {k: v[idx] for k, v in truth.items()}
    truth["t_s"] = t_true[idx]
    truth["sample_index"] = idx  # index in the nominal (drop-free) sample stream
    steps = builder.step_table()
    temp = None
    t_device = seq = None
    if not prof.ideal:
        warm = prof.temp_degc + 3.0 * (1 - np.exp(-t_true[idx] / 300.0))  # die warm-up after power-on
        temp = np.rint((warm - 36.53) * 340.0).astype(np.int16)
        t_device = (t_us[idx] % (1 << 32)).astype(np.uint32)
        seq = (idx % (1 << 16)).astype(np.uint16)
    attrs = {
        "scenario": sc.name,
        "scenario_description": sc.description,
        "seed": int(seed),
        "rate_hz": float(rate_hz),
        "internal_rate_hz": float(f_int),
        "decimation": m,
        "duration_s": float(traj.t_knots[-1]),
        "n_nominal_samples": n_out,
        "n_dropped": int(n_out - idx.size),
        "sensor_profile": json.dumps(prof.to_dict()),
        "drawn_constants": json.dumps(model.constants() if model else {}),
        "step_kind_codes": json.dumps(GAIT_CODES),
        "gait_parameters": json.dumps(builder.gait_list()),
        **describe_mount(mnt),
    }
    return SimResult(sc.name, int(seed), prof, mnt, float(rate_hz), m, kept_t, acc[idx], gyro[idx], saturated,
                     t_device, seq, temp, make_events(events), truth, steps, attrs, traj)

