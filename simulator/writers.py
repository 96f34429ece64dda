"""Write a SimResult as a bootnav HDF5 recording (with /truth) or as the firmware's SD-card text log."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.core.conventions import __version__
from bootnav.errors import InputError
from bootnav.logger.crc import crc16_ccitt_false_rows
from bootnav.logger.mpu6050 import TEMP_LSB_PER_DEGC, accel_code, gyro_code
from bootnav.logger.recording import counts_channel, si_channel, write_group, write_recording
from bootnav.simulator.calibration import TRUTH_UNITS as CALIBRATION_TRUTH_UNITS
from bootnav.simulator.simulate import LongSimulation, SimResult

SIM_DEVICE_ID = 0x00051A00  # "SIM" device id in headers

TRUTH_UNITS = {
    "t_s": "s", "pos_n_m": "m", "vel_n_mps": "m/s", "q_nb": "1 (wxyz, body->nav)", "stance": "1 (0/1)",
    "f_b_mps2": "m/s^2", "omega_b_radps": "rad/s", "foot_pos_n_m": "m", "acc_bias_b_mps2": "m/s^2",
    "gyro_bias_b_radps": "rad/s", "sample_index": "1",
    "step_t_s": "s", "step_t_start_s": "s", "step_t_toe_off_s": "s", "step_t_heel_strike_s": "s",
    "step_length_m": "m", "step_dz_m": "m", "step_heading_rad": "rad", "step_turn_rad": "rad",
    "step_chord_heading_rad": "rad", "step_gait": "1 (index into attrs gait_parameters)",
    "step_kind": "1 (attrs step_kind_codes)", "step_foot_pos_n_m": "m",
    **CALIBRATION_TRUTH_UNITS,
    # with a device (--device): the constants this recording got (docs/simulator.md, "Device truth")
    "temp_degc": "degC (true chip temperature)", "ambient_degc": "degC",
    "acc_sensitivity_matrix": "1 (y = M f at temp_reference_degc)", "gyro_sensitivity_matrix": "1 (y = M w)",
    "acc_bias_turn_on_b_mps2": "m/s^2 (this power-on, at temp_reference_degc)",
    "gyro_bias_turn_on_b_radps": "rad/s (this power-on, at temp_reference_degc)",
    "acc_bias_device_mean_b_mps2": "m/s^2", "gyro_bias_device_mean_b_radps": "rad/s",
    "acc_bias_tempco_b_mps2_per_degc": "m/s^2/degC", "gyro_bias_tempco_b_radps_per_degc": "rad/s/degC",
    "acc_scale_tempco_per_degc": "1/degC", "gyro_scale_tempco_per_degc": "1/degC",
    "clock_error": "1 (device clock = true time x (1 + e))", "temp_reference_degc": "degC",
}
TRUTH_DESCRIPTION = (
    "Exact truth, row i belongs to /imu row i. pos_n_m/vel_n_mps/q_nb: sensor (body) origin and attitude, ENU, "
    "pos starts at the origin; foot_pos_n_m: sole origin of the boot; stance: foot at rest (flat, or on its toe "
    "while crawling) and exactly still; "
    "f_b_mps2/omega_b_radps: exact specific force and angular rate before sensor errors; *_bias_*: total "
    "bias in the delivered samples (turn-on + random walk); t_s: true sample time (the /imu clock has the "
    "simulated clock error and jitter). step_*: one row per stride or posture change (kneel, stand_up; "
    "step_kind), t_s = foot at rest again."
)


def step_arrays(res: SimResult) -> dict[str, np.ndarray]:
    s = res.steps
    out = {"step_t_s": s["t_end_s"], "step_t_start_s": s["t_start_s"], "step_t_toe_off_s": s["t_toe_off_s"],
           "step_t_heel_strike_s": s["t_heel_strike_s"]}
    for key in ("length_m", "dz_m", "heading_rad", "turn_rad", "chord_heading_rad", "gait", "kind"):
        out["step_" + key] = s[key]
    if res.trajectory is not None and len(s["t_end_s"]):
        out["step_foot_pos_n_m"] = res.trajectory.evaluate(s["t_end_s"])[0][:, :3]
    return out


def device_id(res) -> int:
    """The id in the header: the simulated unit's (``--device``), else the generic simulator id."""
    return int(res.attrs.get("device_id", SIM_DEVICE_ID))


