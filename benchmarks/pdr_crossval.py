"""Leave-one-dataset-out (LODO) choice of PDR parameters over the developer PDR sets.

The rule (the same for every detector and for the robust default): for a parameter grid, for each PDR set
S in {oxford_steps, voisard_ipol, mobgap_lab} in turn, choose the grid value with the lowest objective on
the OTHER sets, then score that value on S (never seen by the choice). The objective is the mean over the
sets of each set's mean |count_err_pct| (every set weighs the same, whatever its number of trials). The
value reported for use is the one chosen on all three sets; a change is kept only if every left-out
figure improves by more than the across-trial spread (standard error of the left-out set's mean).

Trials are read once and scored by ``bootnav eval``'s scorer (``runner.score_pdr``). Robust-default goals
(issue 15): Oxford |count err| <= 0.5 % and F1 >= 0.99; Voisard lower back <= 1.5 % and F1 >= 0.98;
Mobilise-D lower back F1 >= 0.95 and step-length MAE <= 0.08 m.

Usage: .venv/bin/python benchmarks/pdr_crossval.py [--datasets DIR] [--grid NAME ...] [--processes 2] [--anatomy]
Grids: ``GRIDS`` below (the literal detectors' open values and the robust default's candidates).
``--anatomy`` prints the robust default's error anatomy instead (``anatomy``: what kind of true step it misses
and what kind of step it adds, per set, and each recording's cadence and F1).
"""

from __future__ import annotations

import argparse
import os
import sys
from multiprocessing import Pool
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bootnav.postproc.evaluate.runner import PdrEstimate, read_imu, score_pdr  # noqa: E402
from bootnav.postproc.pdr import run_pdr  # noqa: E402
from bootnav.postproc.evaluate.pdr import PDR_SETS, list_trials  # noqa: E402
from bootnav.postproc.pdr.pipeline import PdrSettings  # noqa: E402

# name -> (detector, length model, parameter name, values); the values are the physically sensible range
GRIDS = {
    # [Bayindir2014] Leppäkoski: 1st-order low-pass cut-off, not given
    "leppakoski_cutoff": ("leppakoski", {"literal": True, "own_crossing": True}, "cutoff_hz", [1.5, 2.0, 2.5, 3.0, 4.0, 5.0]),
    # FootPath: drop threshold, not in the paper (0.5 m/s^2 in the FootPath code)
    "footpath_threshold": ("footpath", {"literal": True}, "threshold_mps2", [0.5, 1.0, 1.5, 2.0, 3.0]),
    # [Lazarevskiy2021] A_LocalPeaksStep (group gap), no value in the thesis
    "peak_group_gap": ("peak_group", {"literal": True}, "local_peaks_step_s", [0.05, 0.1, 0.15, 0.2, 0.25]),
    # [Lazarevskiy2021] A_LocalDistancePeaks (minimum step spacing), within the thesis' [0.2, 1.0] s
    "peak_group_distance": ("peak_group", {"literal": True}, "local_distance_peaks_s",
                            [0.2, 0.25, 0.3, 0.35, 0.4, 0.45]),
    # [Bayindir2014] Li: "minimum peak magnitude" 2 m/s^2 as height above g or as prominence, not said
    "li_peak_mode": ("li", {"literal": True}, "peak_mode", ["height", "prominence"]),
    # [Bayindir2014] Li: the DTW distance behind the threshold 3 is not defined
    "li_dtw_norm": ("li", {"literal": True}, "dtw_norm", ["path_length", "none", "znorm"]),
    # robust default (engineered, point 4 of issue 15)
    "robust_band": ("robust", {}, "band_hz", [(0.3, 2.5), (0.3, 3.0), (0.3, 3.5), (0.3, 4.0)]),
    "robust_salience_offset": ("robust", {}, "salience_offset", [0.05, 0.1, 0.15, 0.2, 0.3]),
    "robust_interval_penalty": ("robust", {}, "interval_penalty", [0.5, 1.0, 2.0, 4.0]),
    "robust_periodicity_min": ("robust", {}, "periodicity_min", [0.3, 0.45, 0.6]),
    "robust_onset_trim": ("robust", {}, "onset_trim_fraction", [0.0, 0.3, 0.5]),
    # 2026-12-01 error anatomy: the dominant Mobilise-D miss is a mid-bout step gated by periodicity
    "robust_periodicity_window": ("robust", {}, "periodicity_window_s", [1.0, 1.5, 2.0, 2.5]),
}

