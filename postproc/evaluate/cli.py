"""``bootnav eval DATASET_ROOT --out DIR [--jobs N]``: accuracy on every trial, one fixed configuration."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from bootnav.errors import InputError


def add_arguments(parser):
    parser.add_argument("root", type=Path, help="dataset tree with a manifest.json and METRICS.md truth files")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes (default: all cores)")
    parser.add_argument("--sets", nargs="*", default=None, help="only these datasets")
    parser.add_argument("--trials", nargs="*", default=None, help="only these trial ids")
    parser.add_argument("--no-plots", action="store_true", help="skip the per-trial plots")
    from bootnav.postproc.cli_process import add_calibration_arguments

    add_calibration_arguments(parser)  # foot files: as `bootnav process` (the datasets carry no device id)
    parser.add_argument("--force", action="store_true",
                        help="reuse a non-empty --out: the files of the earlier `bootnav eval` there (listed in its "
                             "metrics.json) are removed first, nothing else")


def earlier_eval_files(out: Path) -> list[Path]:
    """The files an earlier ``bootnav eval`` wrote into ``out``: the list in its metrics.json (``written``), or for
    a metrics.json without that list, metrics.json, report.md and the plots named after its trials."""
    metrics = out / "metrics.json"
    try:
        doc = json.loads(metrics.read_text()) if metrics.is_file() else None
    except (OSError, ValueError):
        doc = None
    if not isinstance(doc, dict):
        return []
    if isinstance(doc.get("written"), list):
        names = [str(n) for n in doc["written"]]
    else:
        prefixes = tuple(str(t).replace("/", "__") + "__" for t in doc.get("trials", {}))
        plots = out / "plots"
        names = ["metrics.json", "report.md"]
        if plots.is_dir() and prefixes:
            names += [f"plots/{p.name}" for p in plots.glob("*.png") if p.name.startswith(prefixes)]
    root = out.resolve()
    files = []
    for n in names:
        p = (out / n)
        try:  # only regular files inside out (a hand-edited list cannot reach elsewhere)
            if p.is_file() and not p.is_symlink() and root in p.resolve().parents:
                files.append(p)
        except OSError:
            continue
    return files


def prepare_out(out: Path, force: bool) -> None:
    """Refuse a non-empty ``--out`` without ``--force``; with it, remove only an earlier eval's files (no stale plot
    of an earlier run stays beside the new report, no unrelated file is touched)."""
    from bootnav.core.paths import output_folder

    output_folder(out, [], force=force)
    if not out.is_dir() or not any(out.iterdir()):
        return
    if not force:
        raise InputError(f"--out {out} is not empty; choose a new folder, or add --force to replace the results of an "
                         "earlier `bootnav eval` there (only its own files are removed)")
    for p in earlier_eval_files(out):
        p.unlink(missing_ok=True)


def select_trials(manifest: dict, sets=None, trial_ids=None) -> list[dict]:
    trials = manifest["trials"]
    if sets:
        trials = [t for t in trials if t["set"] in sets]
    if trial_ids:
        trials = [t for t in trials if t["id"] in trial_ids]
    return trials


def run(args) -> int:
    import time

    from bootnav.postproc.evaluate.report import plot_trial, write_metrics_json, write_report
    from bootnav.postproc.evaluate.runner import evaluate_all

    from bootnav.core.limits import check_jobs
    from bootnav.core.paths import regular_input

    check_jobs("--jobs", args.jobs)
    manifest_path = args.root / "manifest.json"
    if not manifest_path.exists():
        raise InputError(f"{manifest_path}: no manifest.json in the dataset root")
    regular_input(manifest_path, "manifest.json")
    trials = select_trials(json.loads(manifest_path.read_text()), args.sets, args.trials)
    if not trials:
        raise InputError("no trial selected")
    prepare_out(args.out, getattr(args, "force", False))
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    from bootnav.core.progress import Progress

    shown = Progress(quiet=getattr(args, "quiet", False))

    def progress(done, total, result):
        status = "ok" if result.status == "ok" else f"FAILED ({result.reason})"
        shown.update(f"[{done}/{total}] {result.id}: {status}", force=done == total or result.status != "ok")
        if done == total:
            shown.done()

    foot_settings = None
    if args.calibration or args.no_calibration or args.accel_calibration:
        from bootnav.postproc.cli_process import apply_calibration_arguments
        from bootnav.postproc.settings import ProcessSettings

        foot_settings = ProcessSettings()
        apply_calibration_arguments(args, foot_settings.calibration)
    results = evaluate_all(args.root, trials, jobs=args.jobs, foot_settings=foot_settings, progress=progress)
    elapsed = time.perf_counter() - t0
    written = []
    if not args.no_plots:
        plots = args.out / "plots"
        plots.mkdir(exist_ok=True)
        for r in results:
            written += [f"plots/{p.name}" for p in plot_trial(r, plots) if p is not None]
    written += ["report.md", "metrics.json"]
    doc = write_metrics_json(results, args.out / "metrics.json", extra={"elapsed_s": elapsed, "written": written})
    report = write_report(results, doc, args.out, header=f"{len(results)} trials in {elapsed:.1f} s.")
    failed = [r for r in results if r.status != "ok"]
    print(f"{len(results) - len(failed)} trials ok, {len(failed)} failed; report: {report}", file=sys.stderr)
    for r in failed:
        print(f"  failed {r.id}: {r.reason}", file=sys.stderr)
    return 0