def recording_meta(res: SimResult) -> dict:
    p = res.profile
    meta = {
        "device": "MPU6050 (simulated)" if not p.ideal else "ideal IMU (simulated)",
        "device_id": f"0x{device_id(res):08X}",  # as the recorder stores the header's id (serial_recorder)
        "firmware_version": f"bootnav-simulator {__version__}",
        "rate_nominal_hz": res.rate_hz,
        "smplrt_div": res.decimation - 1,
        "mount": res.mount.name,
        "subject": "simulated",
        "session_notes": f"simulated scenario {res.scenario} (seed {res.seed}, profile {p.name}"
                         + (f", device 0x{device_id(res):08X})" if "device_id" in res.attrs else ")"),
        "simulator": json.dumps({k: res.attrs[k] for k in ("scenario", "seed", "rate_hz", "internal_rate_hz")}),
        "sensor_profile": p.name,
        "sensor_profile_parameters": json.dumps(p.to_dict()),
        "mount_lever_arm_m": json.dumps(list(res.mount.lever_arm_m)),
        "mount_rpy_deg": json.dumps(list(res.mount.rpy_deg)),
    }
    if not p.ideal:
        meta.update(accel_range_g=p.accel_range_g, gyro_range_dps=p.gyro_range_dps,
                    dlpf_cfg=-1 if p.dlpf_cfg is None else p.dlpf_cfg,
                    accel_fs=accel_code(p.accel_range_g), gyro_fs=gyro_code(p.gyro_range_dps))
    return meta


def write_h5(res: SimResult, path: str | os.PathLike) -> Path:
    """The recording (int16 counts + scale factors; SI floats for ``ideal``) and its /truth group."""
    path = Path(path)
    p = res.profile
    kw = {}
    if res.counts:
        acc_ch = counts_channel("acc", p.accel_lsb_mps2)
        gyro_ch = counts_channel("gyro", p.gyro_lsb_radps)
        kw = dict(t_device=res.t_device, seq=res.seq, temp=res.temp,
                  temp_channel=counts_channel("temp", 1.0 / TEMP_LSB_PER_DEGC))
    else:
        acc_ch, gyro_ch = si_channel("acc"), si_channel("gyro")
    write_recording(path, res.t_s, res.acc, res.gyro, acc_channel=acc_ch, gyro_channel=gyro_ch, events=res.events,
                    meta=recording_meta(res), saturated=res.saturated, **kw)
    arrays = {**res.truth, **step_arrays(res)}
    attrs = {**res.attrs, "description": TRUTH_DESCRIPTION}
    write_group(path, "truth", arrays, attrs=attrs, units=TRUTH_UNITS)
    return path