_CACHE: dict = {}


def _load(trial):
    if trial.id not in _CACHE:
        _CACHE[trial.id] = read_imu(trial.path / trial.imu_file)
    return _CACHE[trial.id]


def score(trial, detector: str, params: dict, length: str = "frequency_variance") -> dict:
    """bootnav eval's PDR metrics of one trial for one detector configuration."""
    t, acc, gyro = _load(trial)
    res = run_pdr(t, acc, gyro, PdrSettings(detector=detector, detector_params=dict(params), length=length))
    est = PdrEstimate(np.asarray(res.t_s), np.asarray(res.length_m), np.column_stack([res.x_m, res.y_m]), 0.0)
    return score_pdr(est, trial.path, trial.truth)[0]


def _job(args):
    trials, detector, params = args
    return [score(tr, detector, params) for tr in trials]


def set_summary(rows: list[dict]) -> dict:
    """Mean |count err| %, its standard error, mean signed count err %, mean F1, step-length MAE."""
    ace = np.array([r["abs_count_err_pct"] for r in rows], float)
    ce = np.array([r["count_err_pct"] for r in rows], float)
    f1 = np.array([r.get("f1", np.nan) for r in rows], float)
    mae = np.array([r.get("step_len_mae_m", np.nan) for r in rows], float)
    nanmean = lambda v: float(np.nanmean(v)) if np.any(np.isfinite(v)) else float("nan")  # noqa: E731
    return {"abs_count": float(ace.mean()), "se": float(ace.std(ddof=1) / np.sqrt(ace.size)) if ace.size > 1 else 0.0,
            "count": float(ce.mean()), "f1": nanmean(f1), "mae": nanmean(mae), "n": int(ace.size)}


def evaluate_grid(by_set: dict, detector: str, base: dict, name: str, values: list, pool) -> dict:
    """{value: {set: summary}} for one parameter grid."""
    jobs, keys = [], []
    for v in values:
        for s, trials in by_set.items():
            for k in range(0, len(trials), 4):  # a few trials per job keeps the IMU cache useful
                jobs.append((trials[k:k + 4], detector, {**base, name: v}))
                keys.append((v, s))
    out: dict = {}
    for (v, s), rows in zip(keys, pool.map(_job, jobs)):
        out.setdefault(v, {}).setdefault(s, []).extend(rows)
    return {v: {s: set_summary(r) for s, r in d.items()} for v, d in out.items()}


def objective(summ: dict, sets) -> float:
    return float(np.mean([summ[s]["abs_count"] for s in sets]))


def lodo(table: dict) -> tuple[list, object]:
    """Per left-out set: (set, value chosen on the others, its left-out summary); and the all-sets choice."""
    sets = list(next(iter(table.values())))
    rows = []
    for s in sets:
        others = [o for o in sets if o != s]
        v = min(table, key=lambda x: objective(table[x], others))
        rows.append((s, v, table[v][s]))
    return rows, min(table, key=lambda x: objective(table[x], sets))


def print_grid(name: str, table: dict) -> None:
    det, _, pname, _ = GRIDS[name]
    sets = list(next(iter(table.values())))
    print(f"\n### {name}: {det}.{pname}  (per set: mean |count err| % ± s.e. / mean F1)\n")
    print("| value | " + " | ".join(sets) + " | objective (all sets) |")
    print("|---|" + "---|" * (len(sets) + 1))
    for v, d in table.items():
        print(f"| {v} | " + " | ".join(f"{d[s]['abs_count']:.2f} ± {d[s]['se']:.2f} / {d[s]['f1']:.3f}" for s in sets)
              + f" | {objective(d, sets):.2f} |")
    rows, chosen = lodo(table)
    from bootnav.postproc.pdr.detectors import DETECTORS

    cur = getattr(DETECTORS[det](**GRIDS[name][1]), pname)
    print(f"\n| left-out set | value chosen on the others | left-out mean \\|count err\\| % | left-out F1 | "
          f"left-out step-length MAE m | current value {cur}: \\|count err\\| % / F1 / MAE |")
    print("|---|---|---|---|---|---|")
    for s, v, sm in rows:
        c = table.get(cur, {}).get(s)
        ref = f"{c['abs_count']:.2f} ± {c['se']:.2f} / {c['f1']:.3f} / {c['mae']:.3f}" if c else "not in the grid"
        print(f"| {s} | {v} | {sm['abs_count']:.2f} ± {sm['se']:.2f} | {sm['f1']:.3f} | {sm['mae']:.3f} | {ref} |")
    print(f"\nchosen on all sets: {pname} = {chosen}")


