"""Accuracy of PDR on the public datasets, exactly as ../shared/datasets/METRICS.md defines it.

* step_events: one-to-one matching of detected to true events within +-0.25 s, nearest pairs first;
  precision = matched / detected, recall = matched / true, f1 = 2 P R / (P + R),
  count_err_pct = 100 (detected - true) / true.
* step_count: count_err_pct as above.
* step_lengths: the detected step nearest each reference contact within +-0.25 s;
  step_len_mae_m, step_len_bias_m over the matched steps.

The dataset walk (``load_trial``, ``evaluate_trial``) is used by benchmarks/pdr_table.py and is what
``bootnav eval`` calls for PDR. A trial that cannot be processed is returned with ``error`` set, never
skipped silently.
"""

from __future__ import annotations

import csv
import gzip
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

TOL_S = 0.25


def match_events(t_true: np.ndarray, t_det: np.ndarray, tol_s: float = TOL_S) -> np.ndarray:
    """One-to-one matching, nearest pairs first (greedy on |dt|, ties by time).

    Returns an (M, 2) int array of (true index, detected index) pairs with |dt| <= tol_s."""
    t_true = np.asarray(t_true, float)
    t_det = np.asarray(t_det, float)
    if t_true.size == 0 or t_det.size == 0:
        return np.zeros((0, 2), int)
    lo = np.searchsorted(t_det, t_true - tol_s, side="left")
    hi = np.searchsorted(t_det, t_true + tol_s, side="right")
    ti = np.repeat(np.arange(t_true.size), hi - lo)
    di = np.concatenate([np.arange(a, b) for a, b in zip(lo, hi)]) if ti.size else np.zeros(0, int)
    if ti.size == 0:
        return np.zeros((0, 2), int)
    dt = np.abs(t_det[di] - t_true[ti])
    order = np.lexsort((ti, dt))
    used_t = np.zeros(t_true.size, bool)
    used_d = np.zeros(t_det.size, bool)
    pairs = []
    for k in order:
        a, b = ti[k], di[k]
        if not used_t[a] and not used_d[b]:
            used_t[a] = used_d[b] = True
            pairs.append((a, b))
    return np.array(sorted(pairs), int).reshape(-1, 2)


def count_err_pct(n_detected: int, n_true: int) -> float:
    """100 (detected - true) / true; 0 when both are 0 (seed-003 Table 3.1 row 1), NaN if only true is 0."""
    if n_true == 0:
        return 0.0 if n_detected == 0 else float("nan")
    return 100.0 * (n_detected - n_true) / n_true


def event_metrics(t_true, t_det, tol_s: float = TOL_S) -> dict:
    """precision, recall, f1, count_err_pct, n_true, n_detected, n_matched, mean_dt_s (det - true)."""
    t_true = np.sort(np.asarray(t_true, float))
    t_det = np.sort(np.asarray(t_det, float))
    pairs = match_events(t_true, t_det, tol_s)
    m = len(pairs)
    p = m / t_det.size if t_det.size else float("nan")
    r = m / t_true.size if t_true.size else float("nan")
    f1 = 2 * p * r / (p + r) if m else 0.0
    dt = t_det[pairs[:, 1]] - t_true[pairs[:, 0]] if m else np.zeros(0)
    return {
        "precision": p, "recall": r, "f1": f1,
        "count_err_pct": count_err_pct(t_det.size, t_true.size),
        "n_true": int(t_true.size), "n_detected": int(t_det.size), "n_matched": m,
        "mean_dt_s": float(dt.mean()) if m else float("nan"),
    }


def step_length_metrics(t_ref, len_ref, t_det, len_det, tol_s: float = TOL_S) -> dict:
    """For each reference contact the nearest detected step within +-tol_s (METRICS.md step_lengths):
    step_len_mae_m, step_len_bias_m (estimate - reference), n_matched."""
    t_ref = np.asarray(t_ref, float)
    len_ref = np.asarray(len_ref, float)
    t_det = np.asarray(t_det, float)
    len_det = np.asarray(len_det, float)
    if t_det.size == 0 or t_ref.size == 0:
        return {"step_len_mae_m": float("nan"), "step_len_bias_m": float("nan"), "n_matched": 0}
    order = np.argsort(t_det)
    t_det, len_det = t_det[order], len_det[order]
    j = np.clip(np.searchsorted(t_det, t_ref), 1, t_det.size - 1) if t_det.size > 1 else np.zeros(t_ref.size, int)
    if t_det.size > 1:
        j = np.where(np.abs(t_det[j - 1] - t_ref) <= np.abs(t_det[j] - t_ref), j - 1, j)
    ok = np.abs(t_det[j] - t_ref) <= tol_s
    err = len_det[j[ok]] - len_ref[ok]
    if err.size == 0:
        return {"step_len_mae_m": float("nan"), "step_len_bias_m": float("nan"), "n_matched": 0}
    return {"step_len_mae_m": float(np.mean(np.abs(err))), "step_len_bias_m": float(np.mean(err)),
            "n_matched": int(err.size)}


