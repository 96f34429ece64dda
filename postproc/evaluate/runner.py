"""Run bootnav on every trial of a dataset tree and score it with METRICS.md.

One fixed configuration for all trials: the estimate of a trial is computed from its IMU files alone;
its truth files are read only after the estimate is final (``estimate_*`` never sees the trial folder's
truth files, ``score_*`` never runs the processor; metric definitions: ``metrics``).

Foot-mounted IMU files go through the ZUPT post-processor (``bootnav.postproc.pipeline.process``); lower-back and
phone files through the PDR pipeline (``bootnav.postproc.pdr.run_pdr``). A trial's unprefixed metrics come from its
main mount (manifest ``mount``); the other pipeline's metrics are kept with a ``foot_`` or ``pdr_`` prefix.
"""

from __future__ import annotations

import csv
import gzip
import json
import os
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core.runs import runs
from bootnav.postproc.evaluate import metrics as M

FOOT_LETTER = {"imu_left.csv.gz": "L", "imu_right.csv.gz": "R"}


@dataclass
class FootEstimate:
    t_s: np.ndarray
    pos_n: np.ndarray
    stance: np.ndarray
    seconds: float
    result: object = None  # the pipeline.ProcessResult (two-boot fusion of a trial's two feet)


@dataclass
class PdrEstimate:
    step_t: np.ndarray
    step_len: np.ndarray
    step_xy: np.ndarray
    seconds: float


@dataclass
class TrialResult:
    id: str
    set: str
    mount: str
    status: str = "ok"
    reason: str = ""
    metrics: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)
    plot_data: dict = field(default_factory=dict)


# ------------------------------------------------------------------------------------------ loading
def read_csv_columns(path: Path) -> dict[str, np.ndarray]:
    """A (gzipped) CSV with a header row -> column name -> array (numbers, or strings if not numeric)."""
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "rt", newline="") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]
    cols = {}
    for k, name in enumerate(header):
        values = [r[k] for r in body]
        try:
            cols[name] = np.array(values, dtype=float)
        except ValueError:
            cols[name] = np.array(values)
    return cols


def read_imu(path: Path):
    """(t_s, acc_mps2, gyro_radps or None) of a canonical IMU file (``bootnav.core.csvio.read_imu_csv``)."""
    from bootnav.core.csvio import read_imu_csv

    d = read_imu_csv(path)
    return d.t_s, d.acc_mps2, d.gyro_radps


# ----------------------------------------------------------------------------------------- estimate
def estimate_foot(path: Path, settings) -> FootEstimate:
    """Path and stance of one foot-mounted IMU file (``process``); reads no truth.

    The times are put back on the file's own clock, the one its truth files use: the importer starts a
    recording at 0 and keeps the first sample's time as ``t0_source_s`` (10-20 ms on some voisard_ipol files,
    ~5 ms on pyshoe_vicon)."""
    from bootnav.postproc.pipeline import process

    t0 = time.perf_counter()
    result = process(path, settings)
    t_s = result.t_s + float(result.recording.meta.get("t0_source_s", 0.0))
    return FootEstimate(t_s, result.pos_n, np.asarray(result.stance, bool), time.perf_counter() - t0, result)


TWO_BOOT_FILES = ("imu_left.csv.gz", "imu_right.csv.gz")
LR = ("left", "right")


def estimate_two_boots(estimates: dict, settings) -> dict:
    """Both feet of one trial fused (``bootnav.postproc.twoboots``), when the trial has a left and a right
    foot file: ``{name: FootEstimate}`` of the fused feet plus ``"metrics"`` (truth-free figures); {} else."""
    if not all(estimates.get(n, ("",))[0] == "foot" for n in TWO_BOOT_FILES):
        return {}
    from bootnav.postproc.settings import ProcessSettings
    from bootnav.postproc.twoboots.run import fuse_for_evaluation

    fused = fuse_for_evaluation(estimates[TWO_BOOT_FILES[0]][1].result, estimates[TWO_BOOT_FILES[1]][1].result,
                                settings or ProcessSettings())
    out = {}
    for name, label in zip(TWO_BOOT_FILES, ("left", "right")):
        t_s, pos_n, stance = fused[label]  # on the file's own clock, as estimate_foot's
        t0 = float(estimates[name][1].result.recording.meta.get("t0_source_s", 0.0))
        out[name] = FootEstimate(t_s + t0, pos_n, stance, fused["seconds"])
    out["metrics"] = fused["metrics"]
    out["single_xy"] = {name: fused["single_xy"][label] for name, label in zip(TWO_BOOT_FILES, ("left", "right"))}
    out["walker_xy"] = fused["walker_xy"]
    return out


