"""Rate invariance: the same developer recordings at lower sample rates, scored like the originals.

Issue 11 asks that every window, threshold and noise be stated in physical units, so that a recording of
the same walk at a lower rate gives the same figures up to the information really lost. This script makes
the lower-rate copies and scores them with METRICS.md next to the native rate:

* decimation by an integer factor k, default **block mean** ("mean"): each output sample is the mean over
  its output interval, the span of k input intervals on the recorded clock, time-stamped at the interval's
  end. That is what a lower-rate MEMS sensor delivers (its digital low-pass / accumulate-and-dump stage
  averages the fast internal samples before the output register is read), and it keeps every velocity and
  angle increment ∫f dt, ∫ω dt over an output interval exactly, so the strapdown integration sees the same
  Δv and Δθ as at the native rate; its sinc response lets some energy above the new Nyquist alias, as a real
  sensor's does. The increments are those the filter integrates at the native rate (``ins.mechanization``):
  row j stands for the interval (t_{j−1}, t_j], so a row repeated with the same time stamp (a packet logged
  twice: every one of x-io's 457 repeated rows has identical values) counts once, and the row after lost
  samples stands for the whole gap. On a uniform clock this is the mean of k consecutive rows.
  ``--method rows`` is the plain mean of k consecutive rows stamped at their mean time (this script's
  block mean before 2026-12-02): on a clock with repeated rows and gaps it weights a repeated row twice and
  a lost interval not at all, so its copies of x-io's walks carry attitude increments up to 1° away from
  what the native run integrates (docs/tuning-log.md, "Rates, second round"). ``--method decimate`` uses
  ``scipy.signal.decimate`` instead (zero-phase FIR anti-alias filter, then every k-th sample): cleaner
  spectrum, but it rings around heel-strike shocks and does not preserve the increments;
* every factor k is run at its k **phases** (``--phases all``, the default): the k ways of grouping the same
  rows into output intervals (leave out the first 0 … k − 1 rows). The grouping alone moves a loop's closure
  by up to a tenth of its value, as much as the rate; the figure of a rate is the mean over its phases and
  the table prints their range (the noise of the figure);
* the copies (imu*.csv.gz, timestamps never resampled) go into a dataset tree under ``--work`` with
  links to the original truth files and a manifest, so ``bootnav.postproc.evaluate.runner.evaluate_all``
  scores them exactly as ``bootnav eval`` scores the originals;
* ``--noise-convention density`` re-runs the lower rates with the per-sample filter noises rescaled to
  keep their DENSITY at the recording's rate (σ_rate = σ · sqrt(f_rate / f_native), for σ_acc, σ_gyro,
  σ_zupt, σ_zaru, the lever arm and the ZARU rate factor), i.e. what the filter would do if its settings
  were densities; the default ("sample") keeps the settings as they are (per sample at any rate).

Default plan (issue 11): openshoe_820 820 -> 410 / 273 / 205 Hz, xio_ngimu_loops 400 -> 200 / 100 Hz,
pyshoe_vicon 200 -> 100 Hz, gaitmap_example 204.8 -> 102.4 Hz, plus both koroglu sets 200 -> 100 Hz.

    .venv/bin/python benchmarks/rates.py [--plan openshoe_820=2,3,4 ...] [--method mean|rows|decimate]
        [--noise-convention sample|density|both] [--set filter.zupt_onset_delay_s=0.1] [--json out.json]

Prints, per dataset and metric, the figure at the native rate and at each lower rate (± SE over trials, the
range over the phases) and the ratio to native; runs in a few minutes on 2 cores.
"""

from __future__ import annotations

import argparse
import gzip
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from crossval import PRIMARY, current_value, parse_value, set_figures, settings_with  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DEFAULT_ROOT = REPO.parent / "shared" / "datasets"
PLAN = {"openshoe_820": [2, 3, 4], "xio_ngimu_loops": [2, 4], "pyshoe_vicon": [2], "gaitmap_example": [2],
        "koroglu_footprints": [2], "koroglu_rectangles": [2]}
