"""A whole mission (issue 23): 30 min and 1 h walks of simulated MPU6050 boots, uncalibrated and calibrated.

Every figure of a 1-2 minute walk of a factory-calibrated IMU hides what per-unit and per-power-on errors do
over a mission. This benchmark simulates many units (``bootnav simulate --device D``: the unit's stable
constants from D, what changes per power-on from the seed) on long scenarios and processes each walk as:

* ``uncal``: the datasheet profile (``mpu6050-16g-2000dps``) with no calibration (what a boot delivers);
* ``cal``: calibrated from ONE simulated hand-held session of the same unit (``simulate --scenario
  calibration --device D --seed other``, ``bootnav calibrate``, then ``process --calibration``);
* ``oracle``: a calibration built from the truth constants the recording got (the drawn scale /
  cross-axis matrix, the turn-on bias mean and temperature coefficients): what a perfect calibration gives;
* ``floor``: ``mpu6050-noise-only`` (white noise + bias random walk): what the sensor's noise allows;
* ablations ``no-<term>``: the datasheet profile with one error term switched off (scale, cross-axis,
  turn-on bias, temperature, clock, bias random walk): which term costs what, uncalibrated.

Figures per walk (``mission_metrics``), after a yaw alignment over the first 10 m (as an entry door would
give it: the estimate is turned about the start so that its chord from the start to the first sample where
the TRUE path has covered 10 m horizontally points as the truth's chord does; the origin is the start of
both): final, worst and ARMSE (RMS over samples) horizontal error, final and worst height error, the share
of true stance samples whose height is within 1.5 m of the truth, and the distance error. The calibrated runs
also give the parameter recovery of ``calibrate`` against the drawn constants (``recovery``): scale and
misalignment errors of C M - I, and the bias error against the calibration session's true turn-on bias.

Printed as a table of medians and worst values over the devices (it asserts nothing); ``--json`` writes every
row. Reusable by other benchmarks: ``--scenarios`` takes any registered scenario, ``--set KEY=VALUE``
overrides process settings (dotted keys, JSON values), ``--label`` names the run in the JSON.

    nice -n 10 .venv/bin/python benchmarks/mission.py --devices 20 --jobs 2 --json mission.json
    nice -n 10 .venv/bin/python benchmarks/mission.py --quick               # 3 devices, 5-min walks
    nice -n 10 .venv/bin/python benchmarks/mission.py --scenarios building --variants uncal cal --set \
        selftune.timing_calibration=false --label no-timing

Simulated recordings and calibration files are cached under ``--cache`` (keyed by scenario, duration,
device, seed and the full sensor profile), so a re-run only processes. Seeds: device k is 0x0B000000 + k,
its walk seed is 1000 + k, its calibration session's seed 5000 + k (never the same draw as the walk). The
noise-only floor is the same walk without a unit (the simulator has no unit without errors).
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from multiprocessing import get_context
from pathlib import Path

import numpy as np

BOOTNAV = [sys.executable, "-m", "bootnav"]
UNCAL_PROFILE = "mpu6050-16g-2000dps"
FLOOR_PROFILE = "mpu6050-noise-only"
ALIGN_M = 10.0  # yaw aligned over the first 10 m (an entry door's heading)
HEIGHT_TOL_M = 1.5  # half a storey: "on the right floor"

# Each ablation switches one error term of the datasheet profile off (SensorProfile fields; fields a version of
# the simulator does not have are skipped, and an ablation with none of its fields is not run).
ABLATIONS: dict[str, dict] = {
    "no-scale": {"accel_scale_sigma": 0.0, "gyro_scale_sigma": 0.0},
    "no-cross-axis": {"accel_cross_axis_sigma": 0.0, "gyro_cross_axis_sigma": 0.0},
    "no-turn-on-bias": {"accel_turn_on_bias_sigma_mg": (0.0, 0.0, 0.0), "gyro_turn_on_bias_sigma_dps": 0.0},
    "no-temperature": "temperature",  # the unit's bias and sensitivity temperature coefficients (DeviceModel)
    "no-clock": {"clock_error_ppm_sigma": 0.0},
    "no-bias-rw": {"accel_bias_rw_mps2_rts": 0.0, "gyro_bias_rw_dps_rts": 0.0},
}
MAIN_VARIANTS = ("uncal", "cal", "oracle", "floor")
DEVICE_BASE = 0x0B000000  # device k of the benchmark is DEVICE_BASE + k


# ---------------------------------------------------------------------------------------------------------------
# figures


def yaw_alignment(truth_xy: np.ndarray, est_xy: np.ndarray, align_m: float = ALIGN_M) -> tuple[float, int]:
    """Yaw (rad) that turns the estimate's chord onto the truth's over the first ``align_m`` of the true path.

    The chord runs from the start to the first sample where the true path has covered ``align_m``
    horizontally (the last sample if it never does); both paths start at the origin. Returns (yaw, index).
    """
    step = np.linalg.norm(np.diff(truth_xy, axis=0), axis=1)
    walked = np.concatenate(([0.0], np.cumsum(step)))
    k = int(min(np.searchsorted(walked, align_m), len(walked) - 1))
    dt, de = truth_xy[k] - truth_xy[0], est_xy[k] - est_xy[0]
    if np.linalg.norm(de) < 1e-9 or np.linalg.norm(dt) < 1e-9:
        return 0.0, k
    return float(math.atan2(dt[1], dt[0]) - math.atan2(de[1], de[0])), k


def mission_metrics(pos_est: np.ndarray, pos_true: np.ndarray, stance_true: np.ndarray,
                    align_m: float = ALIGN_M, height_tol_m: float = HEIGHT_TOL_M) -> dict:
    """Errors of one walk (row-aligned estimate and truth, both starting at the origin; module docstring)."""
    est = np.asarray(pos_est, float) - np.asarray(pos_est, float)[0]
    tru = np.asarray(pos_true, float) - np.asarray(pos_true, float)[0]
    yaw, k = yaw_alignment(tru[:, :2], est[:, :2], align_m)
    c, s = math.cos(yaw), math.sin(yaw)
    xy = est[:, :2] @ np.array([[c, s], [-s, c]])  # rows rotated by +yaw
    h = np.linalg.norm(xy - tru[:, :2], axis=1)
    v = np.abs(est[:, 2] - tru[:, 2])
    st = np.asarray(stance_true, bool)
    return {"final_h_m": float(h[-1]), "worst_h_m": float(h.max()), "armse_h_m": float(np.sqrt(np.mean(h**2))),
            "final_v_m": float(v[-1]), "worst_v_m": float(v.max()),
            "stance_within_tol_pct": float(100.0 * np.mean(v[st] <= height_tol_m)) if st.any() else float("nan"),
            "align_yaw_deg": math.degrees(yaw), "align_index": k}


def recovery(cal, truth: dict) -> dict:
    """Parameter recovery of a calibration against the drawn constants of the session it came from.

    ``calibrate`` expresses both triads in the accelerometer's frame (its C is upper triangular), so C_a M_a
    is not I but R P_a: a rotation R (the accelerometer's axes against the simulator's body axes: a fixed
    re-definition of the body frame, not an error) times a symmetric P_a (polar decomposition). The remaining
    errors are E_a = P_a - I and E_g = R^T C_g M_g - I (the gyro must land in the same frame): diag(E) is the
    scale error, the off-diagonal the misalignment (small angles, rad -> deg). Bias error: b_hat - b_true at
    the reference temperature (the session's turn-on bias, the one ``calibrate`` can see).
    """
    from scipy.linalg import polar

    out = {}
    if cal.acc is None or "acc_sensitivity_matrix" not in truth:
        return out
    CM_a = np.asarray(cal.acc.matrix) @ np.asarray(truth["acc_sensitivity_matrix"], float)
    R, P = polar(CM_a)  # CM_a = R P
    errs = {"acc": P - np.eye(3)}
    if cal.gyro is not None and "gyro_sensitivity_matrix" in truth:
        errs["gyro"] = R.T @ np.asarray(cal.gyro.matrix) @ np.asarray(truth["gyro_sensitivity_matrix"], float) - np.eye(3)
    for triad, E in errs.items():
        off = E[~np.eye(3, dtype=bool)]
        out[f"{triad}_scale_err_pct_max"] = float(100.0 * np.abs(np.diag(E)).max())
        out[f"{triad}_misalign_err_deg_max"] = float(np.degrees(np.abs(off).max()))
    out["frame_rotation_deg"] = float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))
    for triad, key, unit in (("acc", "acc_bias_turn_on_b_mps2", 1.0), ("gyro", "gyro_bias_turn_on_b_radps", 180 / math.pi)):
        tri = getattr(cal, triad)
        if tri is not None and key in truth:
            # the bias in the accelerometer frame: C b_hat vs C M M^-1 b_true, compared in the sensor's own axes
            out[f"{triad}_bias_err_max"] = float(np.abs(np.asarray(tri.bias) - np.asarray(truth[key], float)).max()
                                                 * unit)  # m/s^2, deg/s
    return out


# ---------------------------------------------------------------------------------------------------------------
# simulation (cached)


def device_model(variant: str):
    """The simulator's DeviceModel of a variant: temperature coefficients off for ``no-temperature``."""
    from bootnav.simulator.device import DeviceModel

    if ABLATIONS.get(variant) != "temperature":
        return None
    return DeviceModel(gyro_bias_tempco_sigma_dps_per_degc=0.0, accel_bias_tempco_sigma_mg_per_degc=(0.0, 0.0, 0.0),
                       gyro_scale_tempco_sigma_per_degc=0.0, accel_scale_tempco_sigma_per_degc=0.0)


def sensor_profile(variant: str):
    """The SensorProfile of a variant (``uncal``/``cal``/``oracle`` share the datasheet one), or None when an
    ablation names no field this simulator has."""
    from bootnav.simulator.imu_model import get_profile

    if variant == "floor":
        return get_profile(FLOOR_PROFILE)
    base = get_profile(UNCAL_PROFILE)
    if variant in MAIN_VARIANTS:
        return base
    spec = ABLATIONS[variant]
    if spec == "temperature":
        return base
    known = {k: v for k, v in spec.items() if hasattr(base, k)}
    if not known:
        return None
    return dataclasses.replace(base, name=f"{UNCAL_PROFILE}-{variant}", **known)


def _key(*parts) -> str:
    return hashlib.sha1(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()[:12]


def simulated(cache: Path, scenario: str, duration_s: float | None, device: int | None, seed: int, profile,
              model=None) -> Path:
    """The cached recording of a walk (simulated and written when missing; writes are tmp + rename). The
    noise-only floor has no device (the simulator refuses a unit without errors): the same walk, no unit."""
    from bootnav.simulator.simulate import simulate
    from bootnav.simulator.writers import write_h5

    prof = dataclasses.asdict(profile)
    if not _has_errors(profile):
        device, model = None, None
    mdict = None if model is None else dataclasses.asdict(model)
    tag = "nodev" if device is None else f"0x{device:08X}"
    path = cache / f"{scenario}_{tag}_s{seed}_{_key(scenario, duration_s, device, seed, prof, mdict)}.h5"
    if path.exists():
        return path
    kw = {"duration_s": duration_s}
    if device is not None:
        kw["device"] = device
        if model is not None:
            kw["device_model"] = model
    res = simulate(scenario, seed=seed, profile=profile, **kw)
    tmp = path.with_name(path.name + f".{os.getpid()}.tmp")
    write_h5(res, tmp)
    os.replace(tmp, path)
    return path


def _has_errors(profile) -> bool:
    return bool(profile.accel_scale_sigma or profile.gyro_scale_sigma or profile.gyro_turn_on_bias_sigma_dps
                or any(profile.accel_turn_on_bias_sigma_mg) or profile.clock_error_ppm_sigma
                or profile.accel_cross_axis_sigma or profile.gyro_cross_axis_sigma)


def calibration_file(cache: Path, device: int, seed: int) -> tuple[Path, Path]:
    """``bootnav simulate --scenario calibration --device D --seed S`` + ``bootnav calibrate --no-store``
    (cached): (calibration file, session recording)."""
    dev = f"0x{device:08X}"
    session = cache / f"calsession_{dev}_s{seed}.h5"
    out = cache / f"cal_{dev}_s{seed}.json"
    if out.exists() and session.exists():
        return out, session
    if not session.exists():
        tmp = session.with_name(session.name + f".{os.getpid()}.tmp.h5")
        _run(BOOTNAV + ["simulate", "--scenario", "calibration", "--device", dev, "--seed", str(seed),
                        "--out", str(tmp), "--quiet"])
        os.replace(tmp, session)
    tmp = out.with_name(out.name + f".{os.getpid()}.tmp.json")
    _run(BOOTNAV + ["calibrate", str(session), "--out", str(tmp), "--no-store", "--quiet"])
    os.replace(tmp, out)
    return out, session


def _run(cmd: list[str]) -> None:
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=tempfile.gettempdir())
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd[2:])} failed ({p.returncode}): {(p.stderr or p.stdout).strip()[-600:]}")


