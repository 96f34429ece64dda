"""The source paper's stance detectors as the paper used them [Heidari2019]: the printed eq. 2
(``shoe-literal``) and the acceleration-magnitude threshold (``paper_accmag``), both with the threshold read
off the recording and one stance block per step, and the x-io detector [Madgwick] on x-io's own data."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.core.runs import runs
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.detectors._paper import log_otsu_threshold, rest_magnitude
from tests.conftest import DATASETS

PAPER_DETECTORS = ("shoe-literal", "paper_accmag", "xio")
# x-io's recordings: the script's analysis window [Madgwick] and the stance phases in it. The counts come
# from the gyro alone: every stride shows two |ω| peaks above 2 rad/s (toe-off, heel strike), 13 / 35 / 33
# strides, so 14 / 36 / 34 stance phases (the still start and end included).
XIO = {"straightLine": ((6.0, 26.0), 14), "stairsAndCorridor": ((5.0, 53.0), 36), "spiralStairs": ((4.0, 47.0), 34)}


def _simulated(scenario, seed):
    from bootnav import simulator as sim
    return sim.simulate(scenario, seed=seed)


def _load_xio(name):
    path = DATASETS / "xio_ximu" / name / "imu.csv.gz"
    if not path.exists():
        pytest.skip(f"dataset {path} not found")
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    return path, d[:, 0], d[:, 1:4], d[:, 4:7]


def _phases_in(stance, t_s, window):
    starts, stops = runs(stance)
    return int(np.sum((t_s[stops - 1] >= window[0]) & (t_s[starts] <= window[1])))


def test_xio_truth_counts_are_what_the_gyro_shows(datasets):
    """The expected counts above, re-derived from the gyro peaks (two per stride)."""
    from scipy.signal import find_peaks

    for name, (window, n_stance) in XIO.items():
        _, t, _, gyro = _load_xio(name)
        sel = (t >= window[0]) & (t <= window[1])
        peaks, _ = find_peaks(np.linalg.norm(gyro[sel], axis=1), height=2.0, distance=int(0.4 / np.median(np.diff(t))))
        assert peaks.size == 2 * (n_stance - 1), name


@pytest.mark.parametrize("scenario, n_stance", [("paper-straight", 8), ("paper-stairs", 13)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_paper_detectors_find_one_stance_per_step_on_the_paper_scenarios(scenario, n_stance, seed):
    """7 strides -> 8 stance phases (straight), 12 -> 13 (stairs), for every paper detector with its
    defaults; the benchmark checks seeds 0-19."""
    res = _simulated(scenario, seed)
    truth = res.truth["stance"].astype(bool)
    assert runs(truth)[0].size == n_stance
    for method in PAPER_DETECTORS:
        r = detect_stance(res.t_s, res.acc_mps2, res.gyro_radps, DetectorSettings(method=method),
                          saturated=res.saturated)
        assert r.info["n_stance_phases"] == n_stance, (method, scenario, seed)
        # and they are the true stance phases: each detected phase lies mostly inside a true one
        starts, stops = r.phases()
        assert all(truth[a:b].mean() > 0.5 for a, b in zip(starts, stops)), method


def test_literal_shoe_with_a_fixed_threshold_fragments_the_stairs():
    """Why the threshold is read off the recording: the printed statistic's rest level moves with the
    sensor's scale error and bias (≈ 6-110 on simulated MPU6050s), so the old fixed γ = 1e3 splits the
    stairs walk into fragments (the issue: 31 phases instead of 13), while the recording's own split
    finds 13."""
    res = _simulated("paper-stairs", 0)
    fixed = detect_stance(res.t_s, res.acc_mps2, res.gyro_radps,
                          DetectorSettings("shoe", {"literal_paper_form": True}), saturated=res.saturated)
    read_off = detect_stance(res.t_s, res.acc_mps2, res.gyro_radps, DetectorSettings(method="shoe-literal"),
                             saturated=res.saturated)
    assert fixed.info["n_stance_phases"] > 20
    assert read_off.info["n_stance_phases"] == 13 and read_off.info["threshold_rule"] == "log_otsu"
    truth = res.truth["stance"].astype(bool)
    # the split lies between the rest level (stance median) and the swing level (swing median)
    assert np.median(read_off.statistic[truth]) < read_off.threshold < np.median(read_off.statistic[~truth])


def test_log_otsu_threshold_splits_two_modes_and_rest_magnitude_reads_the_sensor():
    rng = np.random.default_rng(0)
    # two log-normal modes at 10 and 1e4, unequal sizes: the split must fall between them
    x = np.concatenate([10 ** rng.normal(1.0, 0.2, 7000), 10 ** rng.normal(4.0, 0.3, 3000)])
    thr = log_otsu_threshold(x)
    assert 10 ** 1.6 < thr < 10 ** 3.1  # 3 σ outside each mode
    assert np.isnan(log_otsu_threshold(np.ones(10)))
    # a sensor that reads 9.55 m/s² at rest (x-IMU-like scale error), with motion in between
    acc = np.tile([0.0, 0.0, 9.55], (2000, 1)) + rng.normal(0, 0.02, (2000, 3))
    acc[500:800] += rng.normal(0, 5.0, (300, 3))
    assert rest_magnitude(acc, 0.005) == pytest.approx(9.55, abs=0.01)


@pytest.mark.parametrize("method", ["shoe-literal", "paper_accmag"])
def test_paper_detectors_count_the_steps_of_the_xio_stairs(datasets, method):
    _, t, acc, gyro = _load_xio("stairsAndCorridor")
    window, n_stance = XIO["stairsAndCorridor"]
    r = detect_stance(t, acc, gyro, DetectorSettings(method=method))
    assert _phases_in(r.stance, t, window) == n_stance


def test_xio_detector_on_xio_spiral_stairs_in_xio_window(datasets, tmp_path):
    """x-io's own window (4-47 s) ends in mid-stride: the end-anchored high-pass used to leave 0.3 % stance
    and stop ``process``; anchored at rest it finds the 34 stance phases."""
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    path, t, acc, gyro = _load_xio("spiralStairs")
    window, n_stance = XIO["spiralStairs"]
    sel = (t >= window[0]) & (t <= window[1])
    r = detect_stance(t[sel], acc[sel], gyro[sel], DetectorSettings(method="xio"))
    assert r.info["n_stance_phases"] == n_stance
    assert r.threshold == 0.05  # x-io's published threshold is kept
    s = ProcessSettings(crop_s=window)
    s.detector.method = "xio"
    result = process(path, s)
    assert result.summary["stance"]["phases"] == n_stance
