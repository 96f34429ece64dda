"""Leave-one-dataset-out (LODO) validation of a setting's candidate values on the foot-mounted datasets.

Why: a default chosen on all developer recordings at once can fit those files and not transfer (issue 11).
LODO measures what choosing a value on the data is worth on a dataset the choice never saw:

1. every candidate value (plus the current default) scores every trial once, through
   ``bootnav.postproc.evaluate.runner.evaluate_all`` (METRICS.md, one fixed configuration per candidate);
2. per dataset the figure is the mean of its primary metric over its trials (``PRIMARY``; a failed trial
   makes the figure infinite: a failure counts, it is never skipped); figures are normalised per dataset by
   their median over the candidates, so datasets with different metrics pool;
3. for each dataset D in turn, the candidate with the smallest geometric mean of the normalised figures
   over the OTHER datasets is chosen, and its figure on D (the held-out figure) is printed next to the
   default's and the best-in-hindsight (the candidate best on D itself, which LODO cannot know);
4. spread: the standard error of D's mean over its trials (over its IMU files when D has one trial), and
   the paired difference chosen − default with its standard error. A difference inside ±2 SE is noise
   (with 2 units, xio's loops or gaitmap's feet, the SE has one degree of freedom: indicative only).

The closing line gives the geometric mean over datasets of held-out(chosen) / default: below 1 means that
re-choosing this setting on data transfers to unseen datasets; about 1 (or folds choosing different values)
means the setting is flat or data-specific, and the default should rest on physics or a datasheet.

    .venv/bin/python benchmarks/crossval.py --setting filter.zupt_onset_delay_s --values 0 0.1 0.15 0.2
    .venv/bin/python benchmarks/crossval.py --setting filter.sigma_gyro_radps --values 0.3deg 0.6deg 1deg
    .venv/bin/python benchmarks/crossval.py --eval auto=out/eval_auto/metrics.json --setting none

Values are JSON literals (numbers, true/false, "strings"); a number may end in ``deg`` (converted to rad).
``--eval NAME=metrics.json`` adds the output of any ``bootnav eval`` run (another branch, a prototype) as a
candidate; ``--setting none`` compares such runs with the default alone. Per-candidate results are cached
under ``--cache`` (key: the candidate's full settings + a fingerprint of the bootnav source), so a re-run
with more values only computes the new ones. ``--json`` writes every figure. Runs in ~15 s per candidate
on 2 cores for the default foot sets.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEFAULT_ROOT = REPO.parent / "shared" / "datasets"
DEFAULT_CACHE = Path("/tmp/bootnav_crossval_cache")

# dataset -> its primary METRICS.md metric (lower is better); xio_ximu has no numeric truth (not scored)
PRIMARY = {
    "pyshoe_vicon": "armse_2d",
    "xio_ngimu_loops": "closure_pct",
    "openshoe_820": "closure_pct",
    "koroglu_footprints": "final_fp_err_pct",
    "koroglu_rectangles": "closure_pct",
    "iez_mpu6050": "closure_pct",
    "voisard_ipol": "foot_abs_distance_err_pct",
    "gaitmap_example": "stride_mae_m",
}
DEFAULT_NAME = "default"


# ------------------------------------------------------------------------------------------- candidates
def parse_value(text: str):
    """A JSON literal, or a number with a ``deg`` suffix (returned in radians), or a bare string."""
    m = re.fullmatch(r"\s*([-+0-9.eE]+)\s*deg\s*", text)
    if m:
        return math.radians(float(m.group(1)))
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def settings_with(overrides: dict):
    """ProcessSettings with dotted-path overrides, e.g. {"filter.sigma_gyro_radps": 0.01}."""
    from bootnav.postproc.settings import ProcessSettings

    tree: dict = {}
    for path, value in overrides.items():
        node = tree
        *heads, last = path.split(".")
        for h in heads:
            node = node.setdefault(h, {})
        node[last] = value
    s = ProcessSettings.from_dict(tree)
    s.output.plots = False
    return s


def current_value(path: str):
    from bootnav.postproc.settings import ProcessSettings

    node = ProcessSettings()
    for part in path.split("."):
        node = node[part] if isinstance(node, dict) else getattr(node, part)
    return node


def source_fingerprint() -> str:
    """Hash of every .py file of the imported bootnav package tree (a cache entry dies with a code change)."""
    import bootnav
    import bootnav.logger
    import bootnav.postproc

    h = hashlib.sha1()
    for pkg in (bootnav, bootnav.logger, bootnav.postproc):
        root = Path(pkg.__file__).parent
        for f in sorted(root.rglob("*.py")):
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


# --------------------------------------------------------------------------------------------- scoring
def _trial_row(r) -> dict:
    return {"set": r.set, "status": r.status, "reason": r.reason, "metrics": r.metrics, "files": r.files}


def score_settings(root: Path, trials: list[dict], settings, jobs: int, cache_dir: Path | None,
                   fingerprint: str) -> dict:
    """trial id -> {set, status, reason, metrics, files} for one candidate (cached per trial)."""
    from bootnav.postproc.evaluate.runner import evaluate_all

    key = hashlib.sha1((settings.to_json(None) + fingerprint + str(root)).encode()).hexdigest()[:20]
    path = cache_dir / f"{key}.json" if cache_dir else None
    rows = json.loads(path.read_text()) if path and path.exists() else {}
    todo = [t for t in trials if t["id"] not in rows]
    if todo:
        for r in evaluate_all(root, todo, jobs=jobs, foot_settings=settings):
            rows[r.id] = _trial_row(r)
        if path:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(rows, default=float, allow_nan=True))
    return {t["id"]: rows[t["id"]] for t in trials}


def rows_from_eval(metrics_json: Path) -> dict:
    """trial id -> row, from a ``bootnav eval`` metrics.json (its per-trial metrics are flat)."""
    doc = json.loads(Path(metrics_json).read_text())
    out = {}
    for tid, m in doc["trials"].items():
        flat = {k: v for k, v in m.items() if k not in ("set", "mount", "status", "reason", "files")}
        out[tid] = {"set": m["set"], "status": m.get("status", "ok"), "reason": m.get("reason", ""),
                    "metrics": flat, "files": m.get("files", {})}
    return out


def set_figures(rows: dict, set_name: str, metric: str) -> dict:
    """Mean of ``metric`` over the set's trials, its units (trials, or files of a single trial) and SE."""
    trials = {tid: r for tid, r in rows.items() if r["set"] == set_name}
    failed = [tid for tid, r in trials.items() if r["status"] != "ok"]
    vals = {tid: r["metrics"].get(metric, float("nan")) for tid, r in trials.items() if r["status"] == "ok"}
    vals = {k: float(v) for k, v in vals.items() if v is not None and math.isfinite(float(v))}
    units = dict(vals)
    if len(vals) == 1 and not failed:  # one scored trial: its IMU files are the units of spread
        tid = next(iter(vals))
        r = trials[tid]
        bare = metric[5:] if metric.startswith("foot_") else metric
        per_file = {f"{tid}:{f}": d.get(bare) for f, d in r["files"].items()}
        per_file = {k: float(v) for k, v in per_file.items() if isinstance(v, (int, float)) and math.isfinite(v)}
        if len(per_file) > 1:
            units = per_file
    mean = float(np.mean(list(vals.values()))) if vals and not failed else (math.inf if failed else math.nan)
    u = np.array(list(units.values()))
    se = float(u.std(ddof=1) / math.sqrt(len(u))) if len(u) > 1 else math.nan
    return {"mean": mean, "se": se, "n": len(u), "units": units, "failed": failed}