DEVICE_TRUTH = ("acc_sensitivity_matrix", "gyro_sensitivity_matrix", "acc_bias_turn_on_b_mps2",
                "gyro_bias_turn_on_b_radps", "acc_bias_tempco_b_mps2_per_degc", "gyro_bias_tempco_b_radps_per_degc",
                "clock_error", "temp_reference_degc")


def truth_of(path: Path) -> tuple[np.ndarray, np.ndarray, dict, dict]:
    """(pos_n_m, stance, the unit's constants this recording got (``DEVICE_TRUTH``), truth attrs)."""
    import h5py

    with h5py.File(path, "r") as f:
        g = f["truth"]
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in g.attrs.items()}
        consts = {k: g[k][()] for k in DEVICE_TRUTH if k in g}
        if "step_length_m" in g:  # the walked distance: the sum of the true strides
            attrs["_walked_m"] = float(np.sum(g["step_length_m"][()]))
        pos = g["pos_n_m"][()] if "pos_n_m" in g else None
        stance = g["stance"][()].astype(bool) if "stance" in g else None
        return pos, stance, consts, attrs


def oracle_calibration(consts: dict, device: int | None):
    """A calibration from the truth constants the recording got: C = M^-1, b = this power-on's turn-on bias,
    k = the unit's bias temperature coefficients at its reference temperature (the clock error and the
    sensitivity temperature coefficients are not in the calibration model). None without device truth."""
    from bootnav.core.sensorcal import SensorCalibration, TriadCalibration

    if "acc_sensitivity_matrix" not in consts:
        return None

    def triad(m, b, k):
        return TriadCalibration(np.linalg.inv(np.asarray(consts[m], float)), np.asarray(consts[b], float),
                                np.asarray(consts.get(k, np.zeros(3)), float))

    return SensorCalibration(
        device_id=None if device is None else f"0x{device:08X}",
        acc=triad("acc_sensitivity_matrix", "acc_bias_turn_on_b_mps2", "acc_bias_tempco_b_mps2_per_degc"),
        gyro=triad("gyro_sensitivity_matrix", "gyro_bias_turn_on_b_radps", "gyro_bias_tempco_b_radps_per_degc"),
        temp_ref_degc=float(consts.get("temp_reference_degc", 25.0)), source="oracle (simulator truth constants)")


