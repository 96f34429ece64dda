"""PDR accuracy on the developer datasets (../shared/datasets), one fixed configuration per run; prints,
never asserts. Every figure is scored by ``bootnav.postproc.evaluate`` exactly as ``bootnav eval`` scores it
(an undefined value, NaN, is left out of a cell; a cell with none defined reads "n/a").

Sections (``--sections``, default all but ``foot``):

* ``seed002`` -- [Bayindir2014] Tables 3-9 on the paper's protocol: trials of 100 steps, phone in hand or in
  a pocket, slow / normal / fast; step-count error of the FootPath, Li and Leppäkoski detectors (literal
  parameters); total-distance error of each step-length model with Li's detector. Here the Oxford phone
  walks in hand (InHand) and in a pocket (FrontPocket, BackPocket) are cut into consecutive windows of 100
  true steps; a window counts the detections between its first and last true step (+- half a step
  interval); speed class = cadence terciles of the windows (one rule for both positions). No hand/pocket
  walk here has a known distance: the distance table uses Voisard's lower-back 20 m walks (terciles of their
  truth speed). Diagnostics (why the literal detectors miss): per position, the median over true steps of
  the largest LPF |a| - 9.8 near the step (Li's 2 m/s² height gate), upward g-crossings per true step
  (Leppäkoski's trigger), FootPath's triggers per true step. Cells: mean (sample std) [windows], as the paper
  prints them, next to the paper's value.
* ``literal`` -- why each literal detector misses its document's figure: one factor at a time (rate, filter,
  axis, units, thresholds, the former mis-reading) against the literal configuration, on the data matching
  each document (Oxford hand / pocket for [Bayindir2014] and [Lazarevskiy2021], Voisard lower back for
  [NKUA2009]); whole-walk count error between the first and last true step.
* ``detectors`` -- every detector on every PDR trial: count error and F1 per carrying position, Oxford
  summary with the truth-noise diagnostics.
* ``lengths`` -- step-length models with the robust detector: Mobilise-D MAE / bias, Voisard 20 m distance.
* ``foot`` -- the same Voisard walks with the foot-mounted ZUPT pipeline and the two-axis foot detector.

Runs trials in 2 processes (multiprocessing). Usage:

    .venv/bin/python benchmarks/pdr_table.py [--datasets DIR] [--sections seed002,literal,detectors,lengths,foot]
                                             [--detectors a,b] [--lengths a,b] [--engineered]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bootnav.postproc.evaluate.pdr import evaluate_trial, list_trials, position_of  # noqa: E402
from bootnav.postproc.pdr.pipeline import PdrSettings  # noqa: E402

DETECTORS = ["robust", "peak_group", "li", "leppakoski", "footpath", "peak_valley", "zero_crossing", "pan_tompkins",
             "template"]
LENGTHS = ["frequency_variance", "ladetto", "frequency", "renaudin", "footpath", "weinberg"]
SEED002_DETECTORS = ["footpath", "li", "leppakoski"]
SEED002_LENGTHS = ["footpath", "frequency", "renaudin", "frequency_variance"]

# [Bayindir2014] Tables 3-5 (count error %, mean (std)) and 6-9 (distance error %, Li detector)
PAPER_COUNT = {
    "footpath": {"hand": ["-23.2 (6.34)", "-0.667 (0.577)", "0 (0)"], "pocket": ["0 (3.08)", "-12.2 (12.4)", "0 (3.61)"]},
    "li": {"hand": ["-4.33 (2.31)", "-1 (0)", "-0.333 (0.577)"], "pocket": ["-1 (0)", "-0.333 (0.577)", "-6 (7.7)"]},
    "leppakoski": {"hand": ["-31 (3.61)", "-0.667 (0.577)", "-0.333 (0.577)"],
                   "pocket": ["-9.2 (7.85)", "0 (1)", "-0.333 (0.577)"]},
}
PAPER_DIST = {"footpath": ["10.2 (2.06)", "-2.68 (1.42)", "-13.7 (0.636)"],
              "frequency": ["-2.39 (0.721)", "-6.24 (0.742)", "-11.4 (0.424)"],
              "renaudin": ["3.54 (0.0849)", "-0.41 (0.579)", "-5.81 (0.212)"],
              "frequency_variance": ["-12.2 (0.866)", "-11.2 (2.2)", "-9.34 (0.399)"]}
PAPER_DIST_POCKET_FV = ["-5.1 (1.9)", "0.0897 (1.06)", "4.67 (1.53)"]
SPEEDS = ["slow", "normal", "fast"]
WINDOW = 100


def _windows(t_true):
    """(t0, t1, cadence Hz) of consecutive 100-step windows of the true steps."""
    dt = np.median(np.diff(t_true))
    out = []
    for k in range(t_true.size // WINDOW):
        s = t_true[k * WINDOW:(k + 1) * WINDOW]
        out.append((s[0] - dt / 2, s[-1] + dt / 2, (WINDOW - 1) / (s[-1] - s[0])))
    return out


def _diagnostics(trial):
    """Li's gate and Leppäkoski's trigger seen on the true steps of one trial."""
    from scipy import signal

    from bootnav.core.csvio import read_imu_csv
    from bootnav.postproc.pdr.detectors import FootPathDetector
    from bootnav.postproc.pdr.signals import butter_filter, magnitude, resample_uniform

    imu = read_imu_csv(trial.path / trial.imu_file)
    tg, a = resample_uniform(imu.t_s, imu.acc_mps2, 50.0)
    n = magnitude(a)
    taps = signal.firwin(31, 3.0, fs=50.0)
    f = signal.filtfilt(taps, [1.0], n) - 9.8
    tt = trial.t_steps
    dt = np.median(np.diff(tt))
    lo = np.searchsorted(tg, tt - dt / 2)
    hi = np.maximum(np.searchsorted(tg, tt + dt / 2), lo + 1)
    peak = np.array([f[a_:b_].max() for a_, b_ in zip(lo, hi)])
    t30, a30 = resample_uniform(imu.t_s, imu.acc_mps2, 30.0)
    lp = magnitude(butter_filter(a30, 30.0, 3.0, "low", order=1, zero_phase=False))
    inside = (t30 >= tt[0] - dt / 2) & (t30 <= tt[-1] + dt / 2)
    up = np.sum((lp[:-1] < 9.80665) & (lp[1:] >= 9.80665) & inside[1:])
    fp = FootPathDetector().detect(imu.t_s, imu.acc_mps2).t_s
    fp_in = np.sum((fp >= tt[0] - dt / 2) & (fp <= tt[-1] + dt / 2))
    return {"li_peak_median": float(np.median(peak)), "li_peak_below_2": float(np.mean(peak < 2.0)),
            "lepp_upcross_per_step": float(up / tt.size), "footpath_per_step": float(fp_in / tt.size)}


def _count_job(args):
    trial, det = args
    from bootnav.postproc.evaluate.runner import estimate_pdr

    est = estimate_pdr(trial.path / trial.imu_file, PdrSettings(detector=det))
    return trial.id, det, [(c, int(np.sum((est.step_t >= t0) & (est.step_t <= t1)))) for t0, t1, c in
                           _windows(trial.t_steps)]


def _dist_job(args):
    trial, length = args
    row = evaluate_trial(trial, PdrSettings(detector="li", length=length))
    tj = trial.info["truth_json"]
    return length, tj["distance_m"] / (tj["t_end_s"] - tj["t_start_s"]), row.get("distance_err_pct"), row["error"]



def cell1(v) -> str:
    """mean (sample std) [n] with one decimal, as the seed-002 tables print."""
    v = np.asarray([x for x in v if x is not None and np.isfinite(x)], float)
    if v.size == 0:
        return "n/a"
    return f"{v.mean():+.1f} ({np.std(v, ddof=1) if v.size > 1 else 0.0:.1f}) [{v.size}]"


def _tercile(x, bounds):
    return SPEEDS[int(np.searchsorted(bounds, x, side="right"))]


def seed002_section(trials, processes: int) -> None:
    """Section 1: [Bayindir2014] Tables 3-9 on the paper's protocol (module docstring)."""
    pos = {}
    for t in trials:
        if t.set == "oxford_steps" and t.t_steps is not None:
            p = position_of(t)
            if p == "hand" or p.endswith("pocket"):
                pos[t.id] = "hand" if p == "hand" else "pocket"
    ox = [t for t in trials if t.id in pos]
    vo = [t for t in trials if t.set == "voisard_ipol"]
    with Pool(processes) as pool:
        counts = pool.map(_count_job, [(t, d) for t in ox for d in SEED002_DETECTORS])
        diags = dict(zip([t.id for t in ox], pool.map(_diagnostics, ox)))
        dists = pool.map(_dist_job, [(t, L) for t in vo for L in SEED002_LENGTHS])
    cad = np.array([c for tid, d, w in counts if d == SEED002_DETECTORS[0] for c, _ in w])
    bounds = np.percentile(cad, [100 / 3, 200 / 3])
    print(f"# [Bayindir2014] Tables 3-9 on its protocol: {len(ox)} Oxford hand/pocket walks cut into "
          f"{cad.size} windows of {WINDOW} true steps; speed = cadence terciles "
          f"(slow < {bounds[0]:.2f} <= normal < {bounds[1]:.2f} <= fast, steps/s)\n")
    print("### Step-count error %: ours mean (std) [windows] | paper mean (std)\n")
    print("| detector | speed | hand: ours | hand: paper | pocket: ours | pocket: paper |")
    print("|---|---|---|---|---|---|")
    for d in SEED002_DETECTORS:
        for k, sp in enumerate(SPEEDS):
            cells = []
            for where in ("hand", "pocket"):
                v = [100.0 * (n - WINDOW) / WINDOW for tid, dd, w in counts if dd == d and pos[tid] == where
                     for c, n in w if _tercile(c, bounds) == sp]
                cells += [cell1(v), PAPER_COUNT[d][where][k]]
            print(f"| {d} | {sp} | " + " | ".join(cells) + " |")
    print("\n### Why (measured on the true steps; per position, mean over walks)\n")
    print("| position | walks | Li: median peak of LPF\\|a\\| - 9.8 (m/s²) | Li: share of steps below the 2 m/s² "
          "gate | Leppäkoski: g up-crossings per step | FootPath: triggers per step |")
    print("|---|---|---|---|---|---|")
    for where in ("hand", "pocket"):
        ds = [diags[t] for t in diags if pos[t] == where]
        print(f"| {where} | {len(ds)} | {np.mean([x['li_peak_median'] for x in ds]):.2f} | "
              f"{np.mean([x['li_peak_below_2'] for x in ds]):.2f} | "
              f"{np.mean([x['lepp_upcross_per_step'] for x in ds]):.2f} | "
              f"{np.mean([x['footpath_per_step'] for x in ds]):.2f} |")
    vs = np.array([s for L, s, e, err in dists if L == SEED002_LENGTHS[0]])
    vb = np.percentile(vs, [100 / 3, 200 / 3])
    print(f"\n### Total-distance error % with Li's detector: Voisard lower back, 20 m walks, speed terciles "
          f"(slow < {vb[0]:.2f} <= normal < {vb[1]:.2f} <= fast m/s) | paper (in hand; Table 9 also pocket)\n")
    print("| model | speed | ours (lower back) | paper hand | paper pocket |")
    print("|---|---|---|---|---|")
    for L in SEED002_LENGTHS:
        for k, sp in enumerate(SPEEDS):
            v = [e for LL, s, e, err in dists if LL == L and err is None and _tercile(s, vb) == sp]
            pk = PAPER_DIST_POCKET_FV[k] if L == "frequency_variance" else "-"
            print(f"| {L} | {sp} | {cell1(v)} | {PAPER_DIST[L][k]} | {pk} |")
    fails = [(L, err) for L, s, e, err in dists if err]
    if fails:
        print("\nFailures (counted, not skipped):", fails)