def _truth_bouts(trial, tt: np.ndarray) -> list:
    """(first, last) index into the sorted true steps of each walking bout: the reference's bouts where the
    set has them (mobgap_lab), else runs of true steps less than 1.6 s apart (the detector's bout gap)."""
    from bootnav.postproc.evaluate.runner import _truth_json, read_csv_columns

    path = trial.path / "truth_walking_bouts.csv"
    if path.exists():
        c = read_csv_columns(path)
        rows = c["source"] == _truth_json(trial.path).get("step_events_reference", "INDIP")
        rows = rows if rows.any() else np.ones(rows.size, bool)
        idx = [np.nonzero((tt >= a - 0.01) & (tt <= b + 0.01))[0] for a, b in zip(c["t_start_s"][rows], c["t_end_s"][rows])]
        return [(i[0], i[-1]) for i in idx if i.size]
    br = np.r_[0, np.nonzero(np.diff(tt) > 1.6)[0] + 1, tt.size]
    return [(a, b - 1) for a, b in zip(br[:-1], br[1:])]


def anatomy_of_trial(trial) -> dict:
    """Classify the robust default's misses and false steps of one trial against its true steps (matched
    as METRICS.md says: one-to-one within ±0.25 s; mobgap_lab inside the reference's walking bouts).

    A miss is "timing" when an unmatched detection lies within 0.5 s (the step was found, > 0.25 s off);
    else by place: first / last (the first two / last two true steps of a bout), short bout (< 8 true
    steps), turn (mean rate about gravity over 1 s > 0.5 rad/s), slow (true step interval > 0.7 s), mid.
    Its cause is read off the detector's trace at the most prominent candidate within ±0.25 s: no candidate,
    the periodicity / activity / handling gate, or not chosen (beat tracking, onset trim, bout < 4 steps).
    A false step is "timing" (paired with a miss), before the first / after the last true step, or inside."""
    from bootnav.postproc.evaluate.metrics import match_events
    from bootnav.postproc.evaluate.runner import _inside_walking_bouts, _truth_json
    from bootnav.postproc.pdr.detectors import make_detector
    from bootnav.postproc.pdr.signals import centered_moving_average, gravity_direction, resample_uniform

    t, acc, gyro = _load(trial)
    det = make_detector("robust")
    ev = det.detect(t, acc)
    tr = ev.trace
    d = ev.t_s[_inside_walking_bouts(trial.path, _truth_json(trial.path), ev.t_s)]
    tt = np.sort(trial.t_steps)
    md, mt = np.zeros(d.size, bool), np.zeros(tt.size, bool)
    pairs = match_events(d, tt)
    for i, j in pairs:
        md[i], mt[j] = True, True
    place = np.full(tt.size, "mid", object)
    for a, b in _truth_bouts(trial, tt):
        place[a:b + 1] = "short bout" if b - a + 1 < 8 else "mid"
        place[[a, min(a + 1, b)]] = "first"
        place[[b, max(b - 1, a)]] = "last"
    iv = np.diff(tt)
    loc = np.array([np.mean([iv[m] for m in (k - 1, k) if 0 <= m < iv.size and iv[m] < 1.6] or [0.0]) for k in range(tt.size)])
    place[(place == "mid") & (loc > 0.7)] = "slow"
    if gyro is not None:
        tg, ag = resample_uniform(t, np.column_stack([acc, gyro]), 50.0)
        w_up = np.abs(np.einsum("ij,ij->i", ag[:, 3:], gravity_direction(ag[:, :3], 50.0)))
        turn = np.interp(tt, tg, centered_moving_average(w_up, 50)) > 0.5
        place[np.isin(place, ["mid", "slow"]) & turn] = "turn"
    tp, tg = tr["candidates_t_s"], tr["t_s"]
    ipk = np.clip(np.searchsorted(tg, tp), 0, tg.size - 1)
    gate = np.full(tp.size, "not chosen", object)
    if tr["gravity_turn_deg"] is not None:
        gate[tr["gravity_turn_deg"][ipk] > det.handling_max_deg] = "handling gate"
    gate[tr["activity_rms"][ipk] < det.activity_rms_mps2] = "activity gate"
    if tr["periodicity"] is not None:
        gate[tr["periodicity"][ipk] < det.periodicity_min] = "periodicity gate"
    sig = np.interp(tp, tg, tr["signal"])
    out = {"miss": {}, "cause": {}, "false": {}}
    for k in np.nonzero(~mt)[0]:
        timing = bool(np.any(~md & (np.abs(d - tt[k]) < 0.5)))
        c = np.nonzero(np.abs(tp - tt[k]) <= 0.25)[0]
        cause = "no candidate" if c.size == 0 else gate[c[np.argmax(sig[c])]]
        key = "timing" if timing else place[k]
        out["miss"][key] = out["miss"].get(key, 0) + 1
        if not timing:
            out["cause"][cause] = out["cause"].get(cause, 0) + 1
    for i in np.nonzero(~md)[0]:
        key = ("timing" if np.any(~mt & (np.abs(tt - d[i]) < 0.5)) else "before first" if d[i] < tt[0]
               else "after last" if d[i] > tt[-1] else "inside")
        out["false"][key] = out["false"].get(key, 0) + 1
    ok = iv[iv < 1.6]
    off = np.array([d[i] - tt[j] for i, j in pairs])
    out.update(id=trial.id, set=trial.set, mount=trial.mount, n_true=int(tt.size), n_det=int(d.size),
               f1=2.0 * len(pairs) / max(d.size + tt.size, 1), cadence=float(1.0 / np.median(ok)) if ok.size else np.nan,
               offset_ms=float(1e3 * np.median(off)) if off.size else np.nan)
    return out