# ---------------------------------------------------------------------------------------------------------------
# one walk


def run_task(task: dict) -> dict:
    """Simulate (cached), calibrate when the variant needs it, process, score: one row."""
    import bootnav
    from bootnav.core.sensorcal import SensorCalibration
    from bootnav.postproc.settings import ProcessSettings

    t0 = time.perf_counter()
    row = {k: task[k] for k in ("scenario", "device", "seed", "variant", "label")}
    cache = Path(task["cache"])
    dev = int(task["device"], 16)
    profile = sensor_profile(task["variant"])
    try:
        path = simulated(cache, task["scenario"], task["duration_s"], dev, task["seed"], profile,
                         device_model(task["variant"]))
        pos_true, stance_true, consts, attrs = truth_of(path)
        settings = ProcessSettings.from_dict(task["settings"])
        settings.output.plots = False
        calibration = False  # uncal, floor, ablations: never a store match
        if task["variant"] == "cal":
            cal_path, session = calibration_file(cache, dev, task["cal_seed"])
            calibration = str(cal_path)
            row.update({f"rec_{k}": v for k, v in recovery(SensorCalibration.load(cal_path),
                                                           truth_of(session)[2]).items()})
        elif task["variant"] == "oracle":
            calibration = oracle_calibration(consts, dev)
            if calibration is None:
                raise RuntimeError("the recording has no device truth (a simulator without --device?)")
        r = bootnav.process(str(path), settings=settings, calibration=calibration)
        return _score(row, r, pos_true, stance_true, attrs, t0)
    except Exception as exc:  # a failed walk is a row too: it counts, it is never skipped silently
        row.update({"error": f"{type(exc).__name__}: {exc}"[:400], "wall_s": time.perf_counter() - t0})
        return row