# Section literal: one factor changed at a time against the literal configuration (the documents' values
# and the LODO-chosen open values), on the data matching each document: (detector, condition set,
# variant label, parameter overrides). Conditions: Oxford hand / pocket walks ([Bayindir2014], phone in hand
# or pocket; [Lazarevskiy2021], phone in hand), Voisard lower back ([NKUA2009], waist belt).
LITERAL_VARIANTS = [
    ("footpath", "oxford", "literal: 30 Hz, device z, EMA 0.5, drop > 1.5 m/s², 10-sample lockout", {}),
    ("footpath", "oxford", "threshold 0.5 m/s² (FootPath code)", {"threshold_mps2": 0.5}),
    ("footpath", "oxford", "|difference| instead of a drop", {"mode": "abs"}),
    ("footpath", "oxford", "lockout 14 samples (0.47 s)", {"lockout_samples": 14}),
    ("footpath", "oxford", "lockout 20 samples (0.67 s, FootPath code)", {"lockout_samples": 20}),
    ("footpath", "oxford", "100 Hz instead of 30 Hz (lockout 33 samples = 0.33 s)",
     {"fs_hz": 100.0, "lockout_samples": 33}),
    ("li", "oxford", "literal: 50 Hz, causal FIR 30 / 3 Hz, peak prominence >= 2 m/s², DTW <= 3", {}),
    ("li", "oxford", "zero-phase filter", {"zero_phase": True}),
    ("li", "oxford", "2 m/s² as height above 9.8 (the other reading)", {"peak_mode": "height"}),
    ("li", "oxford", "prominence gate 1 m/s²", {"min_peak_mps2": 1.0}),
    ("li", "oxford", "no DTW check", {"use_dtw": False}),
    ("li", "oxford", "DTW <= 3 as total cost instead of per aligned sample", {"dtw_norm": "none"}),
    ("li", "oxford", "100 Hz instead of 50 Hz", {"fs_hz": 100.0}),
    ("leppakoski", "oxford", "literal: 30 Hz, order-1 LPF 4 Hz, 1.7 m/s², 10 m/s³, 0.9 s", {}),
    ("leppakoski", "oxford", "LPF 3 Hz", {"cutoff_hz": 3.0}),
    ("leppakoski", "oxford", "validation past the next crossing (the former reading)", {"own_crossing": False}),
    ("leppakoski", "oxford", "both conditions at one sample", {"same_sample": True}),
    ("leppakoski", "oxford", "100 Hz instead of 30 Hz", {"fs_hz": 100.0}),
    ("peak_group", "oxford", "literal: |a| in g, clamp 1.2 g, groups 0.15 s, distance 0.3 s", {}),
    ("peak_group", "oxford", "clamp 1.1 g", {"a_filter_g": 1.1}),
    ("peak_group", "oxford", "engineered: resampled 100 Hz, 5-Hz LPF, plateau middles", {"literal": False}),
    ("pan_tompkins", "voisard", "literal: 20 Hz, MWI 20 samples (1 s)", {}),
    ("pan_tompkins", "voisard", "50 Hz with the same 20-sample MWI (0.4 s)", {"fs_hz": 50.0}),
    ("pan_tompkins", "voisard", "50 Hz, MWI 50 samples (1 s)", {"fs_hz": 50.0, "mwi_n": 50}),
    ("pan_tompkins", "voisard", "50 Hz, MWI 1 s, humps < 0.2 x local max ignored", {"fs_hz": 50.0, "mwi_n": 50,
                                                                                    "literal": False}),
    ("pan_tompkins", "voisard", "20 Hz, humps < 0.2 x local max ignored", {"literal": False}),
    ("peak_valley", "voisard", "literal: 20 Hz, sensor z in g, 0.20 / 0.15 g gates, 200-ms rescans", {}),
    ("peak_valley", "voisard", "gravity axis instead of sensor z", {"axes": "gravity"}),
    ("peak_valley", "voisard", "gates read in m/s² instead of g", {"acc_unit": "mps2"}),
    ("peak_valley", "voisard", "gravity axis, rescan every sample", {"axes": "gravity", "scan_every": 1}),
    ("zero_crossing", "voisard", "literal: 20 Hz, MA 8, 0.20 g gate", {}),
    ("zero_crossing", "voisard", "gate read in m/s² instead of g", {"acc_unit": "mps2"}),
]


