"""Hard gaits on the simulator: is any foot recording refused, which stance choice ran, how good is the path.

Simulates each scenario x sensor profile x seed (exact truth), runs ``process`` with the default settings and
the simulated truth as reference, and prints one row per run: refused or not, the stance choice, the
confidence, the distance error against the truth strides and the final horizontal error.

    .venv/bin/python benchmarks/never_refuse.py                     # the default matrix (~2 min on 2 cores)
    .venv/bin/python benchmarks/never_refuse.py --scenarios running --profiles ideal --seeds 0 1 2
    .venv/bin/python benchmarks/never_refuse.py --mocap --jobs 2   # pyshoe_vicon trials cut to start in motion

``--mocap`` runs the developer pyshoe_vicon trials whole and cut (from 1/3, 1/2 of the trial to the end, and
the middle half: recordings that start, and end, with the foot in motion, as trials cut out of longer
sessions do), with the motion-capture track as truth (METRICS.md ``armse_2d``): refused or not, the stance
choice, the confidence, the implausible-stride fraction and the error.

Prints figures; asserts nothing (``tests/test_never_refuse.py`` holds the checks).
"""

from __future__ import annotations

import argparse
import os
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

SCENARIOS = ("running", "fast-corridor", "crawl", "shuffle", "three-floors")
PROFILES = ("ideal", "mpu6050-noise-only", "mpu6050-16g-2000dps", "mpu6050-2g-250dps")


def one(args) -> dict:
    scenario, profile, seed, rate = args
    from bootnav.errors import BootnavError
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.simulator import simulate, write_h5

    res = simulate(scenario, seed=seed, profile=profile, rate_hz=rate)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "sim.h5"
        write_h5(res, path)
        row = {"scenario": scenario, "profile": profile, "seed": seed, "rate_hz": rate}
        try:
            out = process(path, ProcessSettings(reference="truth"))
        except BootnavError as exc:
            row.update(refused=True, reason=str(exc)[:120])
            return row
    nav = out.summary["navigation"]
    m = out.metrics or {}
    row.update(refused=False, choice=nav["stance_choice"], confidence=nav["confidence"],
               distance_err_pct=100.0 * m.get("distance_diff_m", float("nan")) / m.get("distance_ref_m", float("nan")),
               final_err_m=m.get("final_error_m", float("nan")),
               strides=out.summary["strides"])
    return row


def mocap_one(args) -> dict:
    """One pyshoe_vicon trial, cut to [a, b) of its samples, through ``process``; armse_2d against its truth."""
    root, trial, cut = args
    import gzip

    from bootnav.errors import BootnavError
    from bootnav.postproc.evaluate.metrics import trajectory_metrics
    from bootnav.postproc.evaluate.runner import read_csv_columns, read_imu
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    folder = Path(root) / trial
    t, acc, gyr = read_imu(folder / "imu.csv.gz")
    n = len(t)
    a, b = int(cut[0] * n), int(cut[1] * n)
    row = {"trial": trial.split("/")[-1], "cut": f"{cut[0]:.2f}-{cut[1]:.2f}"}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "imu.csv.gz"
        with gzip.open(path, "wt") as fh:
            fh.write("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n")
            np.savetxt(fh, np.column_stack([t[a:b], acc[a:b], gyr[a:b]]), delimiter=",", fmt="%.6f")
        try:
            out = process(path, ProcessSettings())
        except BootnavError as exc:
            row.update(refused=True, reason=str(exc).split(": ", 1)[-1][:120])
            return row
    tr = read_csv_columns(folder / "truth_trajectory.csv.gz")
    sel = (tr["t_s"] >= t[a]) & (tr["t_s"] <= t[b - 1])
    m = trajectory_metrics(out.t_s + t[a], out.pos_n, tr["t_s"][sel],
                           np.column_stack([tr["x_m"], tr["y_m"], tr["z_m"]])[sel])
    nav = out.summary["navigation"]
    row.update(refused=False, choice=nav["stance_choice"], confidence=nav["confidence"],
               bad=nav["implausible_stride_fraction"], armse_2d=m["armse_2d"], still=out.init.still is not None)
    return row


def mocap(root: str, jobs: int) -> int:
    import json

    man = json.loads((Path(root) / "manifest.json").read_text())
    trials = [t["path"] for t in man["trials"] if t["set"] == "pyshoe_vicon"]
    cuts = [(0.0, 1.0), (1 / 3, 1.0), (0.5, 1.0), (0.25, 0.75)]
    with ProcessPoolExecutor(jobs) as ex:
        rows = list(ex.map(mocap_one, [(root, tr, c) for tr in trials for c in cuts]))
    print("| trial | samples | refused | still start | stance choice | confidence | implausible | armse_2d m |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r["refused"]:
            print(f"| {r['trial']} | {r['cut']} | **yes**: {r['reason']} | | | | | |")
        else:
            print(f"| {r['trial']} | {r['cut']} | no | {'yes' if r['still'] else 'no'} | {r['choice']} | "
                  f"{r['confidence']:.2f} | {r['bad']:.2f} | {r['armse_2d']:.3f} |")
    for c in cuts:
        sub = [r for r in rows if r["cut"] == f"{c[0]:.2f}-{c[1]:.2f}"]
        ok = [r["armse_2d"] for r in sub if not r["refused"]]
        print(f"cut {c[0]:.2f}-{c[1]:.2f}: {sum(r['refused'] for r in sub)} of {len(sub)} refused; armse_2d mean "
              f"{np.mean(ok):.3f} m, median {np.median(ok):.3f}, worst {np.max(ok):.3f}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    ap.add_argument("--profiles", nargs="*", default=list(PROFILES))
    ap.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    ap.add_argument("--rate", type=float, default=200.0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count())
    ap.add_argument("--mocap", action="store_true", help="the pyshoe_vicon trials whole and cut (module docstring)")
    ap.add_argument("--root", default=next((str(p) for p in (Path(__file__).resolve().parents[2] / "shared" / "datasets",
                                                              Path("/work/shared/datasets")) if p.exists()), ""))
    a = ap.parse_args(argv)
    if a.mocap:
        return mocap(a.root, a.jobs)
    work = [(s, p, k, a.rate) for s in a.scenarios for p in a.profiles for k in a.seeds]
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(one, work))
    print("| scenario | profile | seed | refused | stance choice | confidence | distance err % | final err m | strides |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r["refused"]:
            print(f"| {r['scenario']} | {r['profile']} | {r['seed']} | **yes**: {r['reason']} | | | | | |")
        else:
            print(f"| {r['scenario']} | {r['profile']} | {r['seed']} | no | {r['choice']} | {r['confidence']:.2f} | "
                  f"{r['distance_err_pct']:+.1f} | {r['final_err_m']:.2f} | {r['strides']} |")
    n_ref = sum(r["refused"] for r in rows)
    print(f"\n{n_ref} of {len(rows)} runs refused")
    errs = np.array([abs(r["distance_err_pct"]) for r in rows if not r["refused"]])
    if errs.size:
        print(f"median |distance error| {np.nanmedian(errs):.1f} %, worst {np.nanmax(errs):.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
