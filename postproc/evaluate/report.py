"""metrics.json, a Markdown report with one table per dataset, and a path-vs-truth plot per trial."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.core.jsonio import to_jsonable
from bootnav.postproc.evaluate.runner import TrialResult, dataset_summary

# Metrics shown first in each dataset's table (the rest follow alphabetically in metrics.json only).
HEADLINE = [
    "armse_2d", "mean_h_err_m", "final_h_err_m", "mean_v_err_m", "stance_precision", "stance_recall",
    "closure_pct", "closure_h_m", "closure_v_m", "distance_m",
    "final_fp_err_pct", "mean_fp_err_m", "stride_count_err",
    "stride_mae_m", "stride_bias_m",
    "distance_err_pct", "abs_distance_err_pct", "foot_abs_distance_err_pct",
    "distance_straight_err_pct", "abs_distance_straight_err_pct", "foot_abs_distance_straight_err_pct",
    "f1", "precision", "recall", "count_err_pct", "abs_count_err_pct",
    "step_len_mae_m", "step_len_bias_m", "seconds",
]


def _fmt(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—"
    if isinstance(v, float):
        return f"{v:.3g}" if abs(v) < 1000 else f"{v:.0f}"
    return str(v)


def write_metrics_json(results: list[TrialResult], path: Path, extra: dict | None = None) -> dict:
    """Write every trial's metrics and the per-dataset summary; an undefined metric (NaN) is ``null``."""
    doc = {
        "trials": {
            r.id: {"set": r.set, "mount": r.mount, "status": r.status, "reason": r.reason, **r.metrics,
                   "files": r.files}
            for r in results
        },
        "datasets": dataset_summary(results),
    }
    if extra:
        doc.update(extra)
    atomic.write_text(path, json.dumps(to_jsonable(doc), indent=1, allow_nan=False))
    return doc


