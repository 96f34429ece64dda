"""Are the strides' uncertainty ellipses honest? (issue 24, point 5)

For simulated 30-min ``building`` missions (datasheet profile uncalibrated, and ``mpu6050-noise-only``: a unit
with no scale or cross-axis error, what a perfect calibration leaves), the share of strides whose true
footprint lies inside the stride's 1σ / 2σ / 3σ horizontal ellipse (``steps.csv`` ellipse columns); a
consistent 2-D Gaussian gives 39.3 / 86.5 / 98.9 %. ``overconfidence``: median Mahalanobis distance over its
consistent value √(2 ln 2) (1 = honest, > 1 ellipses too small). Columns ``filter`` = the filter's covariance
alone (``ellipse_scale_sigma = ellipse_cross_axis_rad = 0``), ``+scale`` = the default (``postproc.ellipses``:
the scale and cross-axis errors the filter does not model; for the ``--calibrated`` profiles the calibrated σ,
as if ``bootnav calibrate`` had been applied). The estimate is put in the truth's frame by the
true initial yaw (exact: nothing fitted). Prints a table; asserts nothing.

    nice -n 10 .venv/bin/python benchmarks/ellipse_consistency.py --seeds 4001-4020 \
        --profiles mpu6050-16g-2000dps mpu6050-noise-only
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from building_mission import seeds_arg  # noqa: E402  (benchmarks/ is the script's directory)
from floors_mission import _sim, ellipse_errors


def run_one(path: Path, extra: bool, calibrated: bool = False) -> dict:
    from bootnav.logger.recording import load
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.strides import footprints, stride_footprints

    s = ProcessSettings()
    if not extra:
        s.ellipse_scale_sigma = s.ellipse_cross_axis_rad = s.ellipse_calibrated_sigma = 0.0
    elif calibrated:  # a unit without scale or cross-axis error stands for a calibrated one: the calibrated σ
        s.ellipse_scale_sigma = s.ellipse_cross_axis_rad = s.ellipse_calibrated_sigma
    r = process(path, s)
    truth = load(path).truth
    pos_true = np.asarray(truth["pos_n_m"], float)
    _, fp = footprints(r.t_s, r.pos_n, r.stance)
    _, fp_t = footprints(r.t_s, pos_true, r.stance)
    keep = stride_footprints(fp, s.selftune.min_stride_m)[1:]
    steps = r.steps
    dx, dy, d2 = ellipse_errors(r, steps, truth, pos_true, fp_t[keep])
    return {"in1": 100 * np.mean(d2 <= 1), "in2": 100 * np.mean(d2 <= 4), "in3": 100 * np.mean(d2 <= 9),
            "oc": float(np.median(np.sqrt(d2)) / np.sqrt(2 * np.log(2))), "final_m": float(np.hypot(dx[-1], dy[-1])),
            "major_final_m": float(steps["ellipse_major_m"][-1])}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=seeds_arg, default=seeds_arg("4001-4005"))
    ap.add_argument("--profiles", nargs="+", default=["mpu6050-16g-2000dps", "mpu6050-noise-only"])
    ap.add_argument("--duration", type=float, default=1800.0)
    ap.add_argument("--cache", type=Path, default=Path("/tmp/floors-sims"))
    ap.add_argument("--calibrated", nargs="*", default=["mpu6050-noise-only"],
                    help="profiles processed as if a sensor calibration were applied (ellipse_calibrated_sigma)")
    a = ap.parse_args(argv)
    table = []
    for profile in a.profiles:
        for extra in (False, True):
            rows = []
            for seed in a.seeds:
                m = run_one(_sim("building", seed, profile, a.duration, a.cache), extra, profile in a.calibrated)
                rows.append(m)
                print(f"{profile} seed {seed} {'+scale' if extra else 'filter'} "
                      + " ".join(f"{k}={v:.3g}" for k, v in m.items()), flush=True)
            med = {k: float(np.median([r[k] for r in rows])) for k in rows[0]}
            pooled = np.mean([[r["in1"], r["in2"], r["in3"]] for r in rows], axis=0)
            table.append((profile, "+scale" if extra else "filter", len(rows), pooled, med))
    print("\n| profile | ellipse | missions | inside 1σ / 2σ / 3σ (%, mean over missions; 39.3 / 86.5 / 98.9 if "
          "honest) | overconfidence, median | final error / final 1σ major, median (m) |")
    print("|---|---|---|---|---|---|")
    for profile, what, n, pooled, med in table:
        print(f"| {profile} | {what} | {n} | {pooled[0]:.1f} / {pooled[1]:.1f} / {pooled[2]:.1f} | {med['oc']:.2f} | "
              f"{med['final_m']:.1f} / {med['major_final_m']:.1f} |")


if __name__ == "__main__":
    main()
