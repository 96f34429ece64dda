"""Train the learned stance detector (``postproc/detectors/learned.py``) and test it leave-one-dataset-out.

Labels (only from references, never from a detector of bootnav's: those would teach the model nothing new):

* ``pyshoe_vicon`` (16 trials): per-sample zero-velocity labels, the VICON foot speed under pyshoe's optimised
  threshold (``truth_stance``). The only per-sample stance truth in ../shared/datasets.
* ``gaitmap_example/level_walk`` (both feet): the mocap strides run from one minimum of the foot's speed to the
  next, so each stride boundary is a stance instant (label 1) and the middle of each stride is mid-swing
  (label 0: with boundaries at mid-stance, the half-way point lies in the swing at any walking speed).
* ``koroglu_footprints`` and ``koroglu_rectangles``: each surveyed footprint's time is the last sample of the
  zero-velocity interval on it (the authors' annotation: their own LSTM detector with manual corrections, so
  a second-hand label). Stance: 0.02-0.06 s before it; swing: a quarter of the way to the next footprint of
  consecutive strides (the foot has left the floor; the next stance takes the last third or more).
  Point labels: every 0.01 s within ±0.02 s of the instant, nearest samples.
* The other sets (closure, out-and-back) give no stance label; they only score.

Each labelled dataset gets the same total weight; every trial is used at its own rate and block-mean
decimated by 2 (augmentation: 100 Hz), so the model sees the rates boots log at.

    .venv/bin/python benchmarks/learned_stance.py train [--hidden 0] [--exclude SET ...] [--out model.json]
    .venv/bin/python benchmarks/learned_stance.py crossval [--hidden 0] [--jobs 1]   # the LODO table
    .venv/bin/python benchmarks/learned_stance.py compare h0.json h8.json ...          # LODO choice of variant
    .venv/bin/python benchmarks/learned_stance.py loto [--hidden 0]                  # pyshoe_vicon leave-one-trial-out
    .venv/bin/python benchmarks/learned_stance.py rates                              # decimation check
    .venv/bin/python benchmarks/learned_stance.py decimated [--out model.json]       # figures at lower rates

``train`` without ``--out`` writes the shipped model (postproc/detectors/learned_stance.json) with its
provenance. ``crossval``: for each foot dataset D of ``crossval.PRIMARY``, a model is trained on the labels of
every other dataset (D's never), D's trials are processed with ``--detector learned`` and that model, and its
primary METRICS.md figure is compared with the default detector's (adaptive), paired per trial, ± SE.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import hashlib
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
from crossval import DEFAULT_ROOT, PRIMARY, paired_diff, score_settings, set_figures, settings_with, source_fingerprint  # noqa: E402
from rates import decimate_block_mean, read_imu  # noqa: E402

LABELLED = ("pyshoe_vicon", "gaitmap_example", "koroglu_footprints", "koroglu_rectangles")
#: sources of labels weighted as one (the two koroglu sets: one lab, one annotation, rectangles have few)
GROUP = {"koroglu_rectangles": "koroglu_footprints"}
POINT_HALF_S = 0.02
#: per-sample labels (pyshoe_vicon) kept every STRIDE_SAMPLES-th sample: neighbours say the same thing
STRIDE_SAMPLES = 4
SEED = 0


# ------------------------------------------------------------------------------------------------ labels
def _inputs(data: np.ndarray):
    """t, acc, gyro with the gyro bias and gravity the pipeline gives the detector (``stance_reference``)."""
    from bootnav.postproc.calibration import initial_alignment, stance_reference

    t, acc, gyro = data[:, 0], data[:, 1:4], data[:, 4:7]
    init = initial_alignment(t, acc, gyro)
    bias, g = stance_reference(init, 9.80665)
    return t, acc, gyro - bias, g


def _point_labels(t: np.ndarray, stance_t, swing_t) -> tuple[np.ndarray, np.ndarray]:
    """(sample indices, labels) of point labels, each spread over ±POINT_HALF_S in 0.01 s steps."""
    idx, lab = [], []
    for times, value in ((stance_t, 1), (swing_t, 0)):
        for c in np.asarray(times, float):
            for tt in np.arange(c - POINT_HALF_S, c + POINT_HALF_S + 1e-9, 0.01):
                i = int(np.clip(np.searchsorted(t, tt), 0, len(t) - 1))
                if abs(t[i] - tt) < 0.02:
                    idx.append(i)
                    lab.append(value)
    idx = np.asarray(idx, int)
    keep = np.unique(idx, return_index=True)[1]
    return idx[keep], np.asarray(lab, float)[keep]


def labelled_units(root: Path, sets: list[str], skip_trials=()):
    """Yield (set, unit name, raw data (N, 7), label_fn(t) -> (indices, labels)) of every labelled IMU file."""
    import csv

    manifest = json.loads((root / "manifest.json").read_text())
    for tr in manifest["trials"]:
        s, path = tr["set"], root / tr["path"]
        if s not in sets or tr["id"] in skip_trials:
            continue
        if s == "pyshoe_vicon":
            data = read_imu(path / "imu.csv.gz")
            truth = read_imu_like(path / "truth_stance.csv.gz")
            lab_t, lab_v = truth[:, 0], truth[:, 1]

            def fn(t, lab_t=lab_t, lab_v=lab_v):
                # nearest truth sample per IMU sample (same clock); a block mean's majority when decimated
                v = np.interp(t, lab_t, lab_v)
                keep = np.abs(v - 0.5) > 0.25 if len(t) < len(lab_t) else np.ones(len(t), bool)
                keep &= np.arange(len(t)) % STRIDE_SAMPLES == 0
                return np.flatnonzero(keep), (v[keep] >= 0.5).astype(float)
            yield s, tr["id"], data, fn
        elif s == "gaitmap_example" and (path / "truth_strides.csv").exists():
            rows = list(csv.DictReader(open(path / "truth_strides.csv")))
            for foot, fname in (("L", "imu_left.csv.gz"), ("R", "imu_right.csv.gz")):
                st = [(float(r["t_start_s"]), float(r["t_end_s"])) for r in rows if r["foot"] == foot]
                bounds = sorted({x for ab in st for x in ab})
                mids = [(a + b) / 2 for a, b in st]
                yield s, f"{tr['id']}:{foot}", read_imu(path / fname), (
                    lambda t, bounds=bounds, mids=mids: _point_labels(t, bounds, mids))
        elif s.startswith("koroglu_"):
            rows = list(csv.DictReader(open(path / "truth_footprints.csv")))
            if not rows or "t_s" not in rows[0]:
                continue
            k = [int(r["stride"]) for r in rows]
            ts = [float(r["t_s"]) for r in rows]
            stance = [x - 0.04 for x in ts]
            swing = [ts[i] + 0.25 * (ts[i + 1] - ts[i]) for i in range(len(ts) - 1) if k[i + 1] == k[i] + 1]
            yield s, tr["id"], read_imu(path / "imu.csv.gz"), (
                lambda t, stance=stance, swing=swing: _point_labels(t, stance, swing))


def read_imu_like(path: Path) -> np.ndarray:
    """A small numeric CSV (header line) as an array."""
    import gzip

    with gzip.open(path, "rt") as fh:
        return np.loadtxt(fh, delimiter=",", skiprows=1)


def build_training_set(root: Path, sets: list[str], factors=(1, 2), skip_trials=()):
    """Features X (M, F), labels y (M,), weights w (M,), per-set label counts."""
    from bootnav.core.arrays import median_dt
    from bootnav.postproc.detectors.learned import stance_features

    xs, ys, ws, sources = [], [], [], []
    for s, unit, data, fn in labelled_units(root, sets, skip_trials):
        for k in factors:
            t, x = (data[:, 0], data[:, 1:]) if k == 1 else decimate_block_mean(data[:, 0], data[:, 1:], k)
            t, acc, gyro, g = _inputs(np.column_stack([t, x]))
            feats = stance_features(acc, gyro, median_dt(t), g)
            idx, lab = fn(t)
            xs.append(feats[idx])
            ys.append(lab)
            sources.append(np.full(len(idx), s, dtype=object))
    X, y, src = np.vstack(xs), np.concatenate(ys), np.concatenate(sources)
    w = np.zeros(len(y))
    counts = {}
    group = np.array([GROUP.get(s, s) for s in src], dtype=object)
    present = list(dict.fromkeys(group))
    for s in present:  # every source of labels the same total weight
        m = group == s
        w[m] = len(y) / len(present) / m.sum()
    for s in dict.fromkeys(src):
        m = src == s
        counts[s] = {"labels": int(m.sum()), "stance_fraction": float(y[m].mean())}
    return X, y, w, counts


# ----------------------------------------------------------------------------------------------- fitting
def fit(X: np.ndarray, y: np.ndarray, w: np.ndarray, hidden: int, l2: float = 1e-3, max_iter: int = 400):
    """Weighted logistic loss + L2, one tanh hidden layer of ``hidden`` units (0: logistic regression),
    L-BFGS (scipy). Returns (mean, scale, layers)."""
    from scipy.optimize import minimize

    mean = X.mean(axis=0)
    scale = X.std(axis=0)
    scale[scale <= 0] = 1.0
    Z = (X - mean) / scale
    n, f = Z.shape
    w = w / w.sum()
    rng = np.random.default_rng(SEED)
    shapes = [(f, hidden), (hidden,), (hidden, 1), (1,)] if hidden else [(f, 1), (1,)]
    sizes = [int(np.prod(s)) for s in shapes]
    theta0 = np.concatenate([rng.normal(0, 1 / math.sqrt(s[0]), int(np.prod(s))) if len(s) == 2 else np.zeros(s)
                             for s in shapes])

    def unpack(theta):
        parts, k = [], 0
        for s, m in zip(shapes, sizes):
            parts.append(theta[k:k + m].reshape(s))
            k += m
        return parts

    def loss_grad(theta):
        parts = unpack(theta)
        if hidden:
            W1, b1, W2, b2 = parts
            H = np.tanh(Z @ W1 + b1)
            z = (H @ W2 + b2)[:, 0]
        else:
            W2, b2 = parts
            z = (Z @ W2 + b2)[:, 0]
        p = 0.5 * (1 + np.tanh(0.5 * z))
        eps = 1e-12
        loss = -np.sum(w * (y * np.log(p + eps) + (1 - y) * np.log(1 - p + eps)))
        dz = w * (p - y)
        grads = []
        if hidden:
            gW2 = H.T @ dz[:, None]
            gb2 = np.array([dz.sum()])
            dH = dz[:, None] * W2[:, 0][None, :] * (1 - H**2)
            grads = [Z.T @ dH, dH.sum(axis=0), gW2, gb2]
            weights = [0, 2]
        else:
            grads = [Z.T @ dz[:, None], np.array([dz.sum()])]
            weights = [0]
        for i in weights:
            loss += 0.5 * l2 * np.sum(parts[i] ** 2)
            grads[i] = grads[i] + l2 * parts[i]
        return loss, np.concatenate([g.ravel() for g in grads])

    res = minimize(loss_grad, theta0, jac=True, method="L-BFGS-B", options={"maxiter": max_iter})
    parts = unpack(res.x)
    layers = ((parts[0], parts[1]), (parts[2], parts[3])) if hidden else ((parts[0], parts[1]),)
    return mean, scale, layers, float(res.fun)


def train(root: Path, exclude: list[str], hidden: int, out: Path, l2: float = 1e-3, skip_trials=()) -> dict:
    """Train on the labelled sets not in ``exclude``; write the model JSON; return its provenance."""
    from bootnav.postproc.detectors.learned import StanceModel

    sets = [s for s in LABELLED if s not in exclude]
    t0 = time.perf_counter()
    X, y, w, counts = build_training_set(root, sets, skip_trials=skip_trials)
    t1 = time.perf_counter()
    mean, scale, layers, loss = fit(X, y, w, hidden, l2)
    t2 = time.perf_counter()
    model = StanceModel(mean, scale, layers, {})
    p = model.probability(X)
    acc = {s: None for s in counts}
    prov = {
        "trained_on": sets, "left_out_trials": list(skip_trials), "labels": counts, "hidden_units": hidden, "l2": l2, "seed": SEED,
        "augmentation": "each file at its own rate and block-mean decimated by 2",
        "date": _dt.date.today().isoformat(), "script": "benchmarks/learned_stance.py train",
        "dataset_root": str(root.name), "training_loss": loss,
        "weighted_training_accuracy": float(np.sum(w * ((p >= 0.5) == (y == 1))) / w.sum()),
        "features_s": round(t1 - t0, 2), "fit_s": round(t2 - t1, 2),
    }
    del acc
    model = StanceModel(mean, scale, layers, prov)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(model.to_dict(), indent=1) + "\n")
    tmp.replace(out)
    return prov


# ---------------------------------------------------------------------------------------------- crossval
def _verdict(d: float, se: float) -> str:
    if d == math.inf:
        return "FAIL"
    if not math.isfinite(se) or se == 0:
        return "n/a (1 unit)"
    return "better" if d < -2 * se else "worse" if d > 2 * se else "noise"


def crossval(root: Path, hidden: int, jobs: int, work: Path, cache: Path | None, sets: list[str],
             probability: float = 0.5) -> dict:
    from bootnav.postproc.settings import ProcessSettings  # noqa: F401  (import before timing)

    manifest = json.loads((root / "manifest.json").read_text())
    fp = source_fingerprint()
    models: dict[tuple, Path] = {}
    rows_out = []
    t_train = []
    trial_rows: dict = {"learned": {}, "default": {}}
    for held in sets:
        trials = [t for t in manifest["trials"] if t["set"] == held]
        train_sets = tuple(s for s in LABELLED if s != held)
        if train_sets not in models:
            tmp = work / f"model_tmp_{os.getpid()}.json"
            t0 = time.perf_counter()
            train(root, [held], hidden, tmp)
            t_train.append(time.perf_counter() - t0)
            doc = json.loads(tmp.read_text())  # named by its weights (the provenance holds timings)
            h = hashlib.sha1(json.dumps([doc["mean"], doc["scale"], doc["layers"]]).encode()).hexdigest()[:12]
            path = work / f"model_h{hidden}_{h}.json"
            tmp.replace(path)
            models[train_sets] = path
        path = models[train_sets]
        learned = settings_with({"detector.method": "learned", "detector.params": {"model": str(path),
                                                                                   "probability": probability}})
        r_l = score_settings(root, trials, learned, jobs, cache, fp)
        r_d = score_settings(root, trials, settings_with({}), jobs, cache, fp)
        trial_rows["learned"].update(r_l)
        trial_rows["default"].update(r_d)
        metric = PRIMARY[held]
        f_l, f_d = set_figures(r_l, held, metric), set_figures(r_d, held, metric)
        d, se = paired_diff(f_l, f_d)
        per_trial = {tid: (r_l[tid]["metrics"].get(metric), r_d[tid]["metrics"].get(metric),
                           r_l[tid]["status"], r_d[tid]["status"]) for tid in r_l}
        rows_out.append({"held_out": held, "metric": metric, "trained_on": list(train_sets), "model": str(path),
                         "learned": f_l["mean"], "default": f_d["mean"], "se_default": f_d["se"], "n": f_d["n"],
                         "diff": d, "diff_se": se, "verdict": _verdict(d, se),
                         "failed_learned": f_l["failed"], "failed_default": f_d["failed"], "per_trial": per_trial})
        print(f"{held}: learned {f_l['mean']:.4g} default {f_d['mean']:.4g} diff {d:.3g} ± {se:.3g}",
              file=sys.stderr)
    return {"hidden": hidden, "probability": probability, "rows": rows_out, "train_s": t_train,
            "trial_rows": trial_rows}


def loto(root: Path, hidden: int, jobs: int, work: Path, cache: Path | None, probability: float = 0.5) -> None:
    """pyshoe_vicon leave-one-TRIAL-out: each trial processed with a model trained on every label but its own
    (what per-sample labels from the same lab and sensor buy; not leave-one-dataset-out)."""
    manifest = json.loads((root / "manifest.json").read_text())
    fp = source_fingerprint()
    trials = [t for t in manifest["trials"] if t["set"] == "pyshoe_vicon"]
    rows_l, rows_d = {}, {}
    for tr in trials:
        tmp = work / f"model_tmp_{os.getpid()}.json"
        train(root, [], hidden, tmp, skip_trials=(tr["id"],))
        doc = json.loads(tmp.read_text())
        h = hashlib.sha1(json.dumps([doc["mean"], doc["scale"], doc["layers"]]).encode()).hexdigest()[:12]
        path = work / f"model_h{hidden}_{h}.json"
        tmp.replace(path)
        st = settings_with({"detector.method": "learned", "detector.params": {"model": str(path),
                                                                               "probability": probability}})
        rows_l.update(score_settings(root, [tr], st, jobs, cache, fp))
        rows_d.update(score_settings(root, [tr], settings_with({}), jobs, cache, fp))
    f_l, f_d = (set_figures(r, "pyshoe_vicon", "armse_2d") for r in (rows_l, rows_d))
    d, se = paired_diff(f_l, f_d)
    print(f"\npyshoe_vicon leave-one-trial-out (hidden {hidden}, p >= {probability:g}): learned "
          f"{f_l['mean']:.4g} m, adaptive {f_d['mean']:.4g} m (SE {f_d['se']:.3g}, n {f_d['n']}), "
          f"learned − adaptive {d:.3g} ± {se:.3g} m: {_verdict(d, se)}")
    for tid in rows_l:
        print(f"  {tid}: {rows_l[tid]['metrics'].get('armse_2d', float('nan')):.3f} "
              f"vs {rows_d[tid]['metrics'].get('armse_2d', float('nan')):.3f}")


def compare(paths: list[Path]) -> None:
    """LODO choice among variants (``crossval --json`` outputs) and the default: for each held-out set, the
    variant with the best geometric mean of normalised held-out figures over the OTHER sets
    (``crossval.lodo``), its figure on the held-out set against the default's."""
    from crossval import lodo, print_tables

    runs = [json.loads(Path(p).read_text()) for p in paths]
    sets = [r["held_out"] for r in runs[0]["rows"]]
    rows = {"default (adaptive)": runs[0]["trial_rows"]["default"]}
    for r in runs:
        rows[f"learned h{r['hidden']} p{r['probability']:g}"] = r["trial_rows"]["learned"]
    figs = {c: {s: set_figures(rows[c], s, PRIMARY[s]) for s in sets} for c in rows}
    print_tables(figs, lodo(figs, "default (adaptive)"), {s: PRIMARY[s] for s in sets}, "stance detector")