def _score(row: dict, r, pos_true, stance_true, attrs: dict, t0: float) -> dict:
    pos = np.asarray(r.pos_n_m)
    if pos.shape[0] != pos_true.shape[0]:
        raise RuntimeError(f"estimate has {pos.shape[0]} rows, truth {pos_true.shape[0]}")
    row.update(mission_metrics(pos, pos_true, stance_true))
    summary = r.summary or {}
    dist = summary.get("distance_m")
    row["true_distance_m"] = float(attrs.get("_walked_m", float("nan")))
    if dist is not None:
        row["distance_m"] = float(dist)
        row["distance_err_pct"] = 100.0 * (float(dist) / row["true_distance_m"] - 1.0)
    flags = (summary.get("navigation") or {}).get("stride_flags") or {}
    row["missed_stance_strides"] = int(flags.get("missed_stance", 0))
    dec = (summary.get("filter") or {}).get("heading_decision")
    if isinstance(dec, dict):  # heading_aid "auto": what it decided (docs/building.md)
        row["heading_aid_on"] = bool(dec.get("on"))
        row["heading_aid_segments"] = dec.get("segments") or {}
    cal = summary.get("calibration")
    if isinstance(cal, dict):
        row["calibration"] = cal.get("source") or cal.get("status")
    row["wall_s"] = time.perf_counter() - t0
    return row


