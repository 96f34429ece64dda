"""Height by floors and uncertainty ellipses on simulated missions (issue 24, points 3 and 5).

For each scenario and seed: simulate (datasheet profile, uncalibrated: no calibration file applied), process
with the level-stride height hold off and on (``FilterSettings.level_height``), and print per run

* ``within_1.5m_pct``: share of the true stance samples whose estimated height is within 1.5 m of the truth
  (both start at 0; height is never rotated or scaled);
* ``max_dz_err_m``, ``final_dz_err_m``: largest and last height error on those samples, m;
* ``floor_ok_pct`` (on): share of strides whose ``floor`` column equals the true floor (truth height rounded
  the same way, ``strides.floor_levels`` on the true footprint heights);
* ``in_1sigma_pct`` / ``in_2sigma_pct`` (on): share of strides whose true footprint lies inside the stride's
  1σ / 2σ horizontal ellipse (39.3 % / 86.5 % for a consistent 2-D Gaussian), the estimate first aligned to
  the truth as ``reference.align_to_reference`` does (translation + one rotation about z, never scaled).

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


def _true_floor_pct(r, z_true_fp) -> float:
    from bootnav.postproc.strides import floor_levels

    fs = r.settings.floor_settings()
    truth = floor_levels(z_true_fp - z_true_fp[0], fs)
    est = np.asarray(r.steps["floor"])
    return float(100.0 * np.mean(est == truth[1:])) if len(est) else float("nan")


def run_one(path: Path, level: bool) -> dict:
    from bootnav.logger.recording import load
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.reference import align_to_reference, truth_reference
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.strides import footprints

    s = ProcessSettings()
    s.filter.level_height = level
    t0 = time.perf_counter()
    r = process(path, s)
    run_s = time.perf_counter() - t0
    truth = load(path).truth
    pos_true = np.asarray(truth["pos_n_m"], float)
    st_true = np.asarray(truth["stance"], bool)
    dz = r.pos_n[:, 2] - pos_true[:, 2]
    e = np.abs(dz[st_true])
    out = {"within_1.5m_pct": float(100.0 * np.mean(e <= 1.5)), "max_dz_err_m": float(e.max()),
           "final_dz_err_m": float(e[-1]), "run_s": run_s}
    steps = r.steps
    if "floor" in steps and len(steps["t_s"]):
        _, fp_true = footprints(r.t_s, pos_true, r.stance)
        out["floor_ok_pct"] = _true_floor_pct(r, fp_true[:, 2]) if len(fp_true) == len(steps["t_s"]) + 1 else float("nan")
    if "ellipse_major_m" in steps and len(steps["t_s"]):
        ref = truth_reference(r.recording, path)
        aligned, _, yaw = align_to_reference(ref, r.t_s, r.pos_n)
        idx = np.searchsorted(r.t_s, steps["t_s"]).clip(0, len(r.t_s) - 1)
        # truth at the stride's footprint time vs the aligned estimate's footprint: rotate the stride rows too
        c, s_ = np.cos(yaw or 0.0), np.sin(yaw or 0.0)
        x0, y0 = r.pos_n[0, 0], r.pos_n[0, 1]
        ex = c * (steps["x_m"] - x0) - s_ * (steps["y_m"] - y0)
        ey = s_ * (steps["x_m"] - x0) + c * (steps["y_m"] - y0)
        _, fp_true = footprints(r.t_s, pos_true, r.stance)
        keep = _kept_footprints(r)
        tx, ty = fp_true[keep[1:], 0] - pos_true[0, 0], fp_true[keep[1:], 1] - pos_true[0, 1]
        d2 = _mahalanobis2(tx - ex, ty - ey, steps, yaw or 0.0)
        out["in_1sigma_pct"] = float(100.0 * np.mean(d2 <= 1.0))
        out["in_2sigma_pct"] = float(100.0 * np.mean(d2 <= 4.0))
        out["median_major_m"] = float(np.median(steps["ellipse_major_m"]))
        del aligned, idx
    return out


def _kept_footprints(r) -> np.ndarray:
    from bootnav.postproc.strides import footprints, stride_footprints

    _, fp = footprints(r.t_s, r.pos_n, r.stance)
    return stride_footprints(fp, r.settings.selftune.min_stride_m)


def _mahalanobis2(dx, dy, steps, yaw) -> np.ndarray:
    """Squared Mahalanobis distance of (dx, dy) (aligned frame) in each stride's ellipse (rotated by yaw)."""
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
    ap.add_argument("--only-on", action="store_true", help="skip the run with the height hold off")
    a = ap.parse_args(argv)
    rows = []
    for seed in a.seeds:
        path = _sim(a.scenario, seed, a.profile, a.duration, a.cache)
        for level in ((True,) if a.only_on else (False, True)):
            m = run_one(path, level)
            rows.append((seed, level, m))
            print(f"{a.scenario} seed {seed} level_height={'on ' if level else 'off'} "
                  + " ".join(f"{k}={v:.3g}" for k, v in m.items()), flush=True)
    for level in (False, True):
        sel = [m for _, lv, m in rows if lv == level]
        if not sel:
            continue
        keys = [k for k in sel[0] if k != "run_s"]
        print(f"SUMMARY {a.scenario} {a.profile} n={len(sel)} level_height={'on' if level else 'off'}: "
              + " ".join(f"{k} median={np.median([m.get(k, np.nan) for m in sel]):.3g} "
                         f"min={np.min([m.get(k, np.nan) for m in sel]):.3g} "
                         f"max={np.max([m.get(k, np.nan) for m in sel]):.3g}" for k in keys))


if __name__ == "__main__":
    main()
