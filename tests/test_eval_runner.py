"""`bootnav eval` end to end on a few real trials: every metric present, failures listed, truth unread
before the estimate is final."""

import json
import shutil
import subprocess
import sys

import numpy as np
import pytest

from bootnav.postproc.evaluate import runner


def _manifest_subset(datasets, ids):
    manifest = json.loads((datasets / "manifest.json").read_text())
    return [t for t in manifest["trials"] if t["id"] in ids]


def test_eval_cli_writes_metrics_report_and_plots(datasets, tmp_path):
    ids = ["xio_ngimu_loops/short_walk", "oxford_steps/Samsung_Jamie_Hard_InHand_1"]
    # A private tree: the two trials plus one broken copy whose IMU file is truncated garbage.
    root = tmp_path / "tree"
    trials = _manifest_subset(datasets, ids)
    for t in trials:
        shutil.copytree(datasets / t["path"], root / t["path"])
    xio = next(t for t in trials if t["set"] == "xio_ngimu_loops")
    broken = dict(xio, id="xio_ngimu_loops/broken", path="xio_ngimu_loops/broken")
    (root / broken["path"]).mkdir(parents=True)
    (root / broken["path"] / "imu.csv.gz").write_bytes(b"\x1f\x8b garbage")
    (root / "manifest.json").write_text(json.dumps({"format_version": 1, "trials": trials + [broken]}))
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, "-m", "bootnav", "eval", str(root), "--out", str(out), "--jobs", "2"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((out / "metrics.json").read_text())
    loop = doc["trials"]["xio_ngimu_loops/short_walk"]
    assert loop["status"] == "ok"
    # The x-io walk is a closed loop of about 25 m (its truth.json): the distance walked must be close and
    # the loop must close to within a few percent of it.
    assert 20.0 < loop["distance_m"] < 30.0
    assert loop["closure_pct"] < 3.0
    phone = doc["trials"]["oxford_steps/Samsung_Jamie_Hard_InHand_1"]
    assert phone["status"] == "ok" and phone["f1"] > 0.9 and abs(phone["count_err_pct"]) < 5.0
    failed = doc["trials"]["xio_ngimu_loops/broken"]
    assert failed["status"] == "failed" and failed["reason"]
    assert doc["datasets"]["xio_ngimu_loops"]["n_failed"] == 1
    report = (out / "report.md").read_text()
    assert "## xio_ngimu_loops" in report and "xio_ngimu_loops/broken" in report
    assert len(list((out / "plots").glob("*.png"))) == 2
    assert "failed xio_ngimu_loops/broken" in proc.stderr


def test_estimates_are_made_before_any_truth_file_is_read(datasets, monkeypatch):
    trial = _manifest_subset(datasets, ["pyshoe_vicon/2017-11-22-11-22-03"])[0]
    order = []
    real_read = runner.read_csv_columns
    real_estimate = runner.estimate_foot

    def spy_read(path):
        order.append(("read", path.name))
        return real_read(path)

    def spy_estimate(path, settings):
        order.append(("estimate", path.name))
        return real_estimate(path, settings)

    monkeypatch.setattr(runner, "read_csv_columns", spy_read)
    monkeypatch.setattr(runner, "estimate_foot", spy_estimate)
    result = runner.evaluate_trial(trial, str(datasets))
    assert result.status == "ok", result.reason
    first_truth = next(i for i, (kind, name) in enumerate(order) if kind == "read" and name.startswith("truth"))
    assert all(kind != "estimate" for kind, _ in order[first_truth:])
    # This family's documented accuracy (README): median armse_2d 0.055 m over 16 trials; this short walk is
    # an ordinary one, so twice the median bounds it.
    assert 0.0 < result.metrics["armse_2d"] < 0.11
    # Stance against mocap: a ZUPT must almost never fall in a swing (precision), and must cover at least the
    # core of the foot-flat time the mocap marks as still (recall: half of it).
    assert result.metrics["stance_precision"] >= 0.95
    assert 0.5 <= result.metrics["stance_recall"] <= 1.0


def test_dataset_summary_means_and_medians():
    rows = [runner.TrialResult("s/a", "s", "foot", metrics={"x": 1.0}),
            runner.TrialResult("s/b", "s", "foot", metrics={"x": 3.0}),
            runner.TrialResult("s/c", "s", "foot", status="failed", reason="boom")]
    summary = runner.dataset_summary(rows)["s"]
    assert summary["x"] == pytest.approx(2.0) and summary["median_x"] == pytest.approx(2.0)
    assert summary["n_trials"] == 3 and summary["n_failed"] == 1


def test_footprint_error_is_a_percentage_of_the_walked_polyline():
    """An L-shaped walk, 3 m east then 4 m north (polyline 7 m, start-to-end 5 m), every footprint exact but
    the last 0.7 m off: final_fp_err_pct = 100 * 0.7 / 7 = 10 % (14 % if the chord were used)."""
    from bootnav.postproc.evaluate.metrics import footprint_metrics

    fp_xy = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [3, 1], [3, 2], [3, 3], [3, 4]], float)
    fp_t = np.arange(len(fp_xy), dtype=float)
    est = np.column_stack([fp_xy, np.zeros(len(fp_xy))])
    est[-1, 0] += 0.7
    m = footprint_metrics(fp_t, est, fp_t, fp_xy)
    assert m["final_fp_err_m"] == pytest.approx(0.7, abs=1e-12)
    assert m["final_fp_err_pct"] == pytest.approx(10.0, abs=1e-9)
