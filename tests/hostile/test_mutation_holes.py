"""Issue 27, "test-suite holes": each test here fails under one mutation that the suite did not catch.

- ``mean_v_err_m`` computed on the y axis;
- the crash-safe writer without its fsyncs (file and directory);
- stance/swing run durations off by one sample;
- the gait period one sample long (the old test allowed two samples);
- the ROLLING stride flag taken from the wrong stance phase (the old test used all-zero gyro data);
- the confidence formula (the old tests asserted [0, 1], which the clipping guarantees whatever the formula).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from bootnav.core import atomic
from bootnav.postproc import selftune as S
from bootnav.postproc.detectors import postprocess
from bootnav.postproc.evaluate import metrics as m


def test_mean_v_err_is_the_vertical_error():
    """Exact horizontal path, a vertical drift of 0.05 m/s from 0: mean |dz| = 0.05 * mean(t) = 0.25 m exactly,
    while x and y errors are 0 (so any other axis gives 0)."""
    t = np.linspace(0.0, 10.0, 1001)
    truth = np.column_stack([t, 0.5 * np.sin(t), 0.1 * t])
    est = truth.copy()
    est[:, 2] += 0.05 * t
    r = m.trajectory_metrics(t, est, t, truth)
    assert r["mean_h_err_m"] < 1e-9
    assert r["mean_v_err_m"] == pytest.approx(0.25, rel=1e-9)


def test_atomic_writer_fsyncs_the_file_and_its_directory(tmp_path, monkeypatch):
    """Durability after a power cut needs fsync of the data (before the rename) and of the directory (after it)."""
    synced = []
    real = os.fsync

    def spy(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        return real(fd)

    monkeypatch.setattr(os, "fsync", spy)
    target = tmp_path / "summary.json"
    atomic.write_text(target, "{}")
    tmp_name = atomic.temporary_beside(target).name
    assert [Path(p).name for p in synced] == [tmp_name, tmp_path.name]
    assert Path(synced[1]) == tmp_path and target.read_text() == "{}"


@pytest.mark.parametrize("k", [1, 2, 3, 7])
def test_a_run_of_k_samples_lasts_k_sample_periods(k):
    """A run of k samples at dt covers k·dt (each sample stands for its period): kept by a minimum of k·dt,
    dropped by a minimum half a sample longer, for stance runs and for swing gaps alike."""
    dt = 0.01
    t = np.arange(40) * dt
    stance = np.zeros(40, bool)
    stance[10:10 + k] = True
    kept = postprocess.remove_short_runs(stance, t, (k - 0.5) * dt, dt)
    dropped = postprocess.remove_short_runs(stance, t, (k + 0.5) * dt, dt)
    assert kept.sum() == k and dropped.sum() == 0
    # a swing gap of k samples between two stance runs: filled only by a minimum swing longer than k·dt
    walk = np.ones(40, bool)
    walk[20:20 + k] = False
    assert postprocess.clean_stance(walk, t, dt, min_swing_s=(k + 0.5) * dt).all()
    assert (~postprocess.clean_stance(walk, t, dt, min_swing_s=(k - 0.5) * dt)).sum() == k
    # the same with the stance minimum
    assert postprocess.clean_stance(stance, t, dt, min_stance_s=(k - 0.5) * dt).sum() == k
    assert postprocess.clean_stance(stance, t, dt, min_stance_s=(k + 0.5) * dt).sum() == 0


@pytest.mark.parametrize("k", [217, 240])
def test_gait_period_to_the_sample(k):
    """|ω| pulses every k samples: the autocorrelation peaks at lag k exactly. The overlap of a lag-L linear
    correlation shrinks as (n - L), which moves the peak of a pulse train by far less than half a sample, so
    the period is k·dt to within half a sample (a period one sample long fails)."""
    dt = 0.005
    n = 30 * k
    phase = np.arange(n) % k
    w = 6.0 * np.exp(-0.5 * ((phase - k / 2) / 8.0) ** 2)  # a swing's rate peak once per stride
    gyro = np.column_stack([w, 0.3 * w, np.zeros(n)])
    t = np.arange(n) * dt
    assert S.gait_period(t, gyro) == pytest.approx(k * dt, abs=0.5 * dt)


def test_rolling_flag_belongs_to_the_stance_that_ends_the_stride():
    """Five 1-s strides; the foot turns at 2 rad/s during the 4th stance phase only. The stride ending in that
    phase (index 2: strides run from phase i to phase i+1) is ROLLING, no other."""
    t = np.arange(0.0, 6.0, 0.01)
    stance = np.zeros(t.size, bool)
    starts = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    for a in starts:
        stance[(t >= a) & (t < a + 0.3)] = True
    pos = np.zeros((t.size, 3))
    for i, a in enumerate(starts):
        pos[t >= a, 0] = 1.2 * i
    gyro = np.zeros((t.size, 3))
    rolling = (t >= 3.0) & (t < 3.3)
    gyro[rolling, 1] = 2.0  # > max_stance_rate_radps (1 rad/s)
    gyro[~stance, 1] = 6.0  # swings turn fast (no effect on a stance flag)
    q = S.stride_quality(t, pos, stance, gyro, np.zeros(3), period_s=1.0)
    rolling_strides = [i for i, f in enumerate(q.flags) if f & S.ROLLING]
    assert rolling_strides == [2]
    assert q.stance_rate_radps[2] == pytest.approx(2.0)


@pytest.mark.parametrize("e, b", [(0.0, 0.0), (0.1, 0.0), (0.2, 0.25), (1.5, 0.6)])
def test_confidence_is_the_stated_formula(e, b):
    """(1 − b) · exp(−e / v_scale) with v_scale = 0.5 m/s: values strictly inside (0, 1) that a clip cannot
    produce from a wrong formula."""
    assert S.confidence(e, b, 1.0) == pytest.approx((1 - b) * np.exp(-e / 0.5), rel=1e-12)
    assert S.confidence(e, b, float("nan")) == 0.0  # no periodic gait
