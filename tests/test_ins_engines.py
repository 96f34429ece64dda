"""The fast numba engine and the filterpy reference engine give the same trajectory (to 1e-9 m)."""

from __future__ import annotations

import numpy as np
import pytest

from bootnav.postproc.ins import FilterSettings, run_filter
from tests.test_ins_synthetic import TruthInit, synthetic_walk


@pytest.fixture(scope="module")
def messy_walk():
    """4 strides at 200 Hz with jittered time, 6 duplicate timestamps and two gaps (8 and 30 periods)."""
    w = synthetic_walk(n_strides=4, turn_rad=0.3, climb_m=0.15, acc_noise=0.05, gyro_noise=0.005,
                       acc_bias=(0.05, -0.03, 0.02), gyro_bias=(0.002, -0.001, 0.003), seed=7)
    rng = np.random.default_rng(7)
    n = len(w.t_s)
    keep = np.ones(n, bool)
    keep[300:307] = False  # gap inside a swing/stance boundary region
    keep[700:729] = False
    t = w.t_s + rng.uniform(-0.001, 0.001, n)  # step jitter < 0.4 periods: only the two real gaps pass 1.5 periods
    t[0] = w.t_s[0]
    dup = rng.choice(np.arange(10, n - 10), 6, replace=False)
    order = np.sort(np.concatenate([np.arange(n), dup]))
    t = t[order]
    t[1:][np.diff(order) == 0] = t[:-1][np.diff(order) == 0]  # duplicated rows share the timestamp
    sel = keep[order]
    return (t[sel], w.acc_b[order][sel], w.gyro_b[order][sel], w.stance[order][sel],
            TruthInit(w.q_nb[0], [0.001, 0.0, 0.002]), w.gravity)


CASES = [
    dict(n_states=9, smoother="none"),
    dict(n_states=9, smoother="rts"),
    dict(n_states=15, smoother="none"),
    dict(n_states=15, smoother="rts", zaru=True),
    dict(n_states=9, mode="riccati"),
    dict(n_states=15, smoother="rts", smoother_max_segment_s=0.3),  # segments split mid-swing (memory bound)
    dict(n_states=9, heading_aid="dominant_directions", hde_threshold_rad=0.8),  # optional heuristic aid
    # rolling-foot ZUPT noise off / large, signal-proportional noise, plain-R-like ZARU
    dict(n_states=15, zupt_lever_arm_m=0.0, zaru=False),
    dict(n_states=15, zupt_lever_arm_m=0.3, acc_scale_noise=0.03, gyro_scale_noise=0.02, sigma_zaru_radps=0.05,
         zaru_rate_factor=3.0, zupt_onset_delay_s=0.0),
]


@pytest.mark.parametrize("case", CASES, ids=lambda c: "-".join(f"{k}={v}" for k, v in c.items()))
def test_fast_equals_reference(messy_walk, case):
    t, acc, gyr, stance, init, g = messy_walk
    fast = run_filter(t, acc, gyr, stance, init, g, FilterSettings(engine="fast", **case))
    ref = run_filter(t, acc, gyr, stance, init, g, FilterSettings(engine="reference", **case))
    assert fast.info["n_duplicates"] == 6 and len(fast.info["gaps"]) == 2
    assert fast.info["n_updates"] == ref.info["n_updates"] > 0
    assert fast.info["heading_aid_updates"] == ref.info["heading_aid_updates"]
    # every P⁻ the smoother factorises is positive definite here, also at a segment ending on a swing sample
    # (no update there: the smoother reads P⁻ = P⁺)
    assert fast.info["smoother_skipped_steps"] == 0
    if case.get("heading_aid"):
        assert fast.info["heading_aid_updates"] >= 1
    assert np.abs(fast.pos_n - ref.pos_n).max() < 1e-9
    assert np.abs(fast.vel_n - ref.vel_n).max() < 1e-9
    assert np.abs(fast.q_nb - ref.q_nb).max() < 1e-9
    assert np.abs(fast.pos_sigma_n - ref.pos_sigma_n).max() < 1e-9
    if case["n_states"] == 15:
        assert np.abs(fast.gyro_bias_b - ref.gyro_bias_b).max() < 1e-12
        assert np.abs(fast.acc_bias_b - ref.acc_bias_b).max() < 1e-9
    # the corrections are not trivially zero: the path moved several metres
    assert np.linalg.norm(fast.pos_n[-1, :2]) > 3.0