EXTRA_METRICS = {"xio_ngimu_loops": ["closure_v_m"], "openshoe_820": ["closure_v_m"],
                 "koroglu_rectangles": ["closure_v_m"], "iez_mpu6050": ["closure_v_m"]}
IMU_COLUMNS = "t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps"
# per-sample settings rescaled by sqrt(f_rate / f_native) under the density convention
DENSITY_SCALED = ("filter.sigma_acc_mps2", "filter.sigma_gyro_radps", "filter.sigma_zupt_mps",
                  "filter.sigma_zaru_radps", "filter.zupt_lever_arm_m", "filter.zaru_rate_factor")


# ------------------------------------------------------------------------------------------- decimation
def decimate_block_mean(t_s: np.ndarray, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean of k consecutive samples (the tail that does not fill a block is dropped); time = block mean.

    Parameters
    ----------
    t_s : (N,) sample times, s.
    x : (N, m) samples.
    k : decimation factor (>= 1).

    Returns
    -------
    (t_s, x) of length N // k.
    """
    n = (len(t_s) // k) * k
    return t_s[:n].reshape(-1, k).mean(axis=1), x[:n].reshape(-1, k, x.shape[1]).mean(axis=1)


def decimate_increments(t_s: np.ndarray, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Mean over each output interval of k input intervals on the recorded clock, stamped at its end.

    Row j stands for the interval (t_{j−1}, t_j] (the filter's own rule at the native rate, so a row whose
    time stamp repeats the previous one has no weight and the row after a gap stands for the whole gap). The
    output sample m > 0 is (∫x dt over (T_{m−1}, T_m]) / (T_m − T_{m−1}), T_m = the time of kept row m·k; the
    output sample 0 is the first row (a record starts at rest). On a uniform clock: the mean of rows
    (m−1)k+1 … mk.

    Parameters
    ----------
    t_s : (N,) sample times, s (non-decreasing).
    x : (N, m) samples.
    k : decimation factor (>= 1).

    Returns
    -------
    (t_s, x) of length ceil(N' / k), N' = rows with a positive interval plus the first.
    """
    keep = np.r_[True, np.diff(t_s) > 0]
    t, x = t_s[keep], x[keep]
    cum = np.vstack([np.zeros((1, x.shape[1])), np.cumsum(x[1:] * np.diff(t)[:, None], axis=0)])
    idx = np.arange(0, len(t), k)
    y = np.diff(cum[idx], axis=0) / np.diff(t[idx])[:, None]
    return t[idx], np.vstack([x[:1], y])


DECIMATORS = {"mean": decimate_increments, "rows": decimate_block_mean}
# tree folder per method under --work (reused between runs): "mean" got a new folder when it became the
# interval mean, so that a tree of the old row mean is never taken for it
TREE_NAMES = {"mean": "interval-mean"}


def decimate_fir(t_s: np.ndarray, x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.signal.decimate`` (zero-phase FIR anti-alias filter, then every k-th sample)."""
    from scipy.signal import decimate

    y = decimate(x, k, ftype="fir", axis=0, zero_phase=True)
    return t_s[::k][: len(y)], y


def read_imu(path: Path) -> np.ndarray:
    """(N, 1 + 3 [+ 3]) array t, acc[, gyro] of a canonical IMU file (the one reader, ``read_imu_csv``)."""
    from bootnav.core.csvio import read_imu_csv

    d = read_imu_csv(path)
    cols = [d.t_s[:, None], d.acc_mps2] + ([d.gyro_radps] if d.gyro_radps is not None else [])
    return np.hstack(cols)


def make_tree(root: Path, trials: list[dict], k: int, method: str, work: Path,
              phase: int = 0) -> tuple[Path, list[dict]]:
    """Dataset tree with every trial's IMU files decimated by k (truth files linked); (root, trials).

    ``phase`` (0 … k − 1): the first ``phase`` rows are left out, so the k phases are the k ways of grouping
    the same rows into output intervals."""
    out = work / (f"{TREE_NAMES.get(method, method)}_x{k}" + (f"_p{phase}" if phase else ""))
    new_trials = []
    for t in trials:
        src, dst = root / t["path"], out / t["path"]
        dst.mkdir(parents=True, exist_ok=True)
        imu_names = list(t.get("imu_files") or {"imu.csv.gz": t["mount"]})
        for f in src.iterdir():
            target = dst / f.name
            if f.name in imu_names:
                if not target.exists():
                    data = read_imu(f)
                    fn = DECIMATORS.get(method, decimate_fir)
                    ts, x = fn(data[phase:, 0], data[phase:, 1:], k)
                    tmp = target.with_suffix(".tmp")
                    with gzip.open(tmp, "wt") as fh:
                        fh.write(IMU_COLUMNS + "\n")
                        np.savetxt(fh, np.column_stack([ts, x]), fmt="%.10g", delimiter=",")
                    tmp.rename(target)
            elif not target.exists():
                target.symlink_to(f.resolve())
        new_trials.append({**t, "rate_hz": t["rate_hz"] / k})
    manifest = out / "manifest.json"  # the tree is shared by every dataset decimated by k: keep the others
    ids = {t["id"] for t in new_trials}
    old = json.loads(manifest.read_text())["trials"] if manifest.exists() else []
    manifest.write_text(json.dumps({"format_version": 1, "trials": [t for t in old if t["id"] not in ids] + new_trials},
                                   indent=1))
    return out, new_trials


# ---------------------------------------------------------------------------------------------- scoring
def density_overrides(base: dict, factor: float) -> dict:
    """``base`` overrides plus the per-sample noises rescaled by sqrt(factor) (factor = f_rate / f_native)."""
    out = dict(base)
    for path in DENSITY_SCALED:
        v = out.get(path)
        if v is None:
            v = current_value(path)
        out[path] = float(v) * math.sqrt(factor)
    return out


def score(root: Path, trials: list[dict], overrides: dict, jobs: int) -> dict:
    from bootnav.postproc.evaluate.runner import evaluate_all

    rows = {}
    for r in evaluate_all(root, trials, jobs=jobs, foot_settings=settings_with(overrides)):
        rows[r.id] = {"set": r.set, "status": r.status, "reason": r.reason, "metrics": r.metrics, "files": r.files}
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    ap.add_argument("--plan", nargs="*", default=None, metavar="SET=K1,K2",
                    help="decimation factors per dataset (default: issue 11's plan, see above)")
    ap.add_argument("--method", choices=["mean", "rows", "decimate"], default="mean")
    ap.add_argument("--noise-convention", choices=["sample", "density", "both"], default="sample")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="settings override for every run, e.g. filter.zupt_onset_delay_s=0.1")
    ap.add_argument("--work", type=Path, default=Path("/tmp/bootnav_rates"), help="decimated trees (reused)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--phases", choices=["all", "first"], default="all",
                    help="all (default): every one of the k groupings of the rows into output intervals, the "
                         "figure their mean and their range printed; first: the grouping from row 0 only")
    a = ap.parse_args(argv)

    plan = dict(PLAN)
    if a.plan:
        plan = {}
        for item in a.plan:
            s, _, ks = item.partition("=")
            plan[s] = [int(k) for k in ks.split(",") if k]
    base = {}
    for item in a.set:
        k, _, v = item.partition("=")
        base[k] = parse_value(v)
    manifest = json.loads((a.root / "manifest.json").read_text())
    conventions = ["sample", "density"] if a.noise_convention == "both" else [a.noise_convention]
    t0 = time.perf_counter()
    results: dict = {}
    for set_name, factors in plan.items():
        trials = [t for t in manifest["trials"] if t["set"] == set_name]
        metric_list = [PRIMARY[set_name]] + EXTRA_METRICS.get(set_name, [])
        native = score(a.root, trials, base, a.jobs)
        res = {"native": {"rate_hz": trials[0]["rate_hz"], "figures": {m: set_figures(native, set_name, m)
                                                                        for m in metric_list}}}
        for k in factors:
            for conv in conventions:
                ov = base if conv == "sample" else density_overrides(base, 1.0 / k)
                per_phase = []
                for phase in range(k if a.phases == "all" else 1):
                    root_k, trials_k = make_tree(a.root, trials, k, a.method, a.work, phase)
                    per_phase.append(score(root_k, trials_k, ov, a.jobs))
                res[f"/{k} {conv}"] = {"rate_hz": trials[0]["rate_hz"] / k,
                                       "figures": {m: phase_figures(per_phase, set_name, m) for m in metric_list},
                                       "failed": {tid: r["reason"] for rows in per_phase for tid, r in rows.items()
                                                  if r["status"] != "ok"}}
        results[set_name] = res
    print_table(results, a.method)
    print(f"\n({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    if a.json:
        a.json.write_text(json.dumps({"method": a.method, "overrides": base, "results": results}, indent=1,
                                     default=float, allow_nan=True))
    return 0


def phase_figures(per_phase: list[dict], set_name: str, metric: str) -> dict:
    """``set_figures`` of the per-trial means over the phases, plus ``phases``: the set's figure per phase.

    Why the phases: which k rows form one output interval is arbitrary, and on a walk of ~50 strides the
    grouping alone moves a closure by up to a tenth of its value (openshoe_820 at 410 Hz: 0.555 / 0.605 %),
    as much as the rate itself; the mean over the k groupings is the rate's figure, their range its noise."""
    figs = [set_figures(rows, set_name, metric) for rows in per_phase]
    if len(figs) == 1:
        return {**figs[0], "phases": [figs[0]["mean"]]}
    merged = {}
    for tid in per_phase[0]:
        rs = [rows[tid] for rows in per_phase]
        ok = all(r["status"] == "ok" for r in rs)
        vals = [float(r["metrics"].get(metric, math.nan)) if ok else math.nan for r in rs]
        merged[tid] = {"set": rs[0]["set"], "status": "ok" if ok else "failed", "reason": rs[0]["reason"],
                       "metrics": {metric: float(np.mean(vals))}, "files": {}}
    return {**set_figures(merged, set_name, metric), "phases": [f["mean"] for f in figs]}


def _cell(f: dict) -> str:
    if f["failed"]:
        return f"FAIL ({len(f['failed'])})"
    if f["n"] > 1 and math.isfinite(f["se"]):
        return f"{f['mean']:.4g} ± {f['se']:.2g}"
    return f"{f['mean']:.4g}"


def _phase_range(f: dict) -> str:
    ph = [v for v in f.get("phases", []) if math.isfinite(v)]
    return f"{min(ph):.4g} – {max(ph):.4g}" if len(ph) > 1 else ""


def print_table(results: dict, method: str) -> None:
    print(f"\n### Rate invariance ({method} decimation; figure ± SE over trials, mean over the k phases; ratio to "
          f"native; range of the set's figure over the phases)\n")
    print("| dataset | metric | rate | figure | / native | phases | failed |")
    print("|---|---|---|---|---|---|---|")
    for set_name, res in results.items():
        metrics = list(res["native"]["figures"])
        for m in metrics:
            nat = res["native"]["figures"][m]["mean"]
            for label, r in res.items():
                f = r["figures"][m]
                ratio = f["mean"] / nat if nat and math.isfinite(f["mean"]) else float("nan")
                rate = f"{r['rate_hz']:.4g} Hz" + ("" if label == "native" else f" ({label})")
                failed = ", ".join(r.get("failed", {})) or ""
                print(f"| {set_name} | `{m}` | {rate} | {_cell(f)} | {ratio:.2f} | {_phase_range(f)} | {failed} |")


if __name__ == "__main__":
    raise SystemExit(main())