def paired_diff(a: dict, b: dict) -> tuple[float, float]:
    """Mean and standard error of the per-unit difference a − b (units both have)."""
    keys = sorted(set(a["units"]) & set(b["units"]))
    if not keys or a["failed"] or b["failed"]:
        return (math.inf if a["failed"] and not b["failed"] else math.nan), math.nan
    d = np.array([a["units"][k] - b["units"][k] for k in keys])
    return float(d.mean()), (float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.nan)


# ------------------------------------------------------------------------------------------------ LODO
def lodo(figs: dict, default: str) -> dict:
    """Leave-one-dataset-out choice. ``figs[candidate][set]`` = ``set_figures`` output."""
    cands = list(figs)
    sets = list(next(iter(figs.values())))
    means = np.array([[figs[c][s]["mean"] for s in sets] for c in cands])  # (C, S)
    with np.errstate(invalid="ignore"):
        ref = np.array([np.median(means[np.isfinite(means[:, j]), j]) if np.isfinite(means[:, j]).any() else np.nan
                        for j in range(len(sets))])
        norm = means / ref
    logn = np.log(np.where(norm > 0, norm, np.nan))
    folds = []
    for j, held in enumerate(sets):
        others = [k for k in range(len(sets)) if k != j and np.isfinite(ref[k])]
        score = np.array([np.exp(np.mean(logn[i, others])) if others else np.nan for i in range(len(cands))])
        score = np.where(np.isnan(score), np.inf, score)
        best_score = np.min(score)
        tied = [i for i in range(len(cands)) if score[i] <= best_score * (1 + 1e-12)]
        i_ch = cands.index(default) if cands.index(default) in tied else tied[0]
        col = means[:, j]
        i_best = int(np.nanargmin(np.where(np.isfinite(col), col, np.nan))) if np.isfinite(col).any() else i_ch
        ch, de = figs[cands[i_ch]][held], figs[default][held]
        d, d_se = paired_diff(ch, de)
        if cands[i_ch] == default:
            verdict = "same"
        elif not math.isfinite(d_se) or d_se == 0:
            verdict = "worse" if d == math.inf else "n/a (1 unit)"
        elif d < -2 * d_se:
            verdict = "better"
        elif d > 2 * d_se:
            verdict = "worse"
        else:
            verdict = "noise"
        folds.append({"held_out": held, "chosen": cands[i_ch], "score_on_others": float(score[i_ch]),
                      "held_out_chosen": ch["mean"], "held_out_default": de["mean"], "best_in_hindsight":
                      cands[i_best], "held_out_best": float(col[i_best]), "se_default": de["se"], "n": de["n"],
                      "diff_chosen_minus_default": d, "diff_se": d_se, "verdict": verdict})
    ratios = [f["held_out_chosen"] / f["held_out_default"] for f in folds
              if f["held_out_default"] > 0 and math.isfinite(f["held_out_default"])]
    gm = float(np.exp(np.mean(np.log(ratios)))) if ratios and all(r > 0 for r in ratios) else math.nan
    all_score = np.exp(np.nanmean(logn, axis=1))
    return {"folds": folds, "geomean_heldout_over_default": gm,
            "chosen_on_all": cands[int(np.nanargmin(np.where(np.isfinite(all_score), all_score, np.nan)))],
            "score_on_all": dict(zip(cands, all_score.tolist()))}


