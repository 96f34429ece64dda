"""Hard gaits on the simulator: is any foot recording refused, which stance choice ran, how good is the path.

Simulates each scenario x sensor profile x seed (exact truth), runs ``process`` with the default settings and
the simulated truth as reference, and prints one row per run: refused or not, the stance choice, the
confidence, the distance error against the truth strides and the final horizontal error.

    .venv/bin/python benchmarks/never_refuse.py                     # the default matrix (~2 min on 2 cores)
    .venv/bin/python benchmarks/never_refuse.py --scenarios running --profiles ideal --seeds 0 1 2

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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    ap.add_argument("--profiles", nargs="*", default=list(PROFILES))
    ap.add_argument("--seeds", nargs="*", type=int, default=[0, 1, 2])
    ap.add_argument("--rate", type=float, default=200.0)
    ap.add_argument("--jobs", type=int, default=os.cpu_count())
    a = ap.parse_args(argv)
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