# ----------------------------------------------------------------------------------------------------
# dataset access

@dataclass
class Trial:
    """One PDR-relevant trial of ../shared/datasets (lower back or phone)."""

    id: str
    set: str
    mount: str
    path: Path
    imu_file: str
    truth: list
    t_steps: np.ndarray | None = None
    feet: np.ndarray | None = None  # L/R/unknown per truth step
    n_steps: int | None = None
    t_len: np.ndarray | None = None
    step_len: np.ndarray | None = None
    bouts: np.ndarray | None = None  # (k, 2) walking-bout [start, end] s (mobgap_lab)
    info: dict = field(default_factory=dict)


PDR_SETS = ("oxford_steps", "voisard_ipol", "mobgap_lab")


def _read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def list_trials(root: str | Path, sets=PDR_SETS) -> list[Trial]:
    """Trials with step truth whose main sensor is a lower-back IMU or a phone."""
    root = Path(root)
    manifest = json.loads((root / "manifest.json").read_text())
    out = []
    for tr in manifest["trials"]:
        if tr["set"] not in sets or not ({"step_events", "step_count"} & set(tr["truth"])):
            continue
        files = tr.get("imu_files") or {}
        main = [f for f, m in files.items() if m == tr["mount"]] or list(files)
        if not main:
            main = ["acc.csv.gz" if (root / tr["path"] / "acc.csv.gz").exists() else "imu.csv.gz"]
        t = Trial(id=tr["id"], set=tr["set"], mount=tr["mount"], path=root / tr["path"], imu_file=main[0],
                  truth=list(tr["truth"]), info={"notes": tr.get("notes", ""), "distance_m": tr.get("distance_m")})
        p = t.path
        if (p / "truth_steps.csv").exists():
            rows = _read_csv(p / "truth_steps.csv")
            t.t_steps = np.array([float(r["t_s"]) for r in rows])
            t.feet = np.array([r.get("foot", "unknown") for r in rows])
        if (p / "truth.json").exists():
            tj = json.loads((p / "truth.json").read_text())
            t.n_steps = tj.get("steps")
            t.info["truth_json"] = tj
        if (p / "truth_step_lengths.csv").exists():
            rows = _read_csv(p / "truth_step_lengths.csv")
            t.t_len = np.array([float(r["t_s"]) for r in rows])
            t.step_len = np.array([float(r["step_length_m"]) for r in rows])
        if (p / "truth_walking_bouts.csv").exists():
            rows = _read_csv(p / "truth_walking_bouts.csv")
            src = "INDIP" if any(r["source"].upper().startswith("INDIP") for r in rows) else None
            b = [(float(r["t_start_s"]), float(r["t_end_s"])) for r in rows
                 if src is None or r["source"].upper().startswith("INDIP")]
            t.bouts = np.array(b).reshape(-1, 2)
        if t.t_steps is not None and t.n_steps is None:
            t.n_steps = int(t.t_steps.size)
        out.append(t)
    return out


def load_imu_csv(path: str | Path, max_bad_fraction: float = 0.01):
    """Canonical ``acc.csv.gz`` / ``imu.csv.gz`` (t_s, ax..az m/s^2[, gx..gz rad/s]) -> t, acc, gyro|None.

    Unparseable rows (wrong field count, non-numbers) are skipped and reported on stderr with their line
    numbers; more than ``max_bad_fraction`` of them is an InputError naming the first bad lines."""
    import sys

    from bootnav.errors import InputError

    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as f:
        header = f.readline().strip().split(",")
        body = f.read().splitlines()
    col = {h: i for i, h in enumerate(header)}
    need = ["t_s", "ax_mps2", "ay_mps2", "az_mps2"]
    missing = [h for h in need if h not in col]
    if missing:
        raise InputError(f"{path}: line 1: missing column(s) {missing}; expected {need} (+ gx_radps..gz_radps)")
    try:
        data = np.loadtxt(body, delimiter=",", ndmin=2)
        if data.shape[1] != len(header):
            raise ValueError("field count")
        bad = []
    except ValueError:
        rows, bad = [], []
        for k, line in enumerate(body):
            parts = line.split(",")
            try:
                if len(parts) != len(header):
                    raise ValueError
                rows.append([float(v) for v in parts])
            except ValueError:
                bad.append(k + 2)  # 1-based, after the header
        data = np.array(rows, float).reshape(-1, len(header))
    if bad:
        where = ", ".join(map(str, bad[:5])) + (" ..." if len(bad) > 5 else "")
        if len(bad) > max_bad_fraction * max(len(body), 1) or data.shape[0] < 2:
            raise InputError(f"{path}: {len(bad)} of {len(body)} data rows unreadable (lines {where}); "
                             f"expected {len(header)} numbers per row")
        print(f"warning: {path}: skipped {len(bad)} unreadable row(s) (lines {where})", file=sys.stderr)
    t = data[:, col["t_s"]]
    acc = data[:, [col[h] for h in need[1:]]]
    gyro = data[:, [col[h] for h in ("gx_radps", "gy_radps", "gz_radps")]] if "gx_radps" in col else None
    return t, acc, gyro