def anatomy(by_set: dict, pool) -> None:
    """Print the error anatomy of the robust default per set (``anatomy_of_trial``)."""
    trials = [t for s in by_set.values() for t in s if t.t_steps is not None]
    res = pool.map(anatomy_of_trial, trials)
    sets = [s for s in by_set if any(r["set"] == s for r in res)]
    tot = {s: {"miss": {}, "cause": {}, "false": {}} for s in sets}
    for r in res:
        for part in ("miss", "cause", "false"):
            for k, v in r[part].items():
                tot[r["set"]][part][k] = tot[r["set"]][part].get(k, 0) + v
    print("\n### Error anatomy of the robust default (true steps missed / false steps, counts per set)\n")
    print("| class | " + " | ".join(sets) + " |")
    print("|---|" + "---|" * len(sets))
    print("| true steps / detected | " + " | ".join(
        f"{sum(r['n_true'] for r in res if r['set'] == s)} / {sum(r['n_det'] for r in res if r['set'] == s)}" for s in sets) + " |")
    for part, label in (("miss", "missed"), ("cause", "miss cause (non-timing)"), ("false", "false")):
        for k in sorted({k for s in sets for k in tot[s][part]}):
            print(f"| {label}: {k} | " + " | ".join(str(tot[s][part].get(k, 0)) for s in sets) + " |")
    print("\n| recording | mount | cadence steps/s | true | detected | F1 | median offset ms |")
    print("|---|---|---|---|---|---|---|")
    for r in res:
        print(f"| {r['id']} | {r['mount']} | {r['cadence']:.2f} | {r['n_true']} | {r['n_det']} | {r['f1']:.3f} | {r['offset_ms']:+.0f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", default=os.environ.get("BOOTNAV_DATASETS",
                                                        str(Path(__file__).resolve().parents[2] / "shared" / "datasets")))
    ap.add_argument("--grid", nargs="*", default=None, help=f"grids to run (default: all of {sorted(GRIDS)})")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--anatomy", action="store_true", help="print the robust default's error anatomy and stop")
    a = ap.parse_args(argv)
    trials = list_trials(a.datasets)
    by_set = {s: [t for t in trials if t.set == s] for s in PDR_SETS}
    with Pool(a.processes) as pool:
        if a.anatomy:
            anatomy(by_set, pool)
            return 0
        for name in a.grid if a.grid is not None else GRIDS:
            det, base, pname, values = GRIDS[name]
            print_grid(name, evaluate_grid(by_set, det, base, pname, values, pool))
    return 0


if __name__ == "__main__":
    sys.exit(main())
