"""Foot-mounted accuracy vs the goals of issue 5, read from a ``bootnav eval`` output (metrics.json).

    bootnav eval ../shared/datasets --out out/eval_foot --jobs 2 --no-plots \\
        --sets pyshoe_vicon xio_ngimu_loops openshoe_820 koroglu_footprints koroglu_rectangles \\
               iez_mpu6050 voisard_ipol gaitmap_example
    .venv/bin/python benchmarks/accuracy_foot.py out/eval_foot/metrics.json

Prints one row per goal: dataset, metric, ours (mean over the set's trials, plus the worst trial), the goal
and the pyshoe anchor (issue 5: pyshoe with its published defaults, one configuration for all trials).
``--run ROOT`` runs the eval itself first (into a temporary folder, foot sets only, no plots).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

# (dataset, metric, goal: upper bound, goal text, pyshoe anchor text)
GOALS = [
    ("pyshoe_vicon", "armse_2d", 0.06, "<= 0.06 m, no trial > 0.2 m", "0.39 m"),
    ("xio_ngimu_loops", "closure_pct", 0.3, "<= 0.3 %", "1.5 %"),
    ("openshoe_820", "closure_pct", 0.3, "<= 0.3 %", "1.1 %"),
    ("koroglu_footprints", "final_fp_err_pct", 2.0, "<= 2 %", "5.0 %"),
    ("koroglu_rectangles", "closure_pct", 1.0, "<= 1 %", "4.1 %"),
    ("iez_mpu6050", "closure_pct", 1.0, "<= 1 %", "3.9 %"),
    ("iez_mpu6050", "closure_v_m", 0.1, "<= 0.1 m", "0.50 m"),
    ("voisard_ipol", "foot_abs_distance_err_pct", 1.5, "<= 1.5 %", "3.7 %"),
    ("gaitmap_example", "stride_mae_m", 0.02, "<= 0.02 m", "0.045 m"),
]
FOOT_SETS = sorted({g[0] for g in GOALS})


def goals_table(metrics: dict) -> list[dict]:
    """One dict per goal with mean, worst trial, goal and anchor (NaN where the eval has no such metric)."""
    rows = []
    for ds, key, bound, goal, anchor in GOALS:
        per_trial = [m["metrics"].get(key) if "metrics" in m else m.get(key)
                     for tid, m in metrics.get("trials", {}).items() if tid.startswith(ds + "/")]
        vals = [v for v in per_trial if isinstance(v, (int, float)) and math.isfinite(v)]
        mean = metrics.get("datasets", {}).get(ds, {}).get(key)
        mean = float("nan") if mean is None else mean  # null in metrics.json: undefined in every trial
        worst = max(vals) if vals else float("nan")
        rows.append({"dataset": ds, "metric": key, "ours": mean, "worst": worst, "n": len(vals),
                     "goal": goal, "met": bool(mean <= bound), "pyshoe": anchor})
    return rows


def print_table(rows: list[dict]) -> None:
    print("| dataset | metric | ours (mean) | worst trial | trials | goal | met | pyshoe |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['dataset']} | {r['metric']} | {r['ours']:.4g} | {r['worst']:.4g} | {r['n']} | {r['goal']} | "
              f"{'yes' if r['met'] else 'no'} | {r['pyshoe']} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("metrics", nargs="?", help="metrics.json written by `bootnav eval`")
    ap.add_argument("--run", metavar="ROOT", help="run `bootnav eval ROOT` on the foot sets first")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    if a.run:
        out = Path(tempfile.mkdtemp(prefix="bootnav_foot_"))
        subprocess.run([sys.executable, "-m", "bootnav.cli", "eval", a.run, "--out", str(out), "--jobs",
                        str(a.jobs), "--no-plots", "--sets", *FOOT_SETS], check=True)
        a.metrics = str(out / "metrics.json")
    if not a.metrics:
        ap.error("give metrics.json or --run ROOT")
    metrics = json.loads(Path(a.metrics).read_text())
    failed = {tid: m.get("reason") for tid, m in metrics.get("trials", {}).items()
              if m.get("status", "ok") != "ok" and tid.split("/")[0] in FOOT_SETS}
    print_table(goals_table(metrics))
    for tid, why in failed.items():
        print(f"FAILED {tid}: {why}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
