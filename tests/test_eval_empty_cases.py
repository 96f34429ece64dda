"""Empty cases of the METRICS.md scorer (no true steps, no detections, both empty): one documented answer
(``bootnav.postproc.evaluate.metrics`` docstring) in every caller — the metric functions, ``bootnav eval``
(runner, metrics.json, report.md) and the PDR evaluation of benchmarks/pdr_table.py."""

import gzip
import json
import math

import numpy as np
import pytest

from bootnav.postproc.evaluate import metrics as M
from bootnav.postproc.evaluate import runner
from bootnav.postproc.evaluate.report import write_metrics_json, write_report
from bootnav.postproc.evaluate import pdr as pdr_eval
from tests.test_pdr_detectors import walk

NAN = float("nan")
# (detected, true) -> documented precision, recall, f1, count_err_pct
CASES = {
    "no_truth": ([1.0, 2.0], [], (0.0, NAN, 0.0, NAN)),
    "no_detection": ([], [1.0, 2.0], (NAN, 0.0, 0.0, -100.0)),
    "both_empty": ([], [], (NAN, NAN, NAN, NAN)),
}


def _same(got, want):
    return (math.isnan(want) and math.isnan(got)) or got == pytest.approx(want)


@pytest.mark.parametrize("case", CASES)
def test_step_event_metrics_empty_cases(case):
    detected, true, want = CASES[case]
    r = M.step_event_metrics(detected, true)
    for key, value in zip(("precision", "recall", "f1", "count_err_pct"), want):
        assert _same(r[key], value), (case, key, r[key])
    assert (r["n_detected"], r["n_true"]) == (len(detected), len(true))


def test_other_empty_cases_are_undefined():
    assert math.isnan(M.count_err_pct(0, 0)) and math.isnan(M.count_err_pct(3, 0))
    assert math.isnan(M.step_count_metrics(0, 0)["count_err_pct"])
    r = M.step_length_metrics([], [], [1.0], [0.7])
    assert math.isnan(r["step_len_mae_m"]) and r["n_matched"] == 0
    r = M.step_length_metrics([5.0], [0.7], [1.0], [0.7])  # a step, but 4 s from the contact
    assert math.isnan(r["step_len_bias_m"]) and r["n_matched"] == 0
    t = np.arange(10.0)
    r = M.stance_metrics(t, np.zeros(10, bool), t, np.zeros(10, bool))
    assert math.isnan(r["stance_precision"]) and math.isnan(r["stance_recall"])
    # a defined case next to them still gives a number: half the estimated stance is true stance
    r = M.stance_metrics(t, t < 4, t, t < 2)
    assert r["stance_precision"] == pytest.approx(0.5) and r["stance_recall"] == pytest.approx(1.0)


def _write_imu(path, t, acc):
    with gzip.open(path, "wt") as f:
        f.write("t_s,ax_mps2,ay_mps2,az_mps2\n")
        np.savetxt(f, np.c_[t, acc], delimiter=",", fmt="%.6f")


@pytest.fixture
def tree(tmp_path):
    """Three phone trials: a walk with no true step, a phone at rest with true steps, both empty."""
    t_walk, acc_walk = walk(n_steps=30)
    rest = np.random.default_rng(0).normal(0.0, 0.02, acc_walk.shape) + [0.0, 0.0, 9.80665]
    trials = []
    for case, (acc, true_steps) in {"no_truth": (acc_walk, []), "no_detection": (rest, [4.0, 4.6, 5.2]),
                                    "both_empty": (rest, [])}.items():
        folder = tmp_path / "phones" / case
        folder.mkdir(parents=True)
        _write_imu(folder / "acc.csv.gz", t_walk, acc)
        (folder / "truth_steps.csv").write_text("t_s,foot\n" + "".join(f"{v},L\n" for v in true_steps))
        trials.append({"id": f"phones/{case}", "set": "phones", "path": f"phones/{case}", "mount": "phone_hand",
                       "truth": ["step_events"], "imu_files": {"acc.csv.gz": "phone_hand"}})
    (tmp_path / "manifest.json").write_text(json.dumps({"format_version": 1, "trials": trials}))
    return tmp_path, trials


def test_every_caller_gives_the_documented_answers(tree, tmp_path):
    root, trials = tree
    results = [runner.evaluate_trial(t, str(root)) for t in trials]
    pdr_rows = {r.id: r for r in pdr_eval.list_trials(root, sets=("phones",))}
    for res in results:
        assert res.status == "ok", res.reason
        detected, true, want = CASES[res.id.split("/")[1]]
        assert (res.metrics["n_true"] > 0) == bool(true)
        assert (res.metrics["n_detected"] > 0) == bool(detected)  # the synthetic walk is detected, rest is not
        row = pdr_eval.evaluate_trial(pdr_rows[res.id])
        assert row["error"] is None
        for key, value in zip(("precision", "recall", "f1", "count_err_pct"), want):
            assert _same(res.metrics[key], value), (res.id, key, res.metrics[key])
            assert _same(row[key], value), (res.id, key, row[key])
    out = tmp_path / "out"
    out.mkdir()
    doc = write_metrics_json(results, out / "metrics.json")
    written = json.loads((out / "metrics.json").read_text())  # strict JSON: no NaN token
    assert written["trials"]["phones/both_empty"]["f1"] is None
    assert written["trials"]["phones/no_detection"]["recall"] == 0.0
    summary = written["datasets"]["phones"]
    assert summary["n_undefined"] == {"abs_count_err_pct": 2, "count_err_pct": 2, "f1": 1, "precision": 2,
                                      "recall": 2}
    assert summary["f1"] == 0.0  # mean over the two trials where F1 is defined
    report = write_report(results, doc, out).read_text()
    assert "`precision` in 2" in report
    row = next(line for line in report.splitlines() if line.startswith("| both_empty |"))
    assert row.count("—") >= 4


def test_accuracy_benchmark_reads_null_as_undefined():
    import importlib.util

    from tests.conftest import REPO

    spec = importlib.util.spec_from_file_location("accuracy_foot", REPO / "benchmarks" / "accuracy_foot.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    doc = {"trials": {"pyshoe_vicon/a": {"armse_2d": None}, "pyshoe_vicon/b": {"armse_2d": 0.05}},
           "datasets": {"pyshoe_vicon": {"armse_2d": None}}}
    row = next(r for r in bench.goals_table(json.loads(json.dumps(doc))) if r["dataset"] == "pyshoe_vicon")
    assert math.isnan(row["ours"]) and not row["met"] and row["n"] == 1 and row["worst"] == 0.05