def print_crossval(res: dict) -> None:
    print(f"\n### learned stance detector (hidden units {res['hidden']}, stance at p >= {res['probability']:g}), "
          "leave-one-dataset-out\n")
    print("| held-out set | metric | trained on (labels) | learned | adaptive (default) | SE (n) | "
          "learned − adaptive ± SE | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    short = {"pyshoe_vicon": "vicon", "gaitmap_example": "gaitmap", "koroglu_footprints": "k-fp",
             "koroglu_rectangles": "k-rect"}
    for r in res["rows"]:
        fl = f"FAIL ({len(r['failed_learned'])})" if r["failed_learned"] else f"{r['learned']:.4g}"
        fd = f"FAIL ({len(r['failed_default'])})" if r["failed_default"] else f"{r['default']:.4g}"
        print(f"| {r['held_out']} | `{r['metric']}` | {'+'.join(short[s] for s in r['trained_on'])} | {fl} | {fd} | "
              f"{r['se_default']:.3g} ({r['n']}) | {r['diff']:.3g} ± {r['diff_se']:.3g} | {r['verdict']} |")
    ratios = [r["learned"] / r["default"] for r in res["rows"]
              if r["default"] > 0 and math.isfinite(r["default"]) and math.isfinite(r["learned"])]
    gm = float(np.exp(np.mean(np.log(ratios)))) if ratios else math.nan
    print(f"\nlearned / adaptive, geometric mean over held-out sets: {gm:.3f}; training "
          f"{np.mean(res['train_s']):.1f} s per model (features + fit, {len(res['train_s'])} models)")