def _literal_job(args):
    """Count error % of one detector variant on one walk: detections between the first and last true step
    (+- half a step interval) against the true steps."""
    trial, det, params = args
    from bootnav.postproc.evaluate.runner import estimate_pdr

    est = estimate_pdr(trial.path / trial.imu_file, PdrSettings(detector=det, detector_params=dict(params)))
    tt = trial.t_steps
    half = np.median(np.diff(tt)) / 2
    n = int(np.sum((est.step_t >= tt[0] - half) & (est.step_t <= tt[-1] + half)))
    return 100.0 * (n - tt.size) / tt.size


def literal_section(trials, processes: int) -> None:
    """Section literal: why each literal detector misses its document's figure, one factor at a time."""
    groups = {"hand": [], "pocket": [], "voisard": []}
    for t in trials:
        if t.t_steps is None:
            continue
        p = position_of(t)
        if t.set == "oxford_steps" and (p == "hand" or p.endswith("pocket")):
            groups["hand" if p == "hand" else "pocket"].append(t)
        elif t.set == "voisard_ipol":
            groups["voisard"].append(t)
    jobs, keys = [], []
    for det, cond, label, params in LITERAL_VARIANTS:
        for g in (["hand", "pocket"] if cond == "oxford" else ["voisard"]):
            if det == "peak_group" and g == "pocket":
                continue  # [Lazarevskiy2021] holds the phone in hand
            jobs += [(t, det, params) for t in groups[g]]
            keys += [(det, label, g)] * len(groups[g])
    with Pool(processes) as pool:
        errs = pool.map(_literal_job, jobs)
    cells: dict = {}
    for k, e in zip(keys, errs):
        cells.setdefault(k, []).append(e)
    print(f"\n### Literal detectors, one factor at a time: whole-walk count error %, mean (sd) [walks], "
          f"between the first and last true step ({len(groups['hand'])} Oxford hand, {len(groups['pocket'])} "
          f"pocket walks; {len(groups['voisard'])} Voisard lower-back walks)\n")
    print("| detector | variant | Oxford hand | Oxford pocket | Voisard lower back |")
    print("|---|---|---|---|---|")
    for det, cond, label, params in LITERAL_VARIANTS:
        row = [cell1(cells.get((det, label, g), [])) if (det, label, g) in cells else "-"
               for g in ("hand", "pocket", "voisard")]
        print(f"| {det} | {label.replace('|', chr(92) + '|')} | " + " | ".join(row) + " |")