# ---------------------------------------------------------------------------------------------- output
def _fmt(x: float, metric: str = "") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if x == math.inf:
        return "FAIL"
    return f"{x:.4g}"


def print_tables(figs: dict, result: dict, metrics: dict, setting: str) -> None:
    cands = list(figs)
    sets = list(next(iter(figs.values())))
    print(f"\n### {setting}: dataset figure per candidate (mean over trials; ± SE over trials)\n")
    print("| candidate | " + " | ".join(f"{s} `{metrics[s]}`" for s in sets) + " | geo-mean (norm.) |")
    print("|---|" + "---|" * (len(sets) + 1))
    for c in cands:
        cells = [f"FAIL ({len(figs[c][s]['failed'])} trial)" if figs[c][s]["failed"]
                 else f"{_fmt(figs[c][s]['mean'])} ± {_fmt(figs[c][s]['se'])}" if figs[c][s]["n"] > 1
                 else _fmt(figs[c][s]["mean"]) for s in sets]
        print(f"| {c} | " + " | ".join(cells) + f" | {result['score_on_all'][c]:.3f} |")
    print(f"\n### {setting}: leave-one-dataset-out\n")
    print("| held-out set | chosen on the others | held-out: chosen | default | best in hindsight | "
          "SE (n) | chosen − default ± SE | verdict |")
    print("|---|---|---|---|---|---|---|---|")
    for f in result["folds"]:
        print(f"| {f['held_out']} | {f['chosen']} | {_fmt(f['held_out_chosen'])} | {_fmt(f['held_out_default'])} | "
              f"{_fmt(f['held_out_best'])} ({f['best_in_hindsight']}) | {_fmt(f['se_default'])} ({f['n']}) | "
              f"{_fmt(f['diff_chosen_minus_default'])} ± {_fmt(f['diff_se'])} | {f['verdict']} |")
    print(f"\nheld-out / default, geometric mean over datasets: {result['geomean_heldout_over_default']:.3f} "
          f"(< 1: re-choosing on data transfers); chosen on all datasets: {result['chosen_on_all']}")
    default = next(c for c in cands if c.startswith(DEFAULT_NAME))
    others = [c for c in cands if c != default]
    if others:
        print(f"\n### {setting}: each candidate against the default (paired difference per set ± SE; "
              "better / worse = beyond 2 SE)\n")
        print("| candidate | " + " | ".join(sets) + " |")
        print("|---|" + "---|" * len(sets))
        for c in others:
            cells = []
            for s in sets:
                d, se = paired_diff(figs[c][s], figs[default][s])
                tag = ("FAIL" if d == math.inf else "same" if d == 0 else "n/a" if not math.isfinite(se) or se == 0 else
                       "better" if d < -2 * se else "worse" if d > 2 * se else "noise")
                cells.append(f"{_fmt(d)} ± {_fmt(se)} {tag}")
            print(f"| {c} | " + " | ".join(cells) + " |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--setting", required=True,
                    help="dotted ProcessSettings path, e.g. filter.sigma_gyro_radps, detector.params.alpha; "
                         "'none' to compare only --eval runs with the default")
    ap.add_argument("--values", nargs="*", default=[], help="candidate values (JSON literals, or e.g. 0.6deg)")
    ap.add_argument("--eval", action="append", default=[], metavar="NAME=METRICS_JSON",
                    help="add a `bootnav eval` output as a candidate (repeatable)")
    ap.add_argument("--root", type=Path, default=DEFAULT_ROOT, help="dataset tree with manifest.json")
    ap.add_argument("--sets", nargs="*", default=None, help=f"datasets (default: {' '.join(PRIMARY)})")
    ap.add_argument("--metric", action="append", default=[], metavar="SET=METRIC",
                    help="use another METRICS.md metric for a set, e.g. xio_ngimu_loops=closure_v_m")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--cache", default=str(DEFAULT_CACHE), help="per-candidate result cache folder ('' = none)")
    ap.add_argument("--json", type=Path, default=None, help="write every figure to this JSON file")
    a = ap.parse_args(argv)

    metrics = dict(PRIMARY)
    for item in a.metric:
        k, _, v = item.partition("=")
        metrics[k] = v
    sets = a.sets or list(PRIMARY)
    unknown = [s for s in sets if s not in metrics]
    if unknown:
        ap.error(f"no metric for {unknown}; give --metric SET=METRIC")
    metrics = {s: metrics[s] for s in sets}
    manifest = json.loads((a.root / "manifest.json").read_text())
    trials = [t for t in manifest["trials"] if t["set"] in sets]
    cache = Path(a.cache) if a.cache else None
    fp = source_fingerprint()

    candidates: dict[str, dict] = {DEFAULT_NAME: {}}
    if a.setting != "none":
        dflt = current_value(a.setting)
        for text in a.values:
            v = parse_value(text)
            if v == dflt:
                continue
            candidates[f"{v:.6g}" if isinstance(v, float) else json.dumps(v)] = {a.setting: v}
        candidates = dict(sorted(candidates.items(), key=lambda kv: _order(kv[1].get(a.setting, dflt))))
        candidates = {(f"{k} (default {dflt:.6g})" if isinstance(dflt, float) else f"{k} (default {dflt!r})")
                      if k == DEFAULT_NAME else k: v for k, v in candidates.items()}
    default_key = next(k for k in candidates if k.startswith(DEFAULT_NAME))
    rows: dict[str, dict] = {}
    t0 = time.perf_counter()
    for name, ov in candidates.items():
        t1 = time.perf_counter()
        rows[name] = score_settings(a.root, trials, settings_with(ov), a.jobs, cache, fp)
        print(f"candidate {name}: {time.perf_counter() - t1:.1f} s", file=sys.stderr)
    for item in a.eval:
        name, _, path = item.partition("=")
        r = rows_from_eval(Path(path))
        rows[name] = {t["id"]: r.get(t["id"], {"set": t["set"], "status": "failed", "reason": "missing",
                                                 "metrics": {}, "files": {}}) for t in trials}
    figs = {c: {s: set_figures(rows[c], s, metrics[s]) for s in sets} for c in rows}
    result = lodo(figs, default_key)
    print_tables(figs, result, metrics, a.setting)
    print(f"\n({len(trials)} trials x {len(rows)} candidates, {time.perf_counter() - t0:.0f} s; source "
          f"fingerprint {fp})", file=sys.stderr)
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        a.json.write_text(json.dumps({"setting": a.setting, "metrics": metrics, "candidates": candidates,
                                      "figures": figs, **result, "source_fingerprint": fp},
                                     indent=1, default=float, allow_nan=True))
    return 0


def _order(v):
    return (0, v) if isinstance(v, (int, float)) and not isinstance(v, bool) else (1, str(v))


if __name__ == "__main__":
    raise SystemExit(main())
