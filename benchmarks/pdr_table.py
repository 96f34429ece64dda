"""PDR accuracy table in the style of [Bayindir2014] Tables 3–9, on the developer datasets (../shared/datasets).

Rows: carrying position (Oxford phone positions, lower back of Voisard and Mobilise-D), × speed where the
data allow (Voisard: slow < 0.9 m/s <= normal < 1.15 m/s <= fast from its truth.json walking speed).
Cells: mean count error % (sample std, ddof = 1) per detector; then F1 on step events; step-length MAE per
length model (Mobilise-D) and distance error on Voisard's 20 m out-and-back. Every figure is scored by
``bootnav.postproc.evaluate`` exactly as ``bootnav eval`` scores it (an undefined value, NaN, is left out of a
cell; a cell with none defined reads "n/a").
Runs trials in 2 processes (multiprocessing). Usage:

    .venv/bin/python benchmarks/pdr_table.py [--datasets DIR] [--detectors a,b] [--lengths a,b] [--engineered]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import defaultdict
from multiprocessing import Pool
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bootnav.postproc.pdr.evaluate import evaluate_trial, list_trials, position_of  # noqa: E402
from bootnav.postproc.pdr.pipeline import PdrSettings  # noqa: E402

DETECTORS = ["robust", "peak_group", "li", "leppakoski", "footpath", "peak_valley", "zero_crossing", "pan_tompkins",
             "template"]
LENGTHS = ["frequency_variance", "ladetto", "frequency", "renaudin", "footpath", "weinberg"]


def speed_of(trial) -> str:
    if trial.set != "voisard_ipol":
        return "-"
    tj = trial.info.get("truth_json", {})
    v = tj["distance_m"] / (tj["t_end_s"] - tj["t_start_s"])
    return "slow" if v < 0.9 else ("normal" if v < 1.15 else "fast")


def _job(args):
    trial, settings, kind = args
    row = evaluate_trial(trial, settings)
    row["kind"] = kind
    row["position"] = position_of(trial) if trial.set != "mobgap_lab" else "lower_back (mobgap)"
    if trial.set == "voisard_ipol":
        row["position"] = "lower_back (voisard)"
    row["speed"] = speed_of(trial)
    return row


def _foot_job(trial) -> dict:
    """Foot IMUs of one Voisard walk: the foot-mounted ZUPT pipeline -> strides of both feet (steps table of
    ``steps_from_foot_ins``), and the two-axis foot detector of [NKUA2009, §2.5] (literal and engineered).
    Scored by ``bootnav.postproc.evaluate`` (step events of both feet; 20 m distance per foot as ``bootnav
    eval``'s ``foot_distance_err_pct``, averaged over the feet)."""
    from bootnav.core.csvio import read_imu_csv
    from bootnav.postproc.evaluate.metrics import step_event_metrics
    from bootnav.postproc.evaluate.runner import estimate_foot, score_foot
    from bootnav.postproc.pdr.detectors import TwoAxisFootDetector
    from bootnav.postproc.pdr.foot_ins import steps_from_foot_ins

    row = {"id": trial.id, "detector": "foot_zupt", "length": "-", "error": None}
    feet = ("imu_left.csv.gz", "imu_right.csv.gz")
    for lit in (True, False):
        ta = []
        for f in feet:
            imu = read_imu_csv(trial.path / f)
            ta.append(TwoAxisFootDetector(literal=lit).detect(imu.t_s, imu.acc_mps2).t_s)
        m2 = step_event_metrics(np.concatenate(ta), trial.t_steps)
        key = "two_axis" if lit else "two_axis_eng"
        row[f"{key}_f1"], row[f"{key}_count_err_pct"] = m2["f1"], m2["count_err_pct"]
    try:
        times, dist_err = [], []
        for f in feet:
            est = estimate_foot(trial.path / f, None)
            times.append(steps_from_foot_ins(est.t_s, est.pos_n, est.stance)["t_s"])
            dist_err.append(score_foot(est, trial.path, ["out_and_back"], f)[0]["distance_err_pct"])
        row.update(step_event_metrics(np.concatenate(times), trial.t_steps))
        row["distance_err_pct"] = float(np.mean(dist_err))
    except Exception as exc:  # counted as a failure with its reason
        row["error"] = f"{type(exc).__name__}: {exc}"
    return row


def cell(values) -> str:
    v = np.asarray([x for x in values if x is not None and np.isfinite(x)], float)
    if v.size == 0:
        return "n/a"
    sd = np.std(v, ddof=1) if v.size > 1 else 0.0
    return f"{v.mean():+.2f} ({sd:.2f})"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", default=os.environ.get("BOOTNAV_DATASETS",
                                                        str(Path(__file__).resolve().parents[2] / "shared" / "datasets")))
    ap.add_argument("--detectors", default=",".join(DETECTORS))
    ap.add_argument("--lengths", default=",".join(LENGTHS))
    ap.add_argument("--engineered", action="store_true", help="seed detectors with literal=False")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--foot", action="store_true",
                    help="also run the foot-mounted ZUPT pipeline on Voisard's foot IMUs (both worlds, one walk)")
    a = ap.parse_args(argv)
    trials = list_trials(a.datasets)
    dets = [d for d in a.detectors.split(",") if d]
    lens = [x for x in a.lengths.split(",") if x]
    jobs = []
    for d in dets:
        params = {"literal": False} if a.engineered and d not in ("robust", "template", "two_axis") else {}
        jobs += [(t, PdrSettings(detector=d, detector_params=params), "detector") for t in trials]
    for L in lens:
        jobs += [(t, PdrSettings(length=L), "length") for t in trials if t.set in ("mobgap_lab", "voisard_ipol")]
    t0 = time.perf_counter()
    rows = []
    with Pool(a.processes) as pool:
        for i, r in enumerate(pool.imap_unordered(_job, jobs, chunksize=2)):
            rows.append(r)
            if (i + 1) % 25 == 0 or i + 1 == len(jobs):
                print(f"  {i + 1}/{len(jobs)} trial runs ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    failures = [r for r in rows if r["error"]]
    det_rows = [r for r in rows if r["kind"] == "detector" and not r["error"]]

    def table(metric, title, fmt=cell):
        print(f"\n### {title}\n")
        keys = sorted({(r["position"], r["speed"]) for r in det_rows})
        print("| position | speed | n | " + " | ".join(dets) + " |")
        print("|---|---|---|" + "---|" * len(dets))
        allrow = defaultdict(list)
        for pos, sp in keys:
            cells = []
            n = 0
            for d in dets:
                v = [r.get(metric) for r in det_rows if r["detector"] == d and r["position"] == pos and r["speed"] == sp]
                n = len(v)
                cells.append(fmt(v))
            print(f"| {pos} | {sp} | {n} | " + " | ".join(cells) + " |")
        for d in dets:
            v = [r.get(metric) for r in det_rows if r["detector"] == d and r["position"].startswith(tuple(
                p for p in {x["position"] for x in det_rows} if not p.startswith("lower_back")))]
            allrow[d] = v
        return allrow

    print(f"# PDR benchmark ({len(trials)} trials, {len(rows)} runs, {time.perf_counter() - t0:.1f} s, "
          f"{'engineered' if a.engineered else 'literal'} seed parameters)")
    table("count_err_pct", "Step-count error % per detector: mean (std, ddof=1) over trials")
    table("f1", "F1 of step events (+-0.25 s, one-to-one)", lambda v: cell(v).replace("+", ""))
    print("\n### Oxford phone positions, all trials: mean |count error| % / mean F1 / min F1\n")
    print("| detector | mean abs count err % | mean F1 | min F1 | diagnostic: mean abs count err % vs a truth made "
          "L/R-alternating | diagnostic: mean abs count err % inside the truth's first..last step |")
    print("|---|---|---|---|---|---|")
    for d in dets:
        ox = [r for r in det_rows if r["detector"] == d and r["set"] == "oxford_steps"]
        if ox:
            ce = np.mean([abs(r["count_err_pct"]) for r in ox])
            f1 = [r["f1"] for r in ox]
            alt = np.mean([abs(r["count_err_vs_alternating_truth_pct"]) for r in ox])
            span = np.mean([abs(r["count_err_in_truth_span_pct"]) for r in ox])
            print(f"| {d} | {ce:.2f} | {np.mean(f1):.3f} | {np.min(f1):.3f} | {alt:.2f} | {span:.2f} |")
    len_rows = [r for r in rows if r["kind"] == "length" and not r["error"]]
    print("\n### Step length (robust detector): Mobilise-D step-length MAE / bias (m); Voisard 20 m distance error %\n")
    print("| model | mobgap MAE m | mobgap bias m | voisard distance err % (std) |")
    print("|---|---|---|---|")
    for L in lens:
        mg = [r for r in len_rows if r["length"] == L and r["set"] == "mobgap_lab"]
        vo = [r for r in len_rows if r["length"] == L and r["set"] == "voisard_ipol"]
        print(f"| {L} | {np.nanmean([r.get('step_len_mae_m', np.nan) for r in mg]):.3f} | "
              f"{np.nanmean([r.get('step_len_bias_m', np.nan) for r in mg]):+.3f} | "
              f"{cell([r.get('distance_err_pct') for r in vo])} |")
    if a.foot:
        foot_rows = []
        vo = [t for t in trials if t.set == "voisard_ipol"]
        with Pool(a.processes) as pool:
            foot_rows = pool.map(_foot_job, vo)
        print("\n### Same Voisard walks: foot-mounted ZUPT strides (both feet) vs lower-back PDR (robust + "
              "frequency_variance)\n")
        print("| trials | foot ZUPT: step F1 | foot ZUPT: count err % | foot ZUPT: 20 m distance err % | "
              "foot two_axis [NKUA2009, §2.5] literal: F1 / count err % | two_axis engineered: F1 / count err % | "
              "PDR: step F1 | PDR: count err % | PDR: 20 m distance err % |")
        print("|---|---|---|---|---|---|---|---|---|")
        ok = [r for r in foot_rows if r.get("error") is None]
        ta_rows = foot_rows  # the two-axis detector does not depend on the ZUPT pipeline
        pdr = {r["id"]: r for r in det_rows if r["detector"] == "robust" and r["set"] == "voisard_ipol"}
        pl = [pdr[r["id"]] for r in ok if r["id"] in pdr]
        print(f"| {len(ok)}/{len(foot_rows)} | {cell([r['f1'] for r in ok]).lstrip('+')} | {cell([r['count_err_pct'] for r in ok])} | "
              f"{cell([r['distance_err_pct'] for r in ok])} | "
              f"{cell([r['two_axis_f1'] for r in ta_rows]).lstrip('+')} / "
              f"{cell([r['two_axis_count_err_pct'] for r in ta_rows])} | "
              f"{cell([r['two_axis_eng_f1'] for r in ta_rows]).lstrip('+')} / "
              f"{cell([r['two_axis_eng_count_err_pct'] for r in ta_rows])} | "
              f"{cell([r['f1'] for r in pl]).lstrip('+')} | "
              f"{cell([r['count_err_pct'] for r in pl])} | {cell([r.get('distance_err_pct') for r in pl])} |")
        failures += [r for r in foot_rows if r.get("error")]
    if failures:
        print("\n### Failures (counted, not skipped)\n")
        for r in failures:
            print(f"- {r['id']} {r['detector']}/{r['length']}: {r['error']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
