"""Rate invariance: the same developer recordings at lower sample rates, scored like the originals.

Issue 11 asks that every window, threshold and noise be stated in physical units, so that a recording of
the same walk at a lower rate gives the same figures up to the information really lost. This script makes
the lower-rate copies and scores them with METRICS.md next to the native rate:

* decimation by an integer factor k, default **block mean** ("mean"): each output sample is the mean of k
  consecutive input samples, time-stamped at their mean time. That is what a lower-rate MEMS sensor
  delivers (its digital low-pass / accumulate-and-dump stage averages the fast internal samples before the
  output register is read), and it keeps every velocity and angle increment ∫f dt, ∫ω dt over an output
  interval exactly, so the strapdown integration sees the same Δv and Δθ; its sinc response lets some
  energy above the new Nyquist alias, as a real sensor's does. ``--method decimate`` uses
  ``scipy.signal.decimate`` instead (zero-phase FIR anti-alias filter, then every k-th sample): cleaner
  spectrum, but it rings around heel-strike shocks and does not preserve the increments;
* the copies (imu*.csv.gz, timestamps never resampled) go into a dataset tree under ``--work`` with
  links to the original truth files and a manifest, so ``bootnav.postproc.evaluate.runner.evaluate_all``
  scores them exactly as ``bootnav eval`` scores the originals;
* ``--noise-convention density`` re-runs the lower rates with the per-sample filter noises rescaled to
  keep their DENSITY at the recording's rate (σ_rate = σ · sqrt(f_rate / f_native), for σ_acc, σ_gyro,
  σ_zupt, σ_zaru, the lever arm and the ZARU rate factor), i.e. what the filter would do if its settings
  were densities; the default ("sample") keeps the settings as they are (per sample at any rate).

Default plan (issue 11): openshoe_820 820 -> 410 / 273 / 205 Hz, xio_ngimu_loops 400 -> 200 / 100 Hz,
pyshoe_vicon 200 -> 100 Hz, gaitmap_example 204.8 -> 102.4 Hz, plus both koroglu sets 200 -> 100 Hz.

    .venv/bin/python benchmarks/rates.py [--plan openshoe_820=2,3,4 ...] [--method mean|decimate]
        [--noise-convention sample|density|both] [--set filter.zupt_onset_delay_s=0.1] [--json out.json]

Prints, per dataset and metric, the figure at the native rate and at each lower rate (± SE over trials)
and the ratio to native; runs in about a minute on 2 cores.
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


def make_tree(root: Path, trials: list[dict], k: int, method: str, work: Path) -> tuple[Path, list[dict]]:
    """Dataset tree with every trial's IMU files decimated by k (truth files linked); (root, trials)."""
    out = work / f"{method}_x{k}"
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
                    fn = decimate_block_mean if method == "mean" else decimate_fir
                    ts, x = fn(data[:, 0], data[:, 1:], k)
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
    ap.add_argument("--method", choices=["mean", "decimate"], default="mean")
    ap.add_argument("--noise-convention", choices=["sample", "density", "both"], default="sample")
    ap.add_argument("--set", action="append", default=[], metavar="PATH=VALUE",
                    help="settings override for every run, e.g. filter.zupt_onset_delay_s=0.1")
    ap.add_argument("--work", type=Path, default=Path("/tmp/bootnav_rates"), help="decimated trees (reused)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None)
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
            root_k, trials_k = make_tree(a.root, trials, k, a.method, a.work)
            for conv in conventions:
                ov = base if conv == "sample" else density_overrides(base, 1.0 / k)
                rows = score(root_k, trials_k, ov, a.jobs)
                res[f"/{k} {conv}"] = {"rate_hz": trials[0]["rate_hz"] / k,
                                       "figures": {m: set_figures(rows, set_name, m) for m in metric_list},
                                       "failed": {tid: r["reason"] for tid, r in rows.items() if r["status"] != "ok"}}
        results[set_name] = res
    print_table(results, a.method)
    print(f"\n({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    if a.json:
        a.json.write_text(json.dumps({"method": a.method, "overrides": base, "results": results}, indent=1,
                                     default=float, allow_nan=True))
    return 0


def _cell(f: dict) -> str:
    if f["failed"]:
        return f"FAIL ({len(f['failed'])})"
    if f["n"] > 1 and math.isfinite(f["se"]):
        return f"{f['mean']:.4g} ± {f['se']:.2g}"
    return f"{f['mean']:.4g}"


def print_table(results: dict, method: str) -> None:
    print(f"\n### Rate invariance ({method} decimation; figure ± SE over trials; ratio to native)\n")
    print("| dataset | metric | rate | figure | / native | failed |")
    print("|---|---|---|---|---|---|")
    for set_name, res in results.items():
        metrics = list(res["native"]["figures"])
        for m in metrics:
            nat = res["native"]["figures"][m]["mean"]
            for label, r in res.items():
                f = r["figures"][m]
                ratio = f["mean"] / nat if nat and math.isfinite(f["mean"]) else float("nan")
                rate = f"{r['rate_hz']:.4g} Hz" + ("" if label == "native" else f" ({label})")
                failed = ", ".join(r.get("failed", {})) or ""
                print(f"| {set_name} | `{m}` | {rate} | {_cell(f)} | {ratio:.2f} | {failed} |")


if __name__ == "__main__":
    raise SystemExit(main())