# ---------------------------------------------------------------------------------------------------------------
# table


FIGURES = (("final_h_m", "final h m"), ("worst_h_m", "worst h m"), ("armse_h_m", "ARMSE h m"),
           ("final_v_m", "final v m"), ("worst_v_m", "worst v m"), ("stance_within_tol_pct", "in 1.5 m %"),
           ("distance_err_pct", "dist err %"), ("missed_stance_strides", "missed ZUPT"))


def summarize(rows: list[dict]) -> list[dict]:
    """Per (scenario, variant): n, failures, and median / worst of each figure over the devices."""
    out = []
    keys = []
    for r in rows:
        k = (r["scenario"], r["variant"])
        if k not in keys:
            keys.append(k)
    for scen, var in keys:
        rs = [r for r in rows if r["scenario"] == scen and r["variant"] == var]
        ok = [r for r in rs if "error" not in r]
        s = {"scenario": scen, "variant": var, "n": len(rs), "failed": len(rs) - len(ok)}
        for key, _ in FIGURES:
            vals = np.array([r[key] for r in ok if key in r and r[key] is not None], float)
            if vals.size:
                worst = vals.min() if key == "stance_within_tol_pct" else (
                    vals[np.argmax(np.abs(vals))] if key == "distance_err_pct" else vals.max())
                s[key] = {"median": float(np.median(vals)), "worst": float(worst)}
        rec = sorted({k for r in ok for k in r if k.startswith("rec_")})
        for key in rec:
            vals = np.array([r[key] for r in ok if key in r], float)
            s[key] = {"median": float(np.median(vals)), "worst": float(vals.max()),
                      "rms": float(np.sqrt(np.mean(vals**2)))}
        out.append(s)
    return out


def print_table(summary: list[dict], file=sys.stdout) -> None:
    head = f"{'scenario':<14} {'variant':<16} {'n':>3} {'fail':>4}  " + "  ".join(f"{h:>17}" for _, h in FIGURES)
    print(head, file=file)
    print(" " * 41 + "  ".join(f"{'median / worst':>17}" for _ in FIGURES), file=file)
    for s in summary:
        cells = []
        for key, _ in FIGURES:
            v = s.get(key)
            cells.append(f"{v['median']:>8.2f} /{v['worst']:>7.2f}" if v else f"{'-':>17}")
        print(f"{s['scenario']:<14} {s['variant']:<16} {s['n']:>3} {s['failed']:>4}  " + "  ".join(cells), file=file)
    recs = [s for s in summary if any(k.startswith("rec_") for k in s)]
    for s in recs:
        print(f"\nparameter recovery of `bootnav calibrate` ({s['scenario']}, {s['n']} devices; max over axes, "
              "median / worst / RMS over devices):", file=file)
        for k in sorted(k for k in s if k.startswith("rec_")):
            v = s[k]
            print(f"  {k[4:]:<28} {v['median']:.4f} / {v['worst']:.4f} / {v['rms']:.4f}", file=file)


# ---------------------------------------------------------------------------------------------------------------


def parse_set(items: list[str]) -> dict:
    """``KEY=VALUE`` pairs (dotted keys into ProcessSettings, JSON values, else strings) as a nested dict."""
    out: dict = {}
    for item in items:
        if "=" not in item:
            raise SystemExit(f"--set {item!r}: expected KEY=VALUE, e.g. filter.n_states=9")
        key, val = item.split("=", 1)
        try:
            value = json.loads(val)
        except json.JSONDecodeError:
            value = val
        d = out
        parts = key.split(".")
        for p in parts[:-1]:
            d = d.setdefault(p, {})
        d[parts[-1]] = value
    return out