# ------------------------------------------------------------------------------------------------- rates
def rates(root: Path) -> None:
    """Stance agreement of the shipped model with itself after block-mean decimation (a rate check)."""
    from bootnav.core.arrays import median_dt
    from bootnav.postproc.detectors.learned import LearnedDetector

    manifest = json.loads((root / "manifest.json").read_text())
    picks = {"openshoe_820": (2, 4, 8), "xio_ngimu_loops": (2, 4), "pyshoe_vicon": (2,)}
    print("\n| trial | native Hz | factor | rate Hz | stance fraction native → decimated | agreement |")
    print("|---|---|---|---|---|---|")
    for tr in manifest["trials"]:
        if tr["set"] not in picks or (tr["set"] == "pyshoe_vicon" and not tr["id"].endswith("11-22-03")):
            continue
        f = next(iter(tr.get("imu_files") or {"imu.csv.gz": 0}))
        data = read_imu(root / tr["path"] / f)
        t, acc, gyro, g = _inputs(data)
        det = LearnedDetector(gravity_mps2=g)
        ref = det.detect(acc, gyro, t).stance
        for k in picks[tr["set"]]:
            td, xd = decimate_block_mean(data[:, 0], data[:, 1:], k)
            t2, a2, g2, gg = _inputs(np.column_stack([td, xd]))
            st = LearnedDetector(gravity_mps2=gg).detect(a2, g2, t2).stance
            back = np.interp(t, t2, st.astype(float)) >= 0.5
            print(f"| {tr['id']} | {1 / median_dt(t):.0f} | {k} | {1 / median_dt(t2):.0f} | "
                  f"{ref.mean():.3f} → {st.mean():.3f} | {np.mean(back == ref):.3f} |")


