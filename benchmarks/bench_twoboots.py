"""Two boots vs one on simulated truth: each foot alone, their common mode, the fused feet and the walker.

For each seed: ``bootnav.simulator.twoboots`` simulates both feet of one walker on the ``mixed-walk``
scenario (walking at 90-125 steps/min with 1.0-1.6 m strides, turns, standing, shuffling, stair flights up
and down; no running, whose steps exceed the anthropometric bound) for ``--duration`` s with the default
MPU6050 profile (turn-on biases, noise, bias walks, independent per foot); ``process_two_boots`` runs each
foot alone and both fused (default ``TwoBootSettings`` except the start posture, which the simulator knows:
the right sensor 0.70 m ahead and 0.15 m right of the left one along the left sensor's axis).

**Why the common mode** (docs/twoboots.md): the separation bound is a function of p_L − p_R only, so it
observes the DIFFERENCE of the feet's errors; a common error (both paths turned about the vertical, or scaled,
together) satisfies every bound. The fused feet's errors should therefore end near the common mode of the
feet as the fusion received them, c = (e_L + e_R')/2 (e_R': the right foot alone turned into the common frame
by the frame alignment, which adds its own yaw error), and the fused walker can beat both feet only when
|c| < min(|e_L|, |e_R|), i.e. when the feet erred in opposite directions.

Printed per seed (final values; horizontal positions of each path from its own start, yaw of the sensor
attitude with each foot's single-foot start value removed, signed, counter-clockwise positive):

* **yaw**, deg: left alone, right alone (own frame), right as fed to the fusion (+ the frame alignment's
  error), common mode (left + right-as-fed)/2, fused left, fused right, walker (mean of the fused feet);
* **position**, m: |e_L|, |e_R| (own frame), |c| (c from left and right-as-fed: the midpoint of the two single
  paths), |e_W| of the walker (midpoint of the fused feet) and |e_W − c|; max |r| of the fused feet's relative
  error r = (p̂_L − p̂_R) − (p_L − p_R) at the constraint checks (bounded by γ + the true separation).

Summary lines: the walker vs each foot (mean over seeds, how often below both / below the mean), and whether
the common mode predicts it: on how many seeds the walker is below both feet where |c| is, and the mean
|e_W − c| against the mean |c|.

Usage: ``python benchmarks/bench_twoboots.py [--seeds 10] [--duration 600] [--engine fast]``. Prints;
asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np


def yaw_rad(q_nb: np.ndarray) -> np.ndarray:
    """ZYX yaw of wxyz quaternions (N, 4), unwrapped."""
    from bootnav.core.rotations import euler_zyx_from_quat

    return np.unwrap(euler_zyx_from_quat(q_nb)[:, 2])


def error_path(est: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Horizontal error (N, 2) of a path against the truth, both taken from their own starts, m."""
    return ((est - est[0]) - (true - true[0]))[:, :2]


def rms(d: np.ndarray) -> float:
    """RMS over time of a series (N,) or of the length of vectors (N, k)."""
    d2 = d * d if d.ndim == 1 else np.sum(d * d, axis=1)
    return float(np.sqrt(np.mean(d2)))


