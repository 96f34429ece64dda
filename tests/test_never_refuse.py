"""A plausible foot recording always gets a path (issue: never refuse), on simulated gaits with exact truth.

Running without a foot-flat long enough for the configured detector, fast corridor walks with 2.5 m strides,
crawling and shuffling: ``process`` must return a path, say which stance detection ran and how confident it
is, and the path must be as good as the sensor allows. Tolerances come from the truth: with the ``ideal``
sensor (exact samples) the remaining error is the method's own (sampling, the ZUPT model); 2 % of the
distance is the paper's best Table 1 figure [Heidari2019].
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bootnav import simulator as sim
from bootnav.errors import InputError
from bootnav.postproc.pipeline import process
from bootnav.postproc.settings import ProcessSettings


def _sim(tmp_path, scenario, profile="ideal", seed=0, duration_s=None, with_truth=False):
    res = sim.simulate(scenario, seed=seed, profile=profile, rate_hz=200.0, duration_s=duration_s)
    path = tmp_path / f"{getattr(scenario, 'name', scenario)}-{profile}-{seed}.h5"
    sim.write_h5(res, path)
    return (path, res) if with_truth else path


def _distance_err_pct(r) -> float:
    m = r.metrics
    return 100.0 * m["distance_diff_m"] / m["distance_ref_m"]


def test_running_without_a_usable_foot_flat_gets_a_path(tmp_path):
    """The clean running recording that the adaptive detector without its share rule
    (``isolated_min_flat_fraction`` 0) misses stances on: it used to be refused ('strides longer than 6 m'); the
    fallback puts a ZUPT in every stride. With the share rule (the default) the configured detector finds them."""
    path, res = _sim(tmp_path, "running", duration_s=30.0, with_truth=True)
    old_rule = {"method": "adaptive", "params": {"isolated_min_flat_fraction": 0.0}}
    strict = ProcessSettings.from_dict({"reference": "truth", "detector": old_rule, "selftune": {"fallback": False}})
    with pytest.raises(InputError, match="longer than 6 m|misses stance phases"):
        process(path, strict)  # the old policy refuses: this test can fail
    r = process(path, ProcessSettings.from_dict({"reference": "truth", "detector": old_rule}))
    nav = r.summary["navigation"]
    assert nav["fallback_used"] and nav["configured_failed"]
    assert nav["stance_choice"] != "configured (adaptive)"
    assert any("fallback" in w for w in r.warnings)
    assert 0.5 < nav["confidence"] <= 1.0
    assert abs(_distance_err_pct(r)) < 2.0
    # every truth stride found: one counted stride per pair of consecutive truth stance phases
    truth_stance = np.asarray(res.truth["stance"], bool)
    n_true = int(np.count_nonzero(np.diff(truth_stance.astype(np.int8)) == 1)) + int(truth_stance[0]) - 1
    assert abs(r.summary["strides"] - n_true) <= 1
    d = process(path, ProcessSettings(reference="truth"))  # the default: no fallback needed
    assert not d.summary["navigation"]["fallback_used"] and abs(_distance_err_pct(d)) < 2.0
    assert abs(r.summary["strides"] - n_true) <= 1


@pytest.mark.parametrize("scenario,profile,tol_pct", [
    ("fast-corridor", "ideal", 2.0),
    ("crawl", "mpu6050-noise-only", 3.0),
    ("shuffle", "mpu6050-noise-only", 3.0),
])
def test_hard_gaits_are_processed_within_the_sensor_budget(tmp_path, scenario, profile, tol_pct):
    r = process(_sim(tmp_path, scenario, profile, duration_s=40.0 if scenario != "crawl" else None),
                ProcessSettings(reference="truth"))
    assert abs(_distance_err_pct(r)) < tol_pct
    # the stated formula (1 - b) exp(-e / 0.5 m/s) from the run's own figures: a clip to [0, 1] cannot fake it
    nav = r.summary["navigation"]
    e, b = nav["timing_offset"]["innovation_rms_mps"], nav["implausible_stride_fraction"]
    assert r.summary["confidence"] == pytest.approx((1.0 - b) * np.exp(-e / 0.5), rel=1e-9)


def test_clipping_sensor_is_processed_with_a_low_confidence(tmp_path):
    """±2 g / ±250 °/s (the MPU6050's power-on ranges) clips every running swing: the path is poor, which the
    confidence must say instead of a refusal or a confident wrong answer."""
    r = process(_sim(tmp_path, "running", "mpu6050-2g-250dps", duration_s=30.0), ProcessSettings(reference="truth"))
    assert r.summary["confidence"] < 0.3
    # the strides flagged in steps.csv are the fraction the summary reports, and clipping flags more of them
    # than the 10 % a working detection may have (the self-tuning's failure bound)
    flagged = float(np.mean(np.asarray(r.steps["quality_flags"]) != 0))
    assert r.summary["navigation"]["implausible_stride_fraction"] == pytest.approx(flagged, abs=1e-12)
    assert flagged > r.settings.selftune.max_bad_fraction


def test_standing_still_is_refused_with_a_reason(tmp_path):
    path = _sim(tmp_path, sim.custom("stand", lambda pb: pb.stand(30.0)), "mpu6050-noise-only")
    with pytest.raises(InputError, match="no motion: not one stride.*no periodic gait|not a walking foot.*no periodic"):
        process(path)


def test_a_failed_detector_without_a_gait_rhythm_still_gets_a_path(tmp_path, monkeypatch):
    """Mixed gaits (walk, run, stairs, crawl in one mocap trial) can leave the autocorrelation of |ω| without
    one stride rhythm. That used to turn a failed configured detector into a refusal ('not a walking foot:
    ... and no periodic gait'); now the other candidates run, the path comes with confidence 0 and says why."""
    from bootnav.postproc import selftune

    path = _sim(tmp_path, "fast-corridor", "mpu6050-noise-only", duration_s=25.0)
    s = ProcessSettings()
    s.detector = s.detector.with_method("shoe", threshold=1e12)  # every sample "stance": a fatal finding
    monkeypatch.setattr(selftune.GaitPeriodAccumulator, "finish", lambda self: float("nan"))  # no rhythm found
    strict = ProcessSettings()
    strict.detector = s.detector
    strict.selftune = replace(strict.selftune, fallback=False)
    with pytest.raises(InputError):
        process(path, strict)  # the configured detector does fail: this test can fail
    r = process(path, s)
    nav = r.summary["navigation"]
    assert nav["configured_failed"] and nav["stance_choice"] != "configured (shoe)"
    assert r.summary["confidence"] == 0.0
    assert any("no periodic gait" in w for w in r.warnings)
    assert r.summary["strides"] > 10  # 25 s of walking: a stride every ~1.1 s