def test_fast_equals_reference_with_saturated_samples(messy_walk):
    """Per-sample noise of clipped samples (acc and gyro bits) goes through both engines identically."""
    t, acc, gyr, stance, init, g = messy_walk
    sat = np.zeros(len(t), np.uint8)
    sat[150:160] = 0b000001  # ax clipped
    sat[420:425] = 0b010000  # gy clipped
    out = {}
    for engine in ("fast", "reference"):
        fs = FilterSettings(engine=engine, sat_acc_sigma_mps2=20.0, sat_gyro_sigma_radps=1.0)
        out[engine] = run_filter(t, acc, gyr, stance, init, g, fs, saturated=sat)
    assert out["fast"].info["saturated_samples_inflated"] == 15
    assert np.abs(out["fast"].pos_n - out["reference"].pos_n).max() < 1e-9
    assert np.abs(out["fast"].pos_sigma_n - out["reference"].pos_sigma_n).max() < 1e-9
    plain = run_filter(t, acc, gyr, stance, init, g, FilterSettings())
    # the inflation really acts: the position uncertainty after the clipped bursts is larger
    assert out["fast"].pos_sigma_n[430:].max() > plain.pos_sigma_n[430:].max()


def test_saturation_variance_acts_on_the_clipped_axis_only():
    """Bitmask -> per-axis variance; a clipped x-gyro on a level, still sensor grows the roll (nav x) variance,
    not the yaw variance."""
    from bootnav.postproc.ins.filter import saturation_variance

    fs = FilterSettings(sat_acc_sigma_mps2=4.0, sat_gyro_sigma_radps=0.5)
    sat = np.array([0, 0b000001, 0b001000, 0b100100], np.uint8)
    v = saturation_variance(sat, 4, fs)
    assert np.array_equal(v > 0, [[0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0], [0, 0, 0, 1, 0, 0], [0, 0, 1, 0, 0, 1]])
    assert v[1, 0] == 16.0 and v[2, 3] == 0.25
    assert saturation_variance(np.zeros(4, np.uint8), 4, fs) is None
    n = 400
    t = np.arange(n) * 0.005
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    gyr = np.zeros((n, 3))
    init = TruthInit([1.0, 0, 0, 0], np.zeros(3))
    clipped = np.zeros(n, np.uint8)
    clipped[100:200] = 0b001000  # gx
    off = run_filter(t, acc, gyr, np.zeros(n, bool), init, 9.81, FilterSettings(smoother="none"))
    on = run_filter(t, acc, gyr, np.zeros(n, bool), init, 9.81, FilterSettings(smoother="none"), saturated=clipped)
    s_off, s_on = np.array(off.info["final_state_sigma"]), np.array(on.info["final_state_sigma"])
    # roll variance grows by exactly σ_sat² Δt₀ Δt per clipped step (100 steps, no update), yaw untouched
    added = FilterSettings().sat_gyro_sigma_radps**2 * 0.005 * 0.005 * 100
    assert s_on[6] ** 2 - s_off[6] ** 2 == pytest.approx(added, rel=1e-9)
    assert abs(s_on[8] - s_off[8]) < 1e-12 and abs(s_on[7] - s_off[7]) < 1e-12


@pytest.mark.parametrize("case", [dict(n_states=15, smoother="rts"), dict(n_states=9, mode="riccati"),
                                  dict(n_states=9, heading_aid="dominant_directions", hde_threshold_rad=0.8)],
                         ids=lambda c: "-".join(f"{k}={v}" for k, v in c.items()))