def run_seed(seed: int, duration_s: float, workdir: Path, engine: str = "fast", two_boot: dict | None = None) -> dict:
    """Signed final errors of each foot alone, their common mode, the fused feet and the walker (one walk)."""
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.twoboots import TwoBootSettings, process_two_boots
    from bootnav.postproc.twoboots.run import single_in_common_frame
    from bootnav.simulator.twoboots import (WalkerGeometry, max_separation_m, sensor_position_n, simulate_two_boots,
                                            write_two_boots)

    geo = WalkerGeometry()
    sims = simulate_two_boots("mixed-walk", seed=seed, duration_s=duration_s, geometry=geo)
    paths = write_two_boots(sims, workdir / f"walk{seed}.h5", force=True)
    tb = TwoBootSettings.from_dict({"right_start_m": (geo.step_length_m, -geo.step_width_m),
                                    "right_start_frame": "left-sensor", **(two_boot or {})})
    settings = ProcessSettings.from_dict({"filter": {"engine": engine}})
    res = process_two_boots(*paths, settings, two_boot=tb)
    out: dict = {"seed": seed, "active": res.fused.n_active, "checks": res.fused.n_checks, "gated": res.fused.n_gated,
                 "frame_yaw_deg": math.degrees(res.heading["yaw_rad"]),
                 "distance_m": float(np.sum(sims["left"].steps["length_m"])),
                 "true_max_sep_m": max_separation_m(sims), "gamma_m": tb.max_separation_m}
    origin = sensor_position_n(sims["left"])[0]
    t = res.walker_t_s
    truth, e_pos, e_yaw = {}, {}, {}
    for label in ("left", "right"):
        sim, single, fused = sims[label], res.single[label], getattr(res.fused, label)
        idx = np.arange(sim.n)[single.index]
        p_true = sensor_position_n(sim)[idx] - origin
        y_true = yaw_rad(sim.truth["q_nb"][idx])
        e_single = yaw_rad(single.q_nb) - y_true
        y0 = e_single[0]  # the filter's and the simulator's yaw conventions at the start, same for both paths
        fed = single_in_common_frame(res, label)
        y_fed = e_single + (res.heading["yaw_rad"] if label == "right" else 0.0)
        truth[label] = (fused.t_s, p_true)

        def at_t(a, ts=fused.t_s):
            return np.column_stack([np.interp(t, ts, a[:, j]) for j in range(a.shape[1])]) if a.ndim > 1 \
                else np.interp(t, ts, a)

        e_pos[label] = {"single": at_t(error_path(single.pos_n, p_true)), "fed": at_t(error_path(fed, p_true)),
                        "fused": at_t(error_path(fused.pos_n, p_true))}
        e_yaw[label] = {"single": at_t(e_single - y0), "fed": at_t(y_fed - y0),
                        "fused": at_t(yaw_rad(fused.q_nb) - y_true - y0)}
    common = 0.5 * (e_pos["left"]["fed"] + e_pos["right"]["fed"])
    walker = 0.5 * (e_pos["left"]["fused"] + e_pos["right"]["fused"])
    common_yaw = 0.5 * (e_yaw["left"]["fed"] + e_yaw["right"]["fed"])
    walker_yaw = 0.5 * (e_yaw["left"]["fused"] + e_yaw["right"]["fused"])
    rel = e_pos["left"]["fused"] - e_pos["right"]["fused"]  # (p̂_L − p̂_R) − (p_L − p_R), horizontal
    deg = math.degrees
    out.update(
        yaw_left=deg(e_yaw["left"]["single"][-1]), yaw_right=deg(e_yaw["right"]["single"][-1]),
        yaw_right_fed=deg(e_yaw["right"]["fed"][-1]), yaw_common=deg(common_yaw[-1]),
        yaw_fused_left=deg(e_yaw["left"]["fused"][-1]), yaw_fused_right=deg(e_yaw["right"]["fused"][-1]),
        yaw_walker=deg(walker_yaw[-1]),
        yaw_rms_left=deg(rms(e_yaw["left"]["single"])), yaw_rms_right=deg(rms(e_yaw["right"]["single"])),
        yaw_rms_common=deg(rms(common_yaw)), yaw_rms_walker=deg(rms(walker_yaw)),
        pos_left=float(np.hypot(*e_pos["left"]["single"][-1])), pos_right=float(np.hypot(*e_pos["right"]["single"][-1])),
        pos_common=float(np.hypot(*common[-1])), pos_walker=float(np.hypot(*walker[-1])),
        pos_walker_minus_common=float(np.hypot(*(walker[-1] - common[-1]))),
        pos_rms_left=rms(e_pos["left"]["single"]), pos_rms_right=rms(e_pos["right"]["single"]),
        pos_rms_common=rms(common), pos_rms_walker=rms(walker),
        rel_single_final=float(np.hypot(*(e_pos["left"]["fed"][-1] - e_pos["right"]["fed"][-1]))),
        rel_fused_final=float(np.hypot(*rel[-1])), rel_fused_max=float(np.max(np.hypot(rel[:, 0], rel[:, 1]))))
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=600.0, help="walk length, s (default 600)")
    ap.add_argument("--engine", choices=("fast", "reference"), default="fast",
                    help="filter engine of both feet (reference: a Python loop, ~100x slower)")
    ap.add_argument("--two-boot", default="{}", metavar="JSON",
                    help="TwoBootSettings fields to change, e.g. '{\"instants\": \"double-support\"}'")
    args = ap.parse_args(argv)
    two_boot = json.loads(args.two_boot)
    rows = []
    print(f"mixed-walk, {args.duration:.0f} s, seeds {args.first_seed}-{args.first_seed + args.seeds - 1}, "
          f"{args.engine} engine, two-boot settings {two_boot or 'default'}; final errors. yaw deg signed (R' = right as fed: + frame alignment), "
          "position m (c = common mode of L and R', W = walker), r = fused relative error")
    print(f"{'seed':>4} {'dist':>4} | {'yaw L':>6} {'R':>6} {'R_fed':>6} {'common':>6} {'fusedL':>6} {'fusedR':>6} "
          f"{'walker':>6} | {'|e_L|':>5} {'|e_R|':>5} {'|c|':>5} {'|e_W|':>5} {'|W-c|':>5} | {'r_alone':>7} "
          f"{'r_fused':>7} {'max r':>5} | {'upd':>7} {'time':>5}")
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            t0 = time.perf_counter()
            r = run_seed(seed, args.duration, Path(tmp), args.engine, two_boot)
            rows.append(r)
            print(f"{seed:4d} {r['distance_m']:4.0f} | {r['yaw_left']:6.1f} {r['yaw_right']:6.1f} "
                  f"{r['yaw_right_fed']:6.1f} {r['yaw_common']:6.1f} {r['yaw_fused_left']:6.1f} "
                  f"{r['yaw_fused_right']:6.1f} {r['yaw_walker']:6.1f} | {r['pos_left']:5.2f} {r['pos_right']:5.2f} "
                  f"{r['pos_common']:5.2f} {r['pos_walker']:5.2f} {r['pos_walker_minus_common']:5.2f} | "
                  f"{r['rel_single_final']:7.2f} {r['rel_fused_final']:7.2f} {r['rel_fused_max']:5.2f} | "
                  f"{r['active']:3d}/{r['checks']:<4d} {time.perf_counter() - t0:4.0f}s", flush=True)
    n = len(rows)

    def col(key):
        return np.array([r[key] for r in rows])

    for name, kind in (("position final", "pos"), ("position RMS", "pos_rms"), ("yaw final", "yaw"),
                       ("yaw RMS", "yaw_rms")):
        left, right, walker, common = (np.abs(col(f"{kind}_{k}")) for k in ("left", "right", "walker", "common"))
        alone = np.column_stack([left, right])
        print(f"{name:15s}: mean alone {alone.mean():.3f} (left {left.mean():.3f}, right {right.mean():.3f}), walker "
              f"{walker.mean():.3f} = {walker.mean() / alone.mean():.2f} x, common mode {common.mean():.3f}; walker "
              f"below both feet {int(np.sum(walker < alone.min(axis=1)))}/{n} (common mode below both "
              f"{int(np.sum(common < alone.min(axis=1)))}/{n}), below their mean "
              f"{int(np.sum(walker < alone.mean(axis=1)))}/{n}, below the worse {int(np.sum(walker < alone.max(axis=1)))}/{n}")
    wc, c = col("pos_walker_minus_common"), col("pos_common")
    print(f"walker - common mode (final position): mean {wc.mean():.2f} m (max {wc.max():.2f}) against mean |c| "
          f"{c.mean():.2f} m; yaw walker - common: mean |.| "
          f"{np.mean(np.abs(col('yaw_walker') - col('yaw_common'))):.2f} deg against mean |common| "
          f"{np.mean(np.abs(col('yaw_common'))):.2f} deg")
    print(f"constraint: {int(col('active').sum())} updates at {int(col('checks').sum())} checks, "
          f"{int(col('gated').sum())} of them gated")
    print(f"relative error of the feet (final): alone {col('rel_single_final').mean():.2f} m mean, fused "
          f"{col('rel_fused_final').mean():.2f} m; largest fused |r| over the walk {col('rel_fused_max').max():.2f} m "
          f"(gamma {rows[0]['gamma_m']:.2f} m + true separation <= {col('true_max_sep_m').max():.2f} m)")


if __name__ == "__main__":
    main()
