"""Two boots vs one: heading and position errors of the fused walker against each foot alone (simulated truth).

For each seed: ``bootnav.simulator.twoboots`` simulates both feet of one walker on the ``mixed-walk``
scenario (walking at 90-125 steps/min with 1.0-1.6 m strides, turns, standing, shuffling, stair flights up
and down; no running, whose steps exceed the anthropometric bound) for ``--duration`` s with the default
MPU6050 profile (turn-on biases, noise, bias walks, independent per foot); ``process_two_boots`` runs each
foot alone and both fused (default ``TwoBootSettings`` except the start posture, which the simulator knows:
the right sensor 0.70 m ahead and 0.15 m right of the left one along the left sensor's axis).

Printed per seed, horizontal errors against the exact truth, every path from its own start:

* **each foot alone**: position error at the end and RMS over the walk, m; yaw error at the end and RMS, deg
  (the sensor's attitude, which carries the heading of the path);
* **fused walker**: the midpoint of the two fused feet against the midpoint of the two true sensors, and the
  mean of the two fused feet's yaw errors (the walker's heading).

Usage: ``python benchmarks/bench_twoboots.py [--seeds 10] [--duration 600]``. Prints; asserts nothing.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np


def yaw_rad(q_nb: np.ndarray) -> np.ndarray:
    """ZYX yaw of wxyz quaternions (N, 4), unwrapped."""
    from bootnav.core.rotations import euler_zyx_from_quat

    return np.unwrap(euler_zyx_from_quat(q_nb)[:, 2])


def horizontal_errors(est: np.ndarray, true: np.ndarray) -> tuple[float, float]:
    """(final, RMS) horizontal distance between two paths taken from their own starts, m."""
    e = (est - est[0]) - (true - true[0])
    d = np.hypot(e[:, 0], e[:, 1])
    return float(d[-1]), float(np.sqrt(np.mean(d * d)))


def angle_errors(err_rad: np.ndarray) -> tuple[float, float]:
    """(final, RMS) of a yaw error series, deg (its value at the start removed: both are defined there)."""
    e = np.degrees(err_rad - err_rad[0])
    return float(abs(e[-1])), float(np.sqrt(np.mean(e * e)))


def run_seed(seed: int, duration_s: float, workdir: Path) -> dict:
    """Errors of each foot alone and of the fused walker for one simulated walk."""
    from bootnav.postproc.twoboots import TwoBootSettings, process_two_boots
    from bootnav.simulator.twoboots import WalkerGeometry, sensor_position_n, simulate_two_boots, write_two_boots

    geo = WalkerGeometry()
    sims = simulate_two_boots("mixed-walk", seed=seed, duration_s=duration_s, geometry=geo)
    paths = write_two_boots(sims, workdir / f"walk{seed}.h5", force=True)
    tb = TwoBootSettings(right_start_m=(geo.step_length_m, -geo.step_width_m), right_start_frame="left-sensor")
    res = process_two_boots(*paths, two_boot=tb)
    out: dict = {"seed": seed, "active": res.fused.n_active, "checks": res.fused.n_checks,
                 "frame_yaw_deg": math.degrees(res.heading["yaw_rad"]),
                 "distance_m": float(np.sum(sims["left"].steps["length_m"]))}
    origin = sensor_position_n(sims["left"])[0]
    truth_abs, yaw_err_fused = {}, []
    for label in ("left", "right"):
        sim, single, fused = sims[label], res.single[label], getattr(res.fused, label)
        idx = np.arange(sim.n)[single.index]
        p_true = sensor_position_n(sim)[idx] - origin
        y_true = yaw_rad(sim.truth["q_nb"][idx])
        truth_abs[label] = (sim.truth["t_s"][idx], p_true)
        out[f"{label}_pos"] = horizontal_errors(single.pos_n, p_true)
        out[f"{label}_yaw"] = angle_errors(yaw_rad(single.q_nb) - y_true)
        out[f"{label}_fused_pos"] = horizontal_errors(fused.pos_n, p_true)
        yaw_err_fused.append(np.interp(res.walker_t_s, fused.t_s, yaw_rad(fused.q_nb) - y_true))
    t_l, p_l = truth_abs["left"]
    t_r, p_r = truth_abs["right"]
    walker_true = 0.5 * (p_l + np.column_stack([np.interp(t_l, t_r, p_r[:, j]) for j in range(3)]))
    out["walker_pos"] = horizontal_errors(res.walker_pos_n, walker_true)
    out["walker_yaw"] = angle_errors(0.5 * (yaw_err_fused[0] + yaw_err_fused[1]))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=600.0, help="walk length, s (default 600)")
    args = ap.parse_args(argv)
    rows = []
    print(f"mixed-walk, {args.duration:.0f} s, seeds {args.first_seed}-{args.first_seed + args.seeds - 1}; "
          "horizontal position error final / RMS (m), yaw error final / RMS (deg)")
    print(f"{'seed':>4} {'dist m':>7} | {'left alone':>23} | {'right alone':>23} | {'fused walker':>23} | "
          f"{'updates':>9} {'frame°':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            t0 = time.perf_counter()
            r = run_seed(seed, args.duration, Path(tmp))
            rows.append(r)

            def cell(pos, yaw):
                return f"{pos[0]:5.2f}/{pos[1]:5.2f} {yaw[0]:5.1f}/{yaw[1]:5.1f}"

            print(f"{seed:4d} {r['distance_m']:7.0f} | {cell(r['left_pos'], r['left_yaw'])} | "
                  f"{cell(r['right_pos'], r['right_yaw'])} | {cell(r['walker_pos'], r['walker_yaw'])} | "
                  f"{r['active']:4d}/{r['checks']:<4d} {r['frame_yaw_deg']:6.2f}  [{time.perf_counter() - t0:.0f} s]",
                  flush=True)
    for name, key in (("position final", ("pos", 0)), ("position RMS", ("pos", 1)), ("yaw final", ("yaw", 0)),
                      ("yaw RMS", ("yaw", 1))):
        kind, i = key
        alone = np.array([[r[f"left_{kind}"][i], r[f"right_{kind}"][i]] for r in rows])
        fused = np.array([r[f"walker_{kind}"][i] for r in rows])
        below_both = int(np.sum(fused < alone.min(axis=1)))
        below_mean = int(np.sum(fused < alone.mean(axis=1)))
        print(f"{name:15s}: mean alone {alone.mean():.3f} (left {alone[:, 0].mean():.3f}, right "
              f"{alone[:, 1].mean():.3f}), fused {fused.mean():.3f} = {fused.mean() / alone.mean():.2f} x; fused below "
              f"both feet in {below_both}/{len(rows)} seeds, below their mean in {below_mean}/{len(rows)}")


if __name__ == "__main__":
    main()
