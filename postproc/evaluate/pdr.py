"""PDR accuracy on the developer datasets (lower-back and phone trials), for benchmarks/pdr_table.py.

In ``evaluate`` (not ``pdr``): evaluation uses PDR, PDR never uses evaluation (one-way packages).

Scoring is ``bootnav eval``'s, not a copy: a trial's steps come from
``bootnav.postproc.evaluate.runner.estimate_pdr`` and its METRICS.md metrics from ``runner.score_pdr``
(definitions and empty cases: ``bootnav.postproc.evaluate.metrics``). This module adds the dataset walk
(``list_trials``), per-detector settings and diagnostics that are not METRICS.md metrics
(``alternation_corrected_count``, ``count_err_in_truth_span_pct``). A trial that cannot be processed is
returned with ``error`` set, never skipped silently.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.postproc.evaluate.metrics import EVENT_TOLERANCE_S, count_err_pct
from bootnav.postproc.evaluate.runner import estimate_pdr, score_pdr


@dataclass
class Trial:
    """One PDR-relevant trial of a dataset tree with a manifest.json (lower back or phone)."""

    id: str
    set: str
    mount: str
    path: Path
    imu_file: str
    truth: list  # the manifest's truth kinds
    t_steps: np.ndarray | None = None  # true step events, s (diagnostics and the foot comparison)
    feet: np.ndarray | None = None  # L/R/unknown per true step
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
            t.info["truth_json"] = json.loads((p / "truth.json").read_text())
        out.append(t)
    return out


def evaluate_trial(trial: Trial, settings=None) -> dict:
    """Run the PDR pipeline on one trial and score it exactly as ``bootnav eval`` does.

    Parameters
    ----------
    trial : Trial
        From ``list_trials``.
    settings : PdrSettings, optional
        Detector, length model, ... (default ``PdrSettings()``, the ``bootnav eval`` configuration).

    Returns
    -------
    dict
        ``id``, ``set``, ``mount``, ``detector``, ``length``, ``error`` (None, or the reason the trial
        failed), the METRICS.md metrics of ``runner.score_pdr`` and, for oxford_steps, the diagnostics
        ``count_err_vs_alternating_truth_pct`` and ``count_err_in_truth_span_pct``.
    """
    from bootnav.postproc.pdr.pipeline import PdrSettings

    settings = settings or PdrSettings()
    row = {"id": trial.id, "set": trial.set, "mount": trial.mount, "detector": settings.detector,
           "length": settings.length, "error": None}
    try:
        est = estimate_pdr(trial.path / trial.imu_file, settings)
        row.update(score_pdr(est, trial.path, trial.truth)[0])
    except Exception as exc:  # a failure is a result with its reason, never skipped
        row["error"] = f"{type(exc).__name__}: {exc}"
        return row
    t_det, t_true = est.step_t, trial.t_steps
    if t_true is not None and trial.feet is not None and trial.set == "oxford_steps":
        n_alt = alternation_corrected_count(t_true, trial.feet)
        row["count_err_vs_alternating_truth_pct"] = count_err_pct(int(t_det.size), n_alt)
        # DIAGNOSTIC: steps counted while the insoles were logging steps (handling before the first / after
        # the last true step excluded), to separate walk-edge errors from in-walk errors
        span = (t_det >= t_true.min() - EVENT_TOLERANCE_S) & (t_det <= t_true.max() + EVENT_TOLERANCE_S)
        row["count_err_in_truth_span_pct"] = count_err_pct(int(np.sum(span)), int(t_true.size))
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