def write_long_h5(sim: LongSimulation, path: str | os.PathLike, progress=None) -> Path:
    """Write a ``LongSimulation`` block by block (memory bounded by its ``block_s``, not by the length).

    The recording is the same layout as ``write_h5``'s; ``/truth`` holds the per-stride table and the
    attributes only (``LongSimulation`` keeps no per-sample truth). ``progress(t_s)`` after each block.
    The measured rate and jitter in ``/meta`` are accumulated over the blocks (the nominal period from the
    first block, as ``timing_summary`` would take it from the whole time vector).
    """
    from bootnav.core.timebase import GAP_FACTOR, nominal_period
    from bootnav.logger.recording import RecordingWriter

    path = Path(path)
    p = sim.profile
    if sim.counts:
        acc_ch, gyro_ch = counts_channel("acc", p.accel_lsb_mps2), counts_channel("gyro", p.gyro_lsb_radps)
        temp_ch = counts_channel("temp", 1.0 / TEMP_LSB_PER_DEGC)
    else:
        acc_ch, gyro_ch, temp_ch = si_channel("acc"), si_channel("gyro"), None
    writer = RecordingWriter(path, acc_ch, gyro_ch, temp=temp_ch, device_time=sim.counts, seq=sim.counts,
                             meta=recording_meta(sim), swmr=False)
    try:
        period = None
        t_last = None
        s1 = s2 = 0.0
        k = 0
        for block in sim.blocks():
            optional = dict(temp=block.temp, t_device=block.t_device, seq=block.seq) if sim.counts else {}
            writer.append(block.t_s, block.acc, block.gyro, saturated=block.saturated, **optional)
            writer.add_events(block.events)
            dt = np.diff(block.t_s if t_last is None else np.concatenate(([t_last], block.t_s)))
            t_last = float(block.t_s[-1])
            dt = dt[np.isfinite(dt) & (dt > 0)]
            period = period if period is not None else nominal_period(dt)
            dt = dt[dt < GAP_FACTOR * period]
            s1, s2, k = s1 + float(dt.sum()), s2 + float(np.square(dt).sum()), k + dt.size
            if progress:
                progress(t_last)
        jitter = float(np.sqrt(max(s2 / k - (s1 / k) ** 2, 0.0))) if k else float("nan")
        writer.close(final_meta={"rate_measured_hz": 1.0 / period, "jitter_s": jitter})
    except BaseException:
        writer.abort()
        raise
    steps = {"step_t_s": sim.steps["t_end_s"], "step_t_start_s": sim.steps["t_start_s"],
             "step_t_toe_off_s": sim.steps["t_toe_off_s"], "step_t_heel_strike_s": sim.steps["t_heel_strike_s"],
             "step_foot_pos_n_m": sim.steps["foot_pos_n_m"],
             **{"step_" + key: sim.steps[key] for key in ("length_m", "dz_m", "heading_rad", "turn_rad",
                                                           "chord_heading_rad", "gait", "kind")}}
    write_group(path, "truth", steps, attrs={**sim.attrs, "description": "per-stride truth of a long simulated "
                "recording (no per-sample truth); step_*: see write_h5"}, units=TRUTH_UNITS)
    return path


def sd_lines(res: SimResult) -> list[bytes]:
    """Data lines ``t_us,seq,ax,ay,az,gx,gy,gz,temp*CRC`` (no newline), CRC-16/CCITT-FALSE vectorised."""
    cols = np.column_stack([res.t_device.astype(np.int64), res.seq.astype(np.int64), res.acc.astype(np.int64),
                            res.gyro.astype(np.int64), res.temp.astype(np.int64)])
    bodies = [",".join(map(str, row)).encode("ascii") for row in cols.tolist()]
    crcs = np.zeros(len(bodies), dtype=np.uint16)
    lengths = np.fromiter(map(len, bodies), dtype=np.int64, count=len(bodies))
    for length in np.unique(lengths):  # equal-length rows go through the numpy row CRC together
        sel = np.flatnonzero(lengths == length)
        block = np.frombuffer(b"".join(bodies[i] for i in sel), dtype=np.uint8).reshape(sel.size, int(length))
        crcs[sel] = crc16_ccitt_false_rows(block)
    return [b + b"*%04X" % c for b, c in zip(bodies, crcs.tolist())]


def write_sd_txt(res: SimResult, path: str | os.PathLike) -> Path:
    """The firmware's SD-card log (PROTOCOL.md section 2). Needs int16 counts: not for ``ideal``."""
    if not res.counts:
        raise InputError(f"{path}: the SD-card text format stores int16 counts; profile {res.profile.name!r} "
                         "delivers floats - choose an mpu6050-* profile")
    p = res.profile
    header = (f"# bootnav-sd v1 accel_fs={accel_code(p.accel_range_g)} gyro_fs={gyro_code(p.gyro_range_dps)} "
              f"dlpf={0 if p.dlpf_cfg is None else p.dlpf_cfg} smplrt_div={res.decimation - 1} fw={__version__} "
              f"device_id=0x{device_id(res):08X}")
    path = Path(path)
    with atomic.replacing(path) as f:  # crash-safe: complete or absent
        f.write(header.encode("ascii") + b"\n")
        f.write(b"\n".join(sd_lines(res)) + b"\n")
    return path