def test_navigator_of_each_engine_pushes_alike(messy_walk, case):
    """``filter.navigator`` (what the block passes build): the reference engine behind the stream's push/finish
    (stance mask pushed in chunks of 37 samples, onset delay applied inside, the heading gate closed over a
    stretch, a saturated burst) gives the stream's rows, its ZUPT mask and its counters, to 1e-9 m."""
    from bootnav.postproc.ins.filter import navigator
    from bootnav.postproc.ins.stream import NavRows

    t, acc, gyr, stance, init, g = messy_walk
    n = len(t)
    gate = np.ones(n, bool)
    gate[n // 3:n // 2] = False
    sat = np.zeros(n, np.uint8)
    sat[400:410] = 0b001001  # ax and gx clipped
    rows, navs = {}, {}
    for engine in ("fast", "reference"):
        nav = navs[engine] = navigator(init, g, 0.005, FilterSettings(engine=engine, **case))
        parts = [nav.push(t[a:a + 37], acc[a:a + 37], gyr[a:a + 37], stance[a:a + 37], sat[a:a + 37],
                          heading_gate=gate[a:a + 37]) for a in range(0, n, 37)]
        rows[engine] = NavRows.concatenate(parts + [nav.finish()])
    a, b = rows["fast"], rows["reference"]
    assert type(navs["reference"]).__name__ == "RecordReference" and b.start == 0 and len(b) == len(a) == n
    np.testing.assert_array_equal(b.stance, a.stance)
    np.testing.assert_array_equal(b.zupt, a.zupt)
    assert a.zupt.sum() < a.stance.sum()  # the onset delay acted
    for name in ("pos_n", "vel_n", "q_nb", "pos_sigma_n"):
        assert np.abs(getattr(a, name) - getattr(b, name)).max() < 1e-9, name
    fi, ri = navs["fast"].info, navs["reference"].info
    assert set(fi) == set(ri)
    for k in ("n_filtered", "n_updates", "heading_aid_updates", "n_duplicates", "n_gaps", "gaps",
              "zupt_onset_samples_skipped", "saturated_samples_inflated", "smoother_segments"):
        assert fi[k] == ri[k], k
    assert fi["n_gaps"] == 2 and fi["n_duplicates"] == 6 and fi["saturated_samples_inflated"] == 10
    assert np.abs(navs["fast"].covariance - navs["reference"].covariance).max() < 1e-9
    assert np.linalg.norm(a.pos_n[-1, :2]) > 3.0


@pytest.fixture(scope="module")
def sim_walk(tmp_path_factory):
    """1 min of the long simulation (turns, stairs), the input of ``process``."""
    from bootnav.simulator.simulate import LongSimulation
    from bootnav.simulator.writers import write_long_h5

    return write_long_h5(LongSimulation(60.0, seed=5, block_s=30.0), tmp_path_factory.mktemp("eng") / "walk.h5")


@pytest.mark.parametrize("mode", ["time_varying", "riccati"])
def test_process_honours_the_reference_engine(sim_walk, mode):
    """``bootnav.process(rec, filter={"engine": "reference"})`` runs the filterpy engine in every pass (the
    timing probes, the heading decision's path, the final pass) and says so in summary.json; the path is the
    fast engine's to 1e-9 m (the same filter: ``test_fast_equals_reference``), in the paper mode too (its gain
    reads the whole record's open-loop times)."""
    import time

    import bootnav
    from bootnav.postproc.ins import filterpy_engine

    runs = []
    real = filterpy_engine.ReferenceNavigator.finish

    def counted(self):
        runs.append(self._k)
        return real(self)

    out = {}
    filterpy_engine.ReferenceNavigator.finish = counted
    try:
        for engine in ("fast", "reference"):
            t0 = time.perf_counter()
            out[engine] = bootnav.process(sim_walk, filter={"engine": engine, "mode": mode})
            assert out[engine].summary["filter"]["engine"] == engine
            assert out[engine].summary["filter"]["mode"] == mode
    finally:
        filterpy_engine.ReferenceNavigator.finish = real
    n = len(out["fast"].t_s)
    assert len(runs) >= 2 and max(runs) == n  # the passes ran the reference loop over the whole record
    a, b = out["fast"], out["reference"]
    np.testing.assert_array_equal(a.stance, b.stance)
    assert np.abs(a.pos_n_m - b.pos_n_m).max() < 1e-9
    assert np.abs(a.q_nb - b.q_nb).max() < 1e-9
    assert a.summary["path"]["distance_m"] > 30.0
    assert a.summary["path"]["distance_m"] == pytest.approx(b.summary["path"]["distance_m"], abs=1e-9)
    assert a.summary["navigation"]["timing_offset"] == pytest.approx(b.summary["navigation"]["timing_offset"])
    assert a.summary["filter"]["n_updates"] == b.summary["filter"]["n_updates"] > 0
