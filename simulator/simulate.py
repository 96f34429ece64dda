"""simulate(): scenario -> exact kinematics -> MPU6050 error model -> SimResult (recording + truth).

The exact signals are evaluated at the internal rate f_i = m * rate_hz (m chosen so f_i is closest to
the profile's 1 kHz; ``ideal``: m = 1), passed through the error model in blocks (the DLPF and the bias
random walk carry their state across blocks, so the result does not depend on the block size) and
decimated to the output rate. One ``numpy.random.Generator(seed)`` makes every random draw, in this
order: scenario choices, turn-on constants, per-block noise and bias walks, timestamps, drops. With a
``device`` the unit's stable constants come from its own generator (``device.draw_unit``) and the seed's
generator draws, in the same order, this power-on's bias repeatability instead of the turn-on constants,
and no clock error.

``LongSimulation`` generates recordings of any length (a whole shift) block by block without keeping them:
``writers.write_long_h5`` appends each block to the HDF5 file as it comes.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from bootnav.core.runs import runs
from bootnav.logger.mpu6050 import INT16_MAX, INT16_MIN, TEMP_LSB_PER_DEGC, TEMP_OFFSET_DEGC
from bootnav.logger.recording import SATURATION_BITS, make_events
from bootnav.simulator.device import DeviceModel, DeviceUnit, TemperatureProfile, draw_unit
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


def temp_counts(temp_degc: np.ndarray) -> np.ndarray:
    """TEMP_OUT register counts of a die temperature (T = raw / 340 + 36.53 C), clipped to int16."""
    return np.clip(np.rint((temp_degc - TEMP_OFFSET_DEGC) * TEMP_LSB_PER_DEGC), INT16_MIN, INT16_MAX).astype(np.int16)


def _kinematics(traj, t: np.ndarray, mount: Mount):
    """Exact signals of a foot ``Trajectory``, or of a motion that synthesises itself (calibration session)."""
    own = getattr(traj, "synthesize", None)
    return own(t, mount) if own is not None else synthesize(traj, t, mount)


def device_setup(prof: SensorProfile, device=None, device_model: DeviceModel | None = None,
                 temperature: TemperatureProfile | None = None):
    """(unit or None, temperature profile) for a simulation; checks that the options fit together."""
    if device is None:
        if temperature is not None or device_model is not None:
            raise ValueError("a temperature profile or device model needs a device (--device D): the temperature "
                             "coefficients belong to one unit")
        return None, TemperatureProfile(ambient_degc=prof.temp_degc)
    if prof.ideal:
        raise ValueError(f"profile {prof.name!r} has no sensor errors; a device needs an mpu6050-* profile")
    return draw_unit(device, prof, device_model or DeviceModel()), temperature or TemperatureProfile(
        ambient_degc=prof.temp_degc)


def device_truth(unit: DeviceUnit, model: ErrorModel) -> dict[str, np.ndarray]:
    """The constants this recording got, SI, sensor body frame (docs/simulator.md, "Device truth")."""
    return {
        "acc_sensitivity_matrix": np.array(unit.M_a), "gyro_sensitivity_matrix": np.array(unit.M_g),
        "acc_bias_turn_on_b_mps2": model.b0_a.copy(), "gyro_bias_turn_on_b_radps": model.b0_g.copy(),
        "acc_bias_device_mean_b_mps2": np.array(unit.acc_bias_mean_mps2),
        "gyro_bias_device_mean_b_radps": np.array(unit.gyro_bias_mean_radps),
        "acc_bias_tempco_b_mps2_per_degc": np.array(unit.acc_bias_tempco_mps2_per_degc),
        "gyro_bias_tempco_b_radps_per_degc": np.array(unit.gyro_bias_tempco_radps_per_degc),
        "acc_scale_tempco_per_degc": np.array(unit.acc_scale_tempco_per_degc),
        "gyro_scale_tempco_per_degc": np.array(unit.gyro_scale_tempco_per_degc),
        "clock_error": np.float64(unit.clock_error), "temp_reference_degc": np.float64(unit.t_reference_degc),
    }


def _sample(traj, mnt: Mount, model, tprof, n_out: int, m: int, f_int: float, progress):
    """The trajectory's kinematics at the internal rate ``f_int``, through the error model (``model`` None: exact)
    at the chip temperature of ``tprof`` (None: none), kept every ``m``-th sample, block by block.

    Returns (truth arrays, specific force, angular rate, accelerometer bias, gyro bias), ``n_out`` rows each.
    """
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
        kin = _kinematics(traj, t_int, mnt)
        sl = slice(None, None, m)
        for key, arr in zip(names, (kin.pos_n, kin.vel_n, kin.q_nb, kin.f_b, kin.omega_b, kin.foot_pos_n)):
            truth[key][j0:j1] = arr[sl]
        truth["stance"][j0:j1] = kin.stance[sl]
        if model is None:
            acc_si[j0:j1], gyro_si[j0:j1] = kin.f_b, kin.omega_b
        else:
            a, g, ba, bg = model.process(kin.f_b, kin.omega_b, None if tprof is None else tprof.chip(t_int))
            acc_si[j0:j1], gyro_si[j0:j1], bias_a[j0:j1], bias_g[j0:j1] = a[sl], g[sl], ba[sl], bg[sl]
        if progress:
            progress(j1 / n_out)
    return truth, acc_si, gyro_si, bias_a, bias_g


def _quantized(acc_si: np.ndarray, gyro_si: np.ndarray, prof: SensorProfile):
    """(acc, gyro, saturation bitmask): int16 counts clipped at full scale, bit ``axis`` (acc) and ``axis + 3``
    (gyro) set where clipped; the SI floats themselves for the ideal profile."""
    saturated = np.zeros(len(acc_si), dtype=np.uint8)
    if prof.ideal:
        return acc_si, gyro_si, saturated
    acc, sat_a = quantize(acc_si, prof.accel_lsb_mps2)
    gyro, sat_g = quantize(gyro_si, prof.gyro_lsb_radps)
    for ax in range(3):
        saturated |= (sat_a[:, ax].astype(np.uint8) << ax) | (sat_g[:, ax].astype(np.uint8) << (ax + 3))
    return acc, gyro, saturated


def _delivered_events(idx: np.ndarray, kept_t: np.ndarray, saturated: np.ndarray) -> list[dict]:
    """Events in terms of the delivered samples ``idx`` (their times ``kept_t``): a gap where samples were
    dropped, a saturation run per axis; in sample order."""
    events = []
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
    return events


#: ``simulate``'s defaults, their one home (``simulate_two_boots`` and ``bootnav simulate``'s flags read them)
DEFAULT_SEED = 0
DEFAULT_PROFILE = "mpu6050-16g-2000dps"
DEFAULT_RATE_HZ = 200.0


def simulate(scenario: str | Scenario, seed: int = DEFAULT_SEED, profile: str | SensorProfile = DEFAULT_PROFILE,
             rate_hz: float = DEFAULT_RATE_HZ, duration_s: float | None = None, mount: str | Mount = "right_boot",
             progress=None, device: int | str | None = None, device_model: DeviceModel | None = None,
             temperature: TemperatureProfile | None = None) -> SimResult:
    """Simulate ``scenario`` and return the recording with its exact truth.

    ``progress(done_fraction)`` is called after each block (long runs). ``device`` (0..2^32-1, int or
    decimal / 0x-hex string): one unit's stable constants drawn from the id alone, ``seed`` draws this
    power-on and walk (``simulator/device.py``); ``temperature`` (a ``TemperatureProfile``, needs a device):
    the chip's ambient and warm-up. Without ``device`` the recording is what it always was.
    """
    if not (rate_hz > 0 and math.isfinite(rate_hz)):
        raise ValueError(f"rate must be a positive number of Hz, got {rate_hz}")
    sc = get_scenario(scenario)
    prof = get_profile(profile)
    unit, tprof = device_setup(prof, device, device_model, temperature)
    mnt = MOUNTS[mount] if isinstance(mount, str) else mount
    rng = np.random.default_rng(seed)
    builder = sc.make(rng, duration_s)
    traj = builder.build()
    if mnt.foot == "left":
        traj = traj.mirrored_roll()
    m = 1 if prof.ideal else max(1, int(round(prof.internal_rate_hz / rate_hz)))
    f_int = rate_hz * m
    n_out = int(math.floor(traj.t_knots[-1] * rate_hz + 1e-9)) + 1
    model = None if prof.ideal else ErrorModel(prof, f_int, rng, unit)

    truth, acc_si, gyro_si, bias_a, bias_g = _sample(traj, mnt, model, None if unit is None else tprof, n_out, m,
                                                     f_int, progress)
    # truth position of the sensor starts at the origin (the foot origin already does)
    truth["pos_n_m"] -= truth["pos_n_m"][0].copy()
    truth["acc_bias_b_mps2"] = bias_a
    truth["gyro_bias_b_radps"] = bias_g

    t_true, t_us = timestamps(n_out, rate_hz, prof, rng, None if unit is None else unit.clock_error)
    keep = drop_mask(n_out, rate_hz, prof, rng)
    idx = np.flatnonzero(keep)
    acc, gyro, saturated = _quantized(acc_si, gyro_si, prof)
    saturated = saturated[idx]
    kept_t = (t_us[idx] - t_us[idx[0]]) / 1e6
    events = _delivered_events(idx, kept_t, saturated)

    if hasattr(builder, "per_sample_truth"):  # a motion with its own truth (calibration session)
        truth.update(builder.per_sample_truth(np.arange(n_out) * m / f_int))
    truth = {k: v[idx] for k, v in truth.items()}
    if hasattr(builder, "tables"):
        truth.update(builder.tables(mnt))
    truth["t_s"] = t_true[idx]
    truth["sample_index"] = idx  # index in the nominal (drop-free) sample stream
    steps = builder.step_table()
    temp = None
    t_device = seq = None
    if unit is not None:
        truth["temp_degc"] = tprof.chip(t_true[idx])
        truth["ambient_degc"] = tprof.ambient(t_true[idx])
        truth.update(device_truth(unit, model))
    if not prof.ideal:
        warm = tprof.chip(t_true[idx])  # die warm-up after power-on (device.TemperatureProfile)
        temp = temp_counts(warm)
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
        **(builder.describe() if hasattr(builder, "describe") else {}),
    }
    if unit is not None:
        attrs.update(device_id=unit.device_id, device_model=json.dumps((device_model or DeviceModel()).to_dict()),
                     temperature_profile=json.dumps(tprof.to_dict()))
    return SimResult(sc.name, int(seed), prof, mnt, float(rate_hz), m, kept_t, acc[idx], gyro[idx], saturated,
                     t_device, seq, temp, make_events(events), truth, steps, attrs, traj)



def shift_segment(pb, rng: np.random.Generator) -> None:
    """One piece of a long shift: a lap of a 20 m x 10 m loop with an 8-riser flight up and down, then a pause.

    The lap starts and ends with the foot at rest near the origin; the pause is 2-30 s, one time in five a
    long wait of 1-5 min (standing by at a door), so long recordings have the still phases of real shifts.
    """
    pb.walk_to(20.0, 0.0).walk_to(20.0, 10.0).stairs(8, 0.17, 0.28, up=True).turn_in_place(math.pi)
    pb.stairs(8, 0.17, 0.28, up=False).walk_to(0.0, 10.0).walk_to(0.0, 0.0)
    pb.stand(float(rng.uniform(60.0, 300.0)) if rng.random() < 0.2 else float(rng.uniform(2.0, 30.0)))


@dataclass
class SimBlock:
    """One block of a long simulated recording, as ``RecordingWriter.append`` takes it (delivered samples)."""

    t_s: np.ndarray  # (n,) recorded time since the first sample, s
    acc: np.ndarray  # (n, 3) int16 counts, or m/s^2 for the ideal profile
    gyro: np.ndarray  # (n, 3) int16 counts, or rad/s
    saturated: np.ndarray  # (n,) uint8 bitmask
    t_device: np.ndarray | None
    seq: np.ndarray | None
    temp: np.ndarray | None
    events: list  # dicts with sample_index in the whole recording


class LongSimulation:
    """A recording of any length generated block by block, memory bounded by ``block_s`` (not the length).

    Each block builds the trajectory of whole ``segment`` calls (default ``shift_segment``) continuing the
    previous block's end state (time, foot position, yaw), synthesises it at the internal rate, and passes it
    through one ``ErrorModel`` whose DLPF and bias-walk states carry over. The clock (drift, jitter, monotone
    device time) and the drop bursts carry over too. Three independent generators spawned from ``seed`` draw
    the path choices, the sensor errors and the clock/drops, so the path does not depend on ``block_s``
    (the noise draws do). Per-sample truth is not kept (3 GB at 24 h); the per-stride truth is
    (``steps``, complete after iterating ``blocks``). A saturation burst that spans a block boundary is
    reported as two events.
    """

    def __init__(self, duration_s: float, seed: int = 0, profile: str | SensorProfile = "mpu6050-16g-2000dps",
                 rate_hz: float = 200.0, mount: str | Mount = "right_boot", block_s: float = 600.0,
                 segment=shift_segment, device: int | str | None = None, device_model: DeviceModel | None = None,
                 temperature: TemperatureProfile | None = None):
        if not (rate_hz > 0 and math.isfinite(rate_hz)):
            raise ValueError(f"rate must be a positive number of Hz, got {rate_hz}")
        if not (duration_s > 20.0 and block_s > 0):
            raise ValueError(f"need duration_s > 20 s and block_s > 0, got {duration_s}, {block_s}")
        self.duration_s, self.block_s, self.segment = float(duration_s), float(block_s), segment
        self.scenario, self.seed = "shift", int(seed)
        self.profile = get_profile(profile)
        self.unit, self.temperature = device_setup(self.profile, device, device_model, temperature)
        self.mount = MOUNTS[mount] if isinstance(mount, str) else mount
        self.rate_hz = float(rate_hz)
        self.decimation = 1 if self.profile.ideal else max(1, int(round(self.profile.internal_rate_hz / rate_hz)))
        self.rng_path, rng_model, self.rng_clock = (np.random.default_rng(s)
                                                    for s in np.random.SeedSequence(seed).spawn(3))
        f_int = self.rate_hz * self.decimation
        self.model = None if self.profile.ideal else ErrorModel(self.profile, f_int, rng_model, self.unit)
        self.steps: dict[str, np.ndarray] = {}
        self.gaits: dict = {}
        self.attrs = {"scenario": self.scenario, "scenario_description": "long shift: laps of a 20 m x 10 m loop "
                      "with a stair flight, pauses of 2 s to 5 min (simulate.shift_segment)", "seed": self.seed,
                      "rate_hz": self.rate_hz, "internal_rate_hz": f_int, "decimation": self.decimation,
                      "block_s": self.block_s, "sensor_profile": json.dumps(self.profile.to_dict()),
                      "drawn_constants": json.dumps(self.model.constants() if self.model else {}),
                      "step_kind_codes": json.dumps(GAIT_CODES), **describe_mount(self.mount)}
        if self.unit is not None:
            self.attrs.update(device_id=self.unit.device_id, temperature_profile=json.dumps(self.temperature.to_dict()),
                              device_model=json.dumps((device_model or DeviceModel()).to_dict()))

    @property
    def counts(self) -> bool:
        return not self.profile.ideal

    def blocks(self):
        """Yield ``SimBlock``s in time order; afterwards ``steps`` and ``attrs`` describe the whole run."""
        from bootnav.simulator.gait import PathBuilder

        prof, rate, m = self.profile, self.rate_hz, self.decimation
        f_int = rate * m
        drift = (self.rng_clock.normal() * prof.clock_error_ppm_sigma * 1e-6 if self.unit is None
                 else self.unit.clock_error)
        offset_us = int(self.rng_clock.integers(1_000_000, 4_000_000))
        res_us = max(prof.timestamp_resolution_s, 1e-6) * 1e6
        p_drop = 0.0 if prof.ideal else prof.drop_burst_rate_hz / rate
        t0_us = last_us = None
        drop_left = 0  # samples of a drop burst still to drop at the start of the next block
        n_kept = 0
        last_idx = -1
        state = (0.0, np.zeros(3), 0.0)  # time, foot position, yaw at the end of the previous block
        step_parts: list[dict] = []
        j0, final = 0, False
        while not final:
            t_start, pos, yaw = state
            pb = PathBuilder(yaw0_rad=yaw, t=t_start, pos=pos.copy(), gaits=self.gaits)
            if t_start == 0.0:
                pb.stand(10.0)  # still start: the initial alignment
            while pb.t < min(t_start + self.block_s, self.duration_s - 10.0):
                self.segment(pb, self.rng_path)
            final = pb.t >= self.duration_s - 10.0
            if final:
                pb.stand(10.0)
            traj = pb.build()
            n_end = int(math.floor(pb.t * rate + 1e-9))  # last sample index inside this block's trajectory
            j1 = n_end + 1 if final else n_end
            step_parts.append({**pb.step_table(), "foot_pos_n_m": traj.evaluate(np.array(
                [s["t_end_s"] for s in pb.steps]))[0][:, :3] if pb.steps else np.zeros((0, 3))})
            state = (pb.t, pb.pos.copy(), pb.yaw)
            i_end = (j1 - 1) * m + 1 if final else j1 * m
            kin = synthesize(traj, np.arange(j0 * m, i_end) / f_int, self.mount)
            sl = slice(None, None, m)
            if self.model is None:
                acc, gyro = kin.f_b[sl], kin.omega_b[sl]
                saturated = np.zeros(j1 - j0, np.uint8)
            else:
                a, g, _, _ = self.model.process(kin.f_b, kin.omega_b, None if self.unit is None
                                                else self.temperature.chip(np.arange(j0 * m, i_end) / f_int))
                acc, sat_a = quantize(a[sl], prof.accel_lsb_mps2)
                gyro, sat_g = quantize(g[sl], prof.gyro_lsb_radps)
                saturated = np.zeros(j1 - j0, dtype=np.uint8)
                for ax in range(3):
                    saturated |= (sat_a[:, ax].astype(np.uint8) << ax) | (sat_g[:, ax].astype(np.uint8) << (ax + 3))
            n = j1 - j0
            t_true = np.arange(j0, j1) / rate
            if prof.ideal:
                t_us = np.rint(t_true * 1e6).astype(np.int64)
            else:
                jit = np.clip(self.rng_clock.normal(0.0, 1.0, n), -3, 3) * prof.timestamp_jitter_s
                t_us = (offset_us + res_us * np.rint((t_true * (1 + drift) + jit) * 1e6 / res_us)).astype(np.int64)
                t_us = np.maximum.accumulate(t_us if last_us is None else np.maximum(t_us, last_us))
            last_us = int(t_us[-1])
            keep = np.ones(n, dtype=bool)
            keep[:drop_left] = False
            drop_left = max(0, drop_left - n)
            if p_drop > 0:
                starts = np.flatnonzero(self.rng_clock.random(n) < p_drop)
                starts = starts[starts + j0 > 0]  # the first sample always arrives
                lengths = self.rng_clock.geometric(1.0 / max(prof.drop_burst_mean, 1.0), starts.size)
                for s, L in zip(starts, lengths):  # one iteration per burst (a few per hour), not per sample
                    keep[s : s + L] = False
                    drop_left = max(drop_left, int(s + L - n))
            sel = np.flatnonzero(keep)
            idx = j0 + sel
            if t0_us is None:
                t0_us = int(t_us[sel[0]])
            kept_t = (t_us[sel] - t0_us) / 1e6
            sat = saturated[sel]
            events = []
            jumps = np.diff(np.concatenate(([last_idx], idx))) if last_idx >= 0 else np.diff(idx, prepend=idx[0])
            for i in np.flatnonzero(jumps > 1):
                events.append(dict(t_s=kept_t[i], sample_index=int(n_kept + i), kind="gap", count=int(jumps[i] - 1),
                                   detail="simulated dropped samples (SD write stall)"))
            for axis in range(6):
                s0, s1 = runs((sat >> axis) & 1)
                for s, L in zip(s0, s1 - s0):
                    events.append(dict(t_s=kept_t[s], sample_index=int(n_kept + s), kind="saturation", count=int(L),
                                       axis=axis, detail="at full scale"))
            events.sort(key=lambda e: e["sample_index"])
            temp = t_device = seq = None
            if not prof.ideal:
                warm = self.temperature.chip(t_true[sel])
                temp = temp_counts(warm)
                t_device = (t_us[sel] % (1 << 32)).astype(np.uint32)
                seq = (idx % (1 << 16)).astype(np.uint16)
            n_kept += sel.size
            last_idx = int(idx[-1])
            yield SimBlock(kept_t, acc[sel], gyro[sel], sat, t_device, seq, temp, events)
            j0 = j1
        self.steps = {k: np.concatenate([p[k] for p in step_parts]) for k in step_parts[0]}
        self.attrs.update(duration_s=float(state[0]), n_nominal_samples=j0, n_dropped=int(j0 - n_kept),
                          gait_parameters=json.dumps([asdict(g) for g in sorted(self.gaits, key=self.gaits.get)]))