def restrict_to_bouts(t: np.ndarray, bouts: np.ndarray | None, margin_s: float = 0.0) -> np.ndarray:
    """Boolean mask of times inside any walking bout (mobgap_lab: truth exists only inside bouts)."""
    t = np.asarray(t, float)
    if bouts is None or len(bouts) == 0:
        return np.ones(t.size, bool)
    m = np.zeros(t.size, bool)
    for a, b in bouts:
        m |= (t >= a - margin_s) & (t <= b + margin_s)
    return m


def evaluate_trial(trial: Trial, settings=None) -> dict:
    """Run the PDR pipeline on one trial and compute every metric its truth allows."""
    from bootnav.postproc.pdr.pipeline import PdrSettings, run_pdr

    settings = settings or PdrSettings()
    row = {"id": trial.id, "set": trial.set, "mount": trial.mount, "detector": settings.detector,
           "length": settings.length, "error": None}
    try:
        t, acc, gyro = load_imu_csv(trial.path / trial.imu_file)
        res = run_pdr(t, acc, gyro, settings)
    except Exception as exc:  # a failure is a result with its reason, never skipped
        row["error"] = f"{type(exc).__name__}: {exc}"
        return row
    t_det = res.t_s
    len_det = res.length_m
    t_true = trial.t_steps
    if trial.bouts is not None and t_true is not None:
        # truth exists only inside reference walking bouts: score detections there (+ the tolerance)
        keep = restrict_to_bouts(t_det, trial.bouts, TOL_S)
        t_det, len_det = t_det[keep], len_det[keep]
    if t_true is not None:
        row.update(event_metrics(t_true, t_det))
    elif trial.n_steps is not None:
        row.update({"count_err_pct": count_err_pct(t_det.size, trial.n_steps), "n_true": trial.n_steps,
                    "n_detected": int(t_det.size)})
    if t_true is not None and trial.feet is not None and trial.set == "oxford_steps":
        n_alt = alternation_corrected_count(t_true, trial.feet)
        row["count_err_vs_alternating_truth_pct"] = count_err_pct(int(t_det.size), n_alt)
        # DIAGNOSTIC: steps counted while the insoles were logging steps (handling before the first / after
        # the last true step excluded), to separate walk-edge errors from in-walk errors
        span = (t_det >= t_true.min() - TOL_S) & (t_det <= t_true.max() + TOL_S)
        row["count_err_in_truth_span_pct"] = count_err_pct(int(np.sum(span)), int(t_true.size))
    if trial.step_len is not None and trial.step_len.size:
        row.update(step_length_metrics(trial.t_len, trial.step_len, t_det, len_det))
    if trial.info.get("truth_json", {}).get("t_start_s") is not None and trial.set == "voisard_ipol":
        tj = trial.info["truth_json"]
        inside = (res.t_s >= tj["t_start_s"]) & (res.t_s <= tj["t_end_s"])
        row["distance_est_m"] = float(np.sum(res.length_m[inside]))
        row["distance_err_pct"] = 100.0 * (row["distance_est_m"] - tj["distance_m"]) / tj["distance_m"]
    return row


def alternation_corrected_count(t_steps, feet, bounce_s: float = 0.35, missing_s: float = 0.8) -> int:
    """DIAGNOSTIC only (not a METRICS.md metric): a truth count made consistent with left/right
    alternation. Two events of the same foot less than ``bounce_s`` apart count once (switch bounce);
    two events of the same foot more than ``missing_s`` apart mean the other foot's contact was missed
    (+1). Used to show how much of a detector's count error is truth noise."""
    t = np.asarray(t_steps, float)
    f = np.asarray(feet)
    same = np.nonzero((f[1:] == f[:-1]) & np.isin(f[1:], ["L", "R"]))[0]
    dt = np.diff(t)[same]
    return int(t.size - np.sum(dt < bounce_s) + np.sum(dt > missing_s))


def position_of(trial: Trial) -> str:
    """Carrying position label: phone_<pos> -> <pos> (normalised), lower_back -> lower_back."""
    m = trial.mount
    return m[len("phone_"):].lower() if m.startswith("phone_") else m