def decimated(root: Path, jobs: int, cache: Path | None, work: Path, model: str = "") -> None:
    """Navigation figures of the learned detector and the default on block-mean decimated copies of the two
    unlabelled high-rate sets (never trained on), as benchmarks/rates.py makes them."""
    from rates import make_tree

    manifest = json.loads((root / "manifest.json").read_text())
    fp = source_fingerprint()
    plan = {"openshoe_820": (1, 2, 3, 4), "xio_ngimu_loops": (1, 2, 4)}
    cands = {"adaptive (default)": settings_with({}),
             "learned": settings_with({"detector.method": "learned", "detector.params": {"model": model}})}
    print("\n| set | rate Hz | metric | " + " | ".join(cands) + " |")
    print("|---|---|---|" + "---|" * len(cands))
    for s, factors in plan.items():
        trials = [t for t in manifest["trials"] if t["set"] == s]
        for k in factors:
            r, tr = (root, trials) if k == 1 else make_tree(root, trials, k, "mean", work / "rates")
            cells = []
            for name, st in cands.items():
                rows = score_settings(r, tr, st, jobs, cache, fp)
                f = set_figures(rows, s, "closure_pct")
                v = set_figures(rows, s, "closure_v_m")
                cells.append("FAIL" if f["failed"] else f"{f['mean']:.3g} % / {v['mean']:.3g} m")
            print(f"| {s} | {trials[0]['rate_hz'] / k:.0f} | `closure_pct` / `closure_v_m` | " + " | ".join(cells) + " |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("command", choices=["train", "crossval", "compare", "rates", "decimated", "loto"])
    ap.add_argument("runs", nargs="*", type=Path, help="compare: crossval --json outputs")
    ap.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    ap.add_argument("--hidden", type=int, default=0, help="tanh hidden units (0, the shipped model: logistic regression)")
    ap.add_argument("--l2", type=float, default=1e-3)
    ap.add_argument("--probability", type=float, default=0.5, help="crossval: stance where p(stance) >= this")
    ap.add_argument("--exclude", nargs="*", default=[], help="labelled sets left out of training")
    ap.add_argument("--out", type=Path, default=None, help="model JSON (default: the shipped model)")
    ap.add_argument("--sets", nargs="*", default=None, help="crossval: held-out sets (default: crossval.PRIMARY)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--work", type=Path, default=Path("/tmp/bootnav_learned"))
    ap.add_argument("--cache", default="/tmp/bootnav_crossval_cache")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args(argv)
    if a.command == "train":
        from bootnav.postproc.detectors.learned import SHIPPED_MODEL

        out = a.out or SHIPPED_MODEL
        prov = train(a.root, a.exclude, a.hidden, out, a.l2)
        print(json.dumps(prov, indent=1))
        print(f"wrote {out}")
    elif a.command == "crossval":
        a.work.mkdir(parents=True, exist_ok=True)
        res = crossval(a.root, a.hidden, a.jobs, a.work, Path(a.cache) if a.cache else None, a.sets or list(PRIMARY),
                       a.probability)
        print_crossval(res)
        if a.json:
            a.json.write_text(json.dumps(res, indent=1, default=float))
    elif a.command == "decimated":
        decimated(a.root, a.jobs, Path(a.cache) if a.cache else None, a.work, str(a.out or ""))
    elif a.command == "loto":
        a.work.mkdir(parents=True, exist_ok=True)
        loto(a.root, a.hidden, a.jobs, a.work, Path(a.cache) if a.cache else None, a.probability)
    elif a.command == "compare":
        compare(a.runs)
    else:
        rates(a.root)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
