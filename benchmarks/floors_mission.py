"""Height by floors and uncertainty ellipses on simulated missions (issue 24, points 3 and 5).

For each scenario and seed: simulate (datasheet profile, uncalibrated: no calibration file applied), process
with the level-stride height hold off and on (``FilterSettings.level_height``), and print per run

* ``within_1.5m_pct``: share of the true stance samples whose estimated height is within 1.5 m of the truth
  (both start at 0; height is never rotated or scaled);
* ``max_dz_err_m``, ``final_dz_err_m``: largest and last height error on those samples, m;
* ``floor_ok_pct``: share of strides whose ``floor`` column equals the true floor (the building scenario's
  true storey; elsewhere the same rule, ``strides.floor_levels``, on the true footprint heights);
* ``in_1sigma_pct`` / ``in_2sigma_pct``: share of strides whose true footprint lies inside the stride's
  1σ / 2σ horizontal ellipse (39.3 % / 86.5 % for a consistent 2-D Gaussian); the estimate is turned into the
  truth's frame by the true initial yaw (exact: the filter's frame is the start's heading), nothing fitted;
  ``overconfidence``: median Mahalanobis distance / 1.177 (its value for a consistent 2-D Gaussian);
* ``final_h_err_m``: horizontal error of the last stride.

Configurations (``--configs``): ``off`` = height integrated freely, ``hold`` = the level-stride height hold
(``FilterSettings.level_height``), ``on`` = hold + storeys (``ProcessSettings.floor_storeys``; the default).

Usage (nice, one job: the machine is shared)::

    nice -n 10 .venv/bin/python benchmarks/floors_mission.py --scenario mixed-30min --seeds 101 102 \
        --duration 1800 [--profile mpu6050-16g-2000dps] [--cache /tmp/floors-sims]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np


def _sim(scenario: str, seed: int, profile: str, duration: float | None, cache: Path) -> Path:
    from bootnav.simulator import simulate, write_h5

    cache.mkdir(parents=True, exist_ok=True)
    out = cache / f"{scenario}-{seed}-{profile}-{duration or 0:g}.h5"
    if not out.exists():
        res = simulate(scenario, seed=seed, profile=profile, duration_s=duration)
        tmp = out.with_suffix(".tmp.h5")
        write_h5(res, tmp)
        tmp.rename(out)
    return out


CONFIGS = {"off": dict(level_height=False, storeys=False), "hold": dict(level_height=True, storeys=False),
           "on": dict(level_height=True, storeys=True)}


def run_one(path: Path, config: str) -> dict:
    """One run of ``process`` with the configuration ``config`` (``CONFIGS``) and its figures."""
    from bootnav.logger.recording import load
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.strides import floor_levels, floor_signal, footprints, stride_footprints

    s = ProcessSettings()
    s.filter.level_height = CONFIGS[config]["level_height"]
    s.floor_storeys = CONFIGS[config]["storeys"]
    t0 = time.perf_counter()
    r = process(path, s)
    run_s = time.perf_counter() - t0
    truth = load(path).truth
    pos_true = np.asarray(truth["pos_n_m"], float)
    st_true = np.asarray(truth["stance"], bool)
    e = np.abs(r.pos_n[:, 2] - pos_true[:, 2])[st_true]
    out = {"within_1.5m_pct": float(100.0 * np.mean(e <= 1.5)), "max_dz_err_m": float(e.max()),
           "final_dz_err_m": float(e[-1])}
    # strides: the kept footprints of the estimate, the truth's over the same stance phases
    _, fp = footprints(r.t_s, r.pos_n, r.stance)
    _, fp_t = footprints(r.t_s, pos_true, r.stance)
    keep = stride_footprints(fp, s.selftune.min_stride_m)[1:]
    steps = r.steps
    fs = s.floor_settings()
    if "storey" in truth:  # the building scenario's true storey per sample
        idx = np.searchsorted(r.t_s, steps["t_s"]).clip(0, len(r.t_s) - 1)
        true_floor = np.asarray(truth["storey"])[idx] - int(np.asarray(truth["storey"])[0])
    else:
        zt = fp_t[:, 2] - fp_t[0, 2]
        true_floor = floor_levels(floor_signal(zt, fs), fs)[keep]
    out["floor_ok_pct"] = float(100.0 * np.mean(np.asarray(steps["floor"]) == true_floor))
    # ellipses: the estimate turned into the truth's frame by the true initial yaw (the filter's nav frame is
    # the start's heading: an exact relation, nothing fitted), both from their starts
    dx, dy, d2 = ellipse_errors(r, steps, truth, pos_true, fp_t[keep])
    out["in_1sigma_pct"] = float(100.0 * np.mean(d2 <= 1.0))
    out["in_2sigma_pct"] = float(100.0 * np.mean(d2 <= 4.0))
    # overconfidence: median Mahalanobis distance over that of a consistent 2-D Gaussian, √(2 ln 2) = 1.177
    out["overconfidence"] = float(np.median(np.sqrt(d2)) / np.sqrt(2 * np.log(2)))
    out["median_major_m"] = float(np.median(steps["ellipse_major_m"]))
    out["final_h_err_m"] = float(np.hypot(dx[-1], dy[-1]))
    out["run_s"] = run_s
    return out


def ellipse_errors(r, steps, truth, pos_true, fp_true_strides):
    """Each stride's error (dx, dy) in the truth's frame (the estimate turned by the true initial yaw: the filter's
    nav frame is the start's heading, an exact relation, nothing fitted; both from their starts) and its squared
    Mahalanobis distance in the stride's ellipse."""
    from bootnav.core.rotations import euler_zyx_from_quat

    yaw0 = float(euler_zyx_from_quat(np.asarray(truth["q_nb"][0], float))[2])
    c, s_ = np.cos(yaw0), np.sin(yaw0)
    ex, ey = steps["x_m"] - r.pos_n[0, 0], steps["y_m"] - r.pos_n[0, 1]
    dx = (fp_true_strides[:, 0] - pos_true[0, 0]) - (c * ex - s_ * ey)
    dy = (fp_true_strides[:, 1] - pos_true[0, 1]) - (s_ * ex + c * ey)
    return dx, dy, _mahalanobis2(dx, dy, steps, yaw0)


def _mahalanobis2(dx, dy, steps, yaw) -> np.ndarray:
    """Squared Mahalanobis distance of (dx, dy) (truth frame) in each stride's ellipse (turned by yaw)."""
    a, b = np.asarray(steps["ellipse_major_m"]), np.asarray(steps["ellipse_minor_m"])
    th = np.asarray(steps["ellipse_orientation_rad"]) + yaw
    u = np.cos(th) * dx + np.sin(th) * dy
    v = -np.sin(th) * dx + np.cos(th) * dy
    return (u / np.maximum(a, 1e-12)) ** 2 + (v / np.maximum(b, 1e-12)) ** 2


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default="mixed-30min")
    ap.add_argument("--seeds", type=int, nargs="+", default=[101])
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--profile", default="mpu6050-16g-2000dps")
    ap.add_argument("--cache", type=Path, default=Path("/tmp/floors-sims"))
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS),
                    help="off: free height; hold: level-stride hold; on: hold + storeys (default: all)")
    a = ap.parse_args(argv)
    rows = []
    for seed in a.seeds:
        path = _sim(a.scenario, seed, a.profile, a.duration, a.cache)
        for config in a.configs:
            m = run_one(path, config)
            rows.append((seed, config, m))
            print(f"{a.scenario} seed {seed} {config:4s} " + " ".join(f"{k}={v:.3g}" for k, v in m.items()), flush=True)
    for config in a.configs:
        sel = [m for _, c, m in rows if c == config]
        if not sel:
            continue
        keys = [k for k in sel[0] if k != "run_s"]
        print(f"SUMMARY {a.scenario} {a.profile} n={len(sel)} {config}: "
              + " ".join(f"{k} median={np.median([m.get(k, np.nan) for m in sel]):.3g} "
                         f"min={np.min([m.get(k, np.nan) for m in sel]):.3g} "
                         f"max={np.max([m.get(k, np.nan) for m in sel]):.3g}" for k in keys))


if __name__ == "__main__":
    main()