def estimate_pdr(path: Path, settings) -> PdrEstimate:
    """Steps of one lower-back / phone IMU file (``run_pdr``); reads no truth."""
    from bootnav.postproc.pdr import run_pdr

    t0 = time.perf_counter()
    t, acc, gyro = read_imu(path)
    res = run_pdr(t, acc, gyro, settings)
    step_xy = np.column_stack([res.x_m, res.y_m])
    return PdrEstimate(np.asarray(res.t_s), np.asarray(res.length_m), step_xy, time.perf_counter() - t0)


# -------------------------------------------------------------------------------------------- score
def _truth_json(folder: Path) -> dict:
    p = folder / "truth.json"
    return json.loads(p.read_text()) if p.exists() else {}


def score_foot(est: FootEstimate, folder: Path, kinds: list[str], imu_name: str) -> tuple[dict, dict]:
    """METRICS.md metrics of a foot-mounted estimate of ``imu_name`` for the truth ``kinds`` in ``folder``;
    (metrics, plot data). Used by ``bootnav eval`` and the foot comparison of benchmarks/pdr_table.py."""
    out: dict = {"seconds": est.seconds, "samples": int(len(est.t_s))}
    plot: dict = {"est_xy": est.pos_n[:, :2]}
    truth = _truth_json(folder)
    starts, stops = runs(est.stance)
    stance_t = est.t_s[(starts + stops - 1) // 2]  # mid-stance time of each stance phase
    stance_p = M.stance_positions(est.pos_n, est.stance)
    suffix = imu_name.replace("imu", "").replace(".csv.gz", "")  # "", "_b", "_left", ...
    if "trajectory" in kinds:
        tp = folder / f"truth_trajectory{suffix}.csv.gz"
        if not tp.exists():
            tp = folder / "truth_trajectory.csv.gz"
        c = read_csv_columns(tp)
        pos_truth = np.column_stack([c["x_m"], c["y_m"], c["z_m"]])
        out.update(M.trajectory_metrics(est.t_s, est.pos_n, c["t_s"], pos_truth))
        aligned, _, shift = M.align_to_truth(est.t_s, est.pos_n, c["t_s"], pos_truth, t_origin=c["t_s"][0])
        plot.update(est_xy=aligned[:, :2], truth_xy=(pos_truth - shift)[:, :2])
    if "stance" in kinds:
        sp = folder / f"truth_stance{suffix}.csv.gz"
        if not sp.exists():
            sp = folder / "truth_stance.csv.gz"
        c = read_csv_columns(sp)
        out.update(M.stance_metrics(est.t_s, est.stance, c["t_s"], c["stance"] > 0.5))
    if "closed_loop" in kinds:
        out.update(M.closed_loop_metrics(est.pos_n, est.stance))
    if "footprints" in kinds:
        c = read_csv_columns(folder / "truth_footprints.csv")
        fp_xy = np.column_stack([c["x_m"], c["y_m"]])
        n_true = int(truth.get("n_strides", len(fp_xy) - 1))
        # detected strides: stance phases between the first and last truth footprint times
        inside = (stance_t >= c["t_s"][0] - 0.25) & (stance_t <= c["t_s"][-1] + 0.25)
        r = M.footprint_metrics(est.t_s, est.pos_n, c["t_s"], fp_xy, n_detected_strides=None)
        r["stride_count_err"] = int(max(inside.sum() - 1, 0) - n_true)
        out.update(r)
        aligned, _, shift = M.align_to_truth(
            est.t_s, est.pos_n, c["t_s"], np.column_stack([fp_xy, np.zeros(len(fp_xy))]), t_origin=c["t_s"][0]
        )
        plot.update(est_xy=aligned[:, :2], truth_xy=fp_xy - shift[:2], truth_style="footprints")
    letter = FOOT_LETTER.get(imu_name)
    if "stride_lengths" in kinds and (folder / "truth_strides.csv").exists():
        c = read_csv_columns(folder / "truth_strides.csv")
        sel = c["foot"] == letter if letter else np.ones(len(c["t_start_s"]), bool)
        if sel.any():
            out.update(M.stride_length_metrics(est.t_s, est.pos_n, c["t_start_s"][sel], c["t_end_s"][sel],
                                               c["stride_length_m"][sel]))
    if "step_events" in kinds and letter and (folder / "truth_steps.csv").exists():
        c = read_csv_columns(folder / "truth_steps.csv")
        onsets = est.t_s[starts]  # first sample of each stance phase
        out.update(M.step_event_metrics(onsets, c["t_s"][c["foot"] == letter]))
    if "out_and_back" in kinds:
        uturn = (truth["uturn_t_start_s"], truth["uturn_t_end_s"]) if "uturn_t_start_s" in truth else None
        out.update(M.out_and_back_metrics(est.t_s, est.pos_n, stance_t, stance_p, truth["t_start_s"],
                                          truth["t_end_s"], truth["distance_m"], uturn=uturn))
        out["abs_distance_err_pct"] = abs(out["distance_err_pct"])
        if "distance_straight_err_pct" in out:
            out["abs_distance_straight_err_pct"] = abs(out["distance_straight_err_pct"])
    return out, plot


def _inside_walking_bouts(folder: Path, truth: dict, t: np.ndarray) -> np.ndarray:
    """mobgap_lab: step truth exists only inside the reference's walking bouts (its README says to
    restrict comparisons to them); elsewhere every detected step counts."""
    path = folder / "truth_walking_bouts.csv"
    if not path.exists():
        return np.ones(len(t), bool)
    c = read_csv_columns(path)
    source = truth.get("step_events_reference", "INDIP")
    rows = c["source"] == source
    if not rows.any():
        rows = np.ones(len(c["source"]), bool)
    mask = np.zeros(len(t), bool)
    for a, b in zip(c["t_start_s"][rows], c["t_end_s"][rows]):
        mask |= (t >= a - M.EVENT_TOLERANCE_S) & (t <= b + M.EVENT_TOLERANCE_S)
    return mask


def score_pdr(est: PdrEstimate, folder: Path, kinds: list[str]) -> tuple[dict, dict]:
    """METRICS.md metrics of a PDR estimate for the truth ``kinds`` in ``folder``; (metrics, plot data).

    The one PDR scoring of the project: ``bootnav eval`` and ``bootnav.postproc.evaluate.pdr`` (the PDR
    benchmark) both call it. Step events of mobgap_lab are scored inside the reference's walking bouts."""
    out: dict = {"seconds": est.seconds, "n_steps": int(len(est.step_t))}
    truth = _truth_json(folder)
    in_bouts = _inside_walking_bouts(folder, truth, est.step_t)
    if "step_events" in kinds:
        c = read_csv_columns(folder / "truth_steps.csv")
        out.update(M.step_event_metrics(est.step_t[in_bouts], c["t_s"]))
    if "step_count" in kinds:
        n_true = int(truth["steps"])
        r = M.step_count_metrics(len(est.step_t), n_true)
        out.setdefault("count_err_pct", r["count_err_pct"])
    if "count_err_pct" in out:
        out["abs_count_err_pct"] = abs(out["count_err_pct"])
    if "step_lengths" in kinds:
        c = read_csv_columns(folder / "truth_step_lengths.csv")
        out.update(M.step_length_metrics(est.step_t, est.step_len, c["t_s"], c["step_length_m"]))
    if "out_and_back" in kinds:
        out.update(M.step_distance_metrics(est.step_t, est.step_len, truth["t_start_s"], truth["t_end_s"],
                                           truth["distance_m"]))
        out["abs_distance_err_pct"] = abs(out["distance_err_pct"])
    return out, {"est_xy": est.step_xy}


# -------------------------------------------------------------------------------------------- trial
def _nan_stat(stat, values: list) -> float:
    """``np.nanmean`` / ``np.nanmedian`` of the values; NaN (without a warning) when none is defined."""
    v = np.asarray(values, float)
    return float(stat(v)) if np.any(~np.isnan(v)) else float("nan")


def _mean_metrics(per_file: list[dict]) -> dict:
    keys = {k for d in per_file for k, v in d.items() if isinstance(v, (int, float))}
    return {k: _nan_stat(np.nanmean, [d[k] for d in per_file if k in d]) for k in sorted(keys)}


def evaluate_trial(trial: dict, root: str, foot_settings=None, pdr_settings=None) -> TrialResult:
    """Estimate every IMU file of ``trial`` (no truth read), then score the estimates."""
    folder = Path(root) / trial["path"]
    res = TrialResult(trial["id"], trial["set"], trial["mount"])
    kinds = [k for k in trial["truth"] if k != "none"]
    imu_files = trial.get("imu_files") or {"imu.csv.gz": trial["mount"]}
    try:
        estimates = {}
        for name, mount in imu_files.items():
            path = folder / name
            if mount == "foot":
                estimates[name] = ("foot", estimate_foot(path, foot_settings))
            elif mount == "lower_back" or mount.startswith("phone"):
                estimates[name] = ("pdr", estimate_pdr(path, pdr_settings))
        if not estimates:
            raise ValueError(f"no IMU file with a mount bootnav processes: {imu_files}")
        try:  # a failed fusion never costs the trial its single-foot figures
            two_boots, two_boots_error = estimate_two_boots(estimates, foot_settings), None
        except Exception as exc:
            two_boots, two_boots_error = {}, f"{type(exc).__name__}: {exc}"
        # --- estimates are final; from here on truth may be read ---
        groups: dict[str, list[dict]] = {"foot": [], "pdr": []}
        for name, (kind, est) in estimates.items():
            if kind == "foot":
                scored, plot = score_foot(est, folder, kinds, name)
            else:
                scored, plot = score_pdr(est, folder, kinds)
            res.files[name] = scored
            res.plot_data[name] = plot
            groups[kind].append(scored)
        main = "foot" if trial["mount"] == "foot" else "pdr"
        for kind, rows in groups.items():
            if not rows:
                continue
            means = _mean_metrics(rows)
            if kind == main:
                res.metrics.update(means)
            res.metrics.update({f"{kind}_{k}": v for k, v in means.items()} if kind != main else {})
        if two_boots:  # the fused feet, beside the single-foot figures: keys two_boots_*
            rows = []
            for name in TWO_BOOT_FILES:
                scored, plot = score_foot(two_boots[name], folder, kinds, name)
                res.files[f"{name} (two boots)"] = scored
                res.plot_data[f"{name} (two boots)"] = {**plot, "single_xy": two_boots["single_xy"][name]}
                rows.append(scored)
            res.metrics.update({f"two_boots_{k}": v for k, v in {**_mean_metrics(rows), **two_boots["metrics"]}.items()})
            # both feet alone and fused and the walker in one plot, in the fusion's common frame
            res.plot_data["two boots"] = {"feet_xy": {
                **{f"{label} alone": two_boots["single_xy"][name] for name, label in zip(TWO_BOOT_FILES, LR)},
                **{f"{label} fused": two_boots[name].pos_n[:, :2] for name, label in zip(TWO_BOOT_FILES, LR)},
                "walker (fused midpoint)": two_boots["walker_xy"]}}
        if two_boots_error:
            res.files["two boots"] = {"error": two_boots_error}
    except Exception as exc:  # a failure is reported with its reason, never skipped
        res.status = "failed"
        res.reason = f"{type(exc).__name__}: {exc}"
        res.metrics = {}
        res.plot_data = {"traceback": traceback.format_exc(limit=4)}
    return res


def _worker(args):
    trial, root, foot_settings, pdr_settings = args
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    return evaluate_trial(trial, root, foot_settings, pdr_settings)


def evaluate_all(root, trials: list[dict], jobs: int | None = None, foot_settings=None, pdr_settings=None,
                 progress=None) -> list[TrialResult]:
    """Evaluate trials on ``jobs`` processes (default: all cores); ``progress(done, total, result)``."""
    jobs = jobs or os.cpu_count() or 1
    work = [(t, str(root), foot_settings, pdr_settings) for t in trials]
    results: list[TrialResult] = []
    if jobs == 1:
        for k, w in enumerate(work):
            results.append(_worker(w))
            if progress:
                progress(k + 1, len(work), results[-1])
    else:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            futures = [pool.submit(_worker, w) for w in work]
            for k, fut in enumerate(as_completed(futures)):
                results.append(fut.result())
                if progress:
                    progress(k + 1, len(work), results[-1])
    order = {t["id"]: i for i, t in enumerate(trials)}
    return sorted(results, key=lambda r: order[r.id])


def dataset_summary(results: list[TrialResult]) -> dict:
    """Per dataset: mean and median of every metric over its successful trials, plus failure counts.

    A metric that is undefined in a trial (NaN: a zero denominator, ``metrics`` module docstring) is left
    out of the mean and median; ``n_undefined`` maps each such metric to the number of trials."""
    out: dict = {}
    for set_name in dict.fromkeys(r.set for r in results):
        rows = [r for r in results if r.set == set_name]
        ok = [r.metrics for r in rows if r.status == "ok"]
        keys = sorted({k for m in ok for k in m})
        summary = {k: _nan_stat(np.nanmean, [m[k] for m in ok if k in m]) for k in keys}
        summary.update({f"median_{k}": _nan_stat(np.nanmedian, [m[k] for m in ok if k in m]) for k in keys})
        summary["n_trials"] = len(rows)
        summary["n_failed"] = len(rows) - len(ok)
        undefined = {k: sum(1 for m in ok if k in m and np.isnan(m[k])) for k in keys}
        summary["n_undefined"] = {k: n for k, n in undefined.items() if n}
        out[set_name] = summary
    return out