def plot_trial(result: TrialResult, out_dir: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for name, data in result.plot_data.items():
        if "feet_xy" in data:
            paths.append(_plot_feet(result, name, data["feet_xy"], out_dir))
        if "est_xy" not in data:
            continue
        fig, ax = plt.subplots(figsize=(6, 5))
        est = np.asarray(data["est_xy"])
        ax.plot(est[:, 0], est[:, 1], "-", lw=1.2, label="bootnav estimate")
        if "single_xy" in data:  # a fused foot (two boots): the same foot processed alone
            single = np.asarray(data["single_xy"])
            ax.plot(single[:, 0], single[:, 1], ":", lw=0.9, color="tab:gray", label="this foot alone")
        ax.plot(est[0, 0], est[0, 1], "go", label="start")
        ax.plot(est[-1, 0], est[-1, 1], "rs", label="end")
        if "truth_xy" in data:
            tr = np.asarray(data["truth_xy"])
            style = "k.:" if data.get("truth_style") == "footprints" else "k:"
            ax.plot(tr[:, 0], tr[:, 1], style, lw=1.2, label="truth")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x east [m]")
        ax.set_ylabel("y north [m]")
        m = result.files.get(name, {})
        key = next((k for k in ("armse_2d", "closure_pct", "final_fp_err_pct", "abs_distance_err_pct",
                                "stride_mae_m", "f1") if k in m), None)
        title = f"{result.id} · {name}"
        if key:
            title += f"\n{key} = {_fmt(m[key])}"
        ax.set_title(title, fontsize=9)
        paths.append(_finish_plot(fig, ax, out_dir, result.id, name.replace(".csv.gz", "")))
    return paths


FEET_STYLE = {"left alone": ("tab:blue", ":", 0.9), "right alone": ("tab:red", ":", 0.9),
              "left fused": ("tab:blue", "-", 1.0), "right fused": ("tab:red", "-", 1.0),
              "walker (fused midpoint)": ("k", "-", 1.6)}


def _plot_feet(result: TrialResult, name: str, feet_xy: dict, out_dir: Path) -> Path:
    """Both feet of a two-boot trial, alone and fused, and the walker, from above (the fusion's frame)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 5))
    for label, xy in feet_xy.items():
        color, ls, lw = FEET_STYLE.get(label, (None, "-", 1.0))
        xy = np.asarray(xy)
        ax.plot(xy[:, 0], xy[:, 1], ls=ls, lw=lw, color=color, label=label)
    walker = np.asarray(feet_xy["walker (fused midpoint)"])
    ax.plot(walker[0, 0], walker[0, 1], "go", label="start")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m] (left foot's frame)")
    ax.set_ylabel("y [m]")
    m = result.metrics
    ax.set_title(f"{result.id} · {name}\nbound active at {_fmt(m.get('two_boots_active_updates'))} of "
                 f"{_fmt(m.get('two_boots_checks'))} checks", fontsize=9)
    return _finish_plot(fig, ax, out_dir, result.id, name.replace(" ", "_"))


def _finish_plot(fig, ax, out_dir: Path, trial_id: str, stem: str) -> Path:
    """Grid, legend and layout of an eval plot; saved as ``<trial>__<stem>.png``, closed; returns the path."""
    import matplotlib.pyplot as plt

    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    p = out_dir / (trial_id.replace("/", "__") + "__" + stem + ".png")
    atomic.replace_with(p, lambda tmp: fig.savefig(tmp, dpi=90, format="png"))  # never half written
    plt.close(fig)
    return p


def write_report(results: list[TrialResult], doc: dict, out_dir: Path, header: str = "") -> Path:
    lines = ["# bootnav evaluation report", ""]
    if header:
        lines += [header, ""]
    for set_name, summary in doc["datasets"].items():
        rows = [r for r in results if r.set == set_name]
        keys = [k for k in HEADLINE if any(k in r.metrics for r in rows)]
        lines += [f"## {set_name}", "", f"{summary['n_trials']} trials, {summary['n_failed']} failed.", ""]
        if summary["n_undefined"]:
            counts = ", ".join(f"`{k}` in {n}" for k, n in summary["n_undefined"].items())
            lines += [f"Undefined (zero denominator; — below, left out of mean and median): {counts} "
                      f"trial(s).", ""]
        if keys:
            lines.append("| trial | " + " | ".join(keys) + " |")
            lines.append("|---|" + "---|" * len(keys))
            for r in rows:
                if r.status != "ok":
                    continue
                lines.append(f"| {r.id.split('/', 1)[1]} | " + " | ".join(_fmt(r.metrics.get(k)) for k in keys) + " |")
            lines.append("| **mean** | " + " | ".join(_fmt(summary.get(k)) for k in keys) + " |")
            lines.append("| **median** | " + " | ".join(_fmt(summary.get(f"median_{k}")) for k in keys) + " |")
        failed = [r for r in rows if r.status != "ok"]
        if failed:
            lines += ["", "Failures:"] + [f"- `{r.id}`: {r.reason}" for r in failed]
        lines.append("")
    lines += two_boot_section(doc)
    path = out_dir / "report.md"
    atomic.write_text(path, "\n".join(lines))
    return path


TWO_BOOT_METRICS = ("abs_distance_err_pct", "distance_err_pct", "abs_distance_straight_err_pct", "stride_mae_m", "armse_2d", "closure_pct",
                    "final_fp_err_pct")


def two_boot_section(doc: dict) -> list[str]:
    """Report lines: per dataset with two feet per trial, each foot alone (mean of both) vs both fused
    (``bootnav.postproc.twoboots``), and the fusion's truth-free figures."""
    lines = []
    for set_name, s in doc["datasets"].items():
        if "two_boots_checks" not in s:
            continue
        if not lines:
            lines += ["## Two boots: each foot alone vs both feet fused", "",
                      "Trials with a left and a right foot file: both feet fused with the maximum-separation bound "
                      "(`bootnav process --two-boots`, default `TwoBootSettings`); alone = the mean over the two "
                      "feet of the single-foot figures above.", "",
                      "| dataset | metric | alone | fused |", "|---|---|---|---|"]
        for key in TWO_BOOT_METRICS:
            alone = s.get(f"foot_{key}", s.get(key))  # a trial whose main mount is not a foot keeps foot_*
            if alone is not None and f"two_boots_{key}" in s:
                lines.append(f"| {set_name} | {key} | {_fmt(alone)} | {_fmt(s[f'two_boots_{key}'])} |")
        lines.append(f"| {set_name} | climb difference left-right, m | {_fmt(s.get('two_boots_climb_single_diff_m'))} | "
                     f"{_fmt(s.get('two_boots_climb_fused_diff_m'))} |")
        lines.append(f"| {set_name} | constraint updates / checks | | {_fmt(s.get('two_boots_active_updates'))} / "
                     f"{_fmt(s.get('two_boots_checks'))} |")
        lines.append(f"| {set_name} | gait-symmetry clock offset (residual), ms | | "
                     f"{_fmt(s.get('two_boots_clock_offset_ms'))} ({_fmt(s.get('two_boots_clock_residual_ms'))}) |")
    return lines + ([""] if lines else [])