def build_tasks(args) -> list[dict]:
    settings = parse_set(args.set)
    from bootnav.postproc.settings import ProcessSettings

    ProcessSettings.from_dict(settings)  # a typo fails here, before any work
    variants = list(args.variants)
    tasks = []
    for scen in args.scenarios:
        for k in range(args.first_device, args.first_device + args.devices):
            for var in variants:
                if var not in MAIN_VARIANTS and var not in ABLATIONS:
                    raise SystemExit(f"unknown variant {var!r}; choose from {MAIN_VARIANTS + tuple(ABLATIONS)}")
                if var in ABLATIONS and k - args.first_device >= args.ablation_devices:
                    continue
                if sensor_profile(var) is None:
                    print(f"note: {var} skipped: this simulator has no such error term", file=sys.stderr)
                    continue
                tasks.append({"scenario": scen, "device": f"0x{DEVICE_BASE + k:08X}", "seed": 1000 + k,
                              "cal_seed": 5000 + k, "variant": var, "label": args.label,
                              "duration_s": args.duration, "cache": str(args.cache), "settings": settings})
    return tasks


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--devices", type=int, default=20, help="simulated units (default 20)")
    ap.add_argument("--first-device", type=int, default=0, help="index of the first unit (default 0)")
    ap.add_argument("--scenarios", nargs="+", default=["mixed-30min", "long"], help="registered scenarios")
    ap.add_argument("--variants", nargs="+", default=list(MAIN_VARIANTS) + list(ABLATIONS),
                    help=f"of {', '.join(MAIN_VARIANTS + tuple(ABLATIONS))}")
    ap.add_argument("--ablation-devices", type=int, default=None,
                    help="run the ablations on the first N devices only (default: all)")
    ap.add_argument("--duration", type=float, default=None, help="walk length in s (default: the scenario's)")
    ap.add_argument("--quick", action="store_true", help="3 devices, 300 s walks, mixed-30min only")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="process settings override, dotted key, JSON value (repeatable)")
    ap.add_argument("--label", default="", help="name of this run in the JSON rows")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes (default: all cores)")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "bootnav-mission-cache")
    ap.add_argument("--json", type=Path, default=None, help="write every row and the summary here")
    args = ap.parse_args(argv)
    if args.quick:
        args.devices, args.duration = min(args.devices, 3), args.duration or 300.0
        if args.scenarios == ["mixed-30min", "long"]:
            args.scenarios = ["mixed-30min"]
    if args.ablation_devices is None:
        args.ablation_devices = args.devices
    args.cache.mkdir(parents=True, exist_ok=True)
    tasks = build_tasks(args)
    # calibration sessions first (they are shared by no other task, but each must be made once per device)
    t0 = time.perf_counter()
    rows = []
    print(f"{len(tasks)} walks on {args.jobs} worker(s); cache {args.cache}", file=sys.stderr)
    with get_context("spawn").Pool(max(1, args.jobs)) as pool:
        for i, row in enumerate(pool.imap_unordered(run_task, tasks), 1):
            rows.append(row)
            msg = row.get("error") or f"final {row.get('final_h_m', float('nan')):.2f} m"
            print(f"[{i}/{len(tasks)}] {row['scenario']} {row['device']} {row['variant']}: {msg} "
                  f"({row.get('wall_s', 0):.0f} s)", file=sys.stderr, flush=True)
    order = {(t["scenario"], t["device"], t["variant"]): i for i, t in enumerate(tasks)}
    rows.sort(key=lambda r: order[(r["scenario"], r["device"], r["variant"])])
    summary = summarize(rows)
    print_table(summary)
    print(f"\n{len(rows)} walks in {time.perf_counter() - t0:.0f} s; yaw aligned over the first {ALIGN_M:g} m; "
          f"label {args.label!r}; settings overrides {parse_set(args.set)}")
    if args.json:
        from bootnav.core import atomic
        from bootnav.core.jsonio import to_jsonable

        atomic.write_text(args.json, json.dumps(to_jsonable({"label": args.label, "argv": sys.argv[1:],
                                                             "rows": rows, "summary": summary}), indent=1) + "\n")
        print(f"rows and summary: {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