def _job(args):
    trial, settings, kind = args
    row = evaluate_trial(trial, settings)
    row["kind"] = kind
    row["position"] = position_of(trial) if trial.set != "mobgap_lab" else "lower_back (mobgap)"
    if trial.set == "voisard_ipol":
        row["position"] = "lower_back (voisard)"
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
    ap.add_argument("--sections", default="seed002,literal,detectors,lengths",
                    help="comma-separated: seed002, literal, detectors, lengths, foot (module docstring)")
    a = ap.parse_args(argv)
    sections = {x for x in a.sections.split(",") if x}
    unknown = sections - {"seed002", "literal", "detectors", "lengths", "foot"}
    if unknown:
        ap.error(f"unknown section(s) {sorted(unknown)}")
    trials = list_trials(a.datasets)
    if "seed002" in sections:
        seed002_section(trials, a.processes)
    if "literal" in sections:
        literal_section(trials, a.processes)
    # the foot section compares with the robust lower-back runs
    dets = [d for d in a.detectors.split(",") if d] if "detectors" in sections else ["robust"] * ("foot" in sections)
    lens = [x for x in a.lengths.split(",") if x] if "lengths" in sections else []
    if not (dets or lens):
        return 0
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
        print("| position | n | " + " | ".join(dets) + " |")
        print("|---|---|" + "---|" * len(dets))
        for pos in sorted({r["position"] for r in det_rows}):
            cells, n = [], 0
            for d in dets:
                v = [r.get(metric) for r in det_rows if r["detector"] == d and r["position"] == pos]
                n = len(v)
                cells.append(fmt(v))
            print(f"| {pos} | {n} | " + " | ".join(cells) + " |")

    print(f"# PDR benchmark ({len(trials)} trials, {len(rows)} runs, {time.perf_counter() - t0:.1f} s, "
          f"{'engineered' if a.engineered else 'literal'} seed parameters)")
    if "detectors" in sections:
        detector_tables(dets, det_rows, table)
    if "lengths" in sections:
        length_table(lens, [r for r in rows if r["kind"] == "length" and not r["error"]])
    if "foot" in sections:
        failures += foot_table(trials, det_rows, a.processes)
    if failures:
        print("\n### Failures (counted, not skipped)\n")
        for r in failures:
            print(f"- {r['id']} {r['detector']}/{r['length']}: {r['error']}")
    return 0


def detector_tables(dets, det_rows, table) -> None:
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


def length_table(lens, len_rows) -> None:
    print("\n### Step length (robust detector): Mobilise-D step-length MAE / bias (m); Voisard 20 m distance error %\n")
    print("| model | mobgap MAE m | mobgap bias m | voisard distance err % (std) |")
    print("|---|---|---|---|")
    for L in lens:
        mg = [r for r in len_rows if r["length"] == L and r["set"] == "mobgap_lab"]
        vo = [r for r in len_rows if r["length"] == L and r["set"] == "voisard_ipol"]
        print(f"| {L} | {np.nanmean([r.get('step_len_mae_m', np.nan) for r in mg]):.3f} | "
              f"{np.nanmean([r.get('step_len_bias_m', np.nan) for r in mg]):+.3f} | "
              f"{cell([r.get('distance_err_pct') for r in vo])} |")


def foot_table(trials, det_rows, processes) -> list:
    """Section foot; returns the failed rows."""
    vo = [t for t in trials if t.set == "voisard_ipol"]
    with Pool(processes) as pool:
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
    return [r for r in foot_rows if r.get("error")]


if __name__ == "__main__":
    sys.exit(main())
