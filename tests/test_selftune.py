"""Self-tuning of the stance detection, stride quality flags and the level-stride timing calibration
(``bootnav.postproc.selftune``) on simulated recordings, where the truth is exact."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from bootnav.postproc import selftune as S
from bootnav.postproc.calibration import CalibrationSettings, initial_alignment
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.ins import FilterSettings, run_filter

from bootnav import simulator as sim
from bootnav.simulator import gait
from bootnav.simulator import scenarios

G = CalibrationSettings().gravity()
# a fast run whose foot never rests: the heel rocker rolls straight into the toe-off (no foot-flat)
RUN_NO_FLAT = replace(gait.RUN, name="run_no_flat", still_fraction=0.0)


def _corridor(g, leg_m: float = 40.0):
    return scenarios.custom(g.name, lambda pb: pb.stand(5.0).walk(3.0).walk(leg_m, g).walk(3.0).stand(5.0))


def _arrays(res):
    return res.t_s, np.asarray(res.acc_mps2, float), np.asarray(res.gyro_radps, float)


@pytest.fixture(scope="module")
def walk():
    return sim.simulate(_corridor(gait.WALK), seed=3)


@pytest.fixture(scope="module")
def run_no_flat():
    return sim.simulate(_corridor(RUN_NO_FLAT), seed=4)


def test_gait_period_is_the_simulated_stride_period(walk, run_no_flat):
    # stride period = 120 / cadence (both feet's steps per minute); resolution of the lag: one sample (5 ms)
    for res, g in ((walk, gait.WALK), (run_no_flat, RUN_NO_FLAT)):
        t, _, w = _arrays(res)
        assert S.gait_period(t, w) == pytest.approx(120.0 / g.cadence_spm, abs=0.01)


def _process(res, **settings):
    """``process`` of a simulated recording's arrays (the passes, with their fallback): its ``ProcessResult``."""
    import bootnav

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. a short still period: not what these tests are about
        return bootnav.process(*_arrays(res), **settings).raw


def test_no_gait_in_a_standing_recording():
    """No gait rhythm and no stride: not a failed stance detection but no motion, refused as such."""
    from bootnav.errors import InputError

    res = sim.simulate(scenarios.custom("stand", lambda pb: pb.stand(20.0)), seed=5)
    t, a, w = _arrays(res)
    assert np.isnan(S.gait_period(t, w))
    with pytest.raises(InputError, match="no motion: not one stride .* and no periodic gait"):
        _process(res)


def test_walking_keeps_the_configured_detector(walk):
    t, a, w = _arrays(walk)
    r = _process(walk)
    out = r.navigation
    assert out.choice.startswith("configured") and out.failed is None and not out.candidates
    from bootnav.postproc.calibration import stance_reference

    bias, g_rest = stance_reference(r.init, G)  # the configured detector sees the rest as the sensor read it
    configured = detect_stance(t, a, w - bias, DetectorSettings(), g_rest).stance
    assert np.array_equal(r.stance, configured)
    assert out.quality.bad_fraction == 0.0 and 0.5 < out.confidence <= 1.0


def test_cycle_minimum_finds_the_slowest_instant_of_every_stride(run_no_flat):
    t, a, w = _arrays(run_no_flat)
    period = S.gait_period(t, w)
    windows = S.cycle_minimum_stance(t, a, w, G, period, DetectorSettings())
    steps = run_no_flat.steps
    speed = np.linalg.norm(run_no_flat.truth["vel_n_mps"], axis=1)
    running = steps["length_m"] > 2.0
    between = np.flatnonzero(running[:-1] & running[1:])  # a running stride followed by another: no rest between
    assert between.size >= 10
    centres = []
    for k in between:
        # the truth's slowest instant between the mid-swings around this stride's end (the would-be stance)
        t0, t1 = steps["t_start_s"][k], steps["t_end_s"][k]
        inside = (t > t1 - 0.3 * (t1 - t0)) & (t < t1 + 0.3 * (t1 - t0))
        centres.append(t[inside][np.argmin(speed[inside])])
    starts = np.flatnonzero(np.diff(windows.astype(int)) == 1) + 1
    stops = np.flatnonzero(np.diff(windows.astype(int)) == -1) + 1
    mids = 0.5 * (t[starts] + t[stops - 1])
    for c in centres:  # one window per stride, centred on the truth's slowest instant within one window length
        assert np.min(np.abs(mids - c)) < 0.06 * period + 0.01


def test_running_without_foot_flat_gets_one_update_per_stride(run_no_flat):
    # the adaptive detector without its share rule misses these stances (what got refused): the fallback's case
    old_rule = DetectorSettings(params={"isolated_min_flat_fraction": 0.0})
    r = _process(run_no_flat, detector=old_rule.to_dict())
    out = r.navigation
    assert out.candidates[0]["bad_fraction"] > 0.1
    assert not out.choice.startswith("configured") and out.quality.bad_fraction == 0.0
    est = r.steps
    steps = run_no_flat.steps
    running = steps["length_m"] > 2.0
    k = np.flatnonzero(running[:-1] & running[1:])[1:]  # strides that start and end inside the run
    j = np.abs(est["t_s"][None, :] - steps["t_end_s"][k][:, None]).argmin(axis=1)
    # a footprint at every true stride end (within one cycle-minimum window, 0.06 of the 0.71 s cycle), and
    # each stride's length within 5 cm of the truth's 2.5 m (one ZUPT-aided 0.7 s swing of a MEMS INS)
    assert np.all(np.abs(est["t_s"][j] - steps["t_end_s"][k]) < 0.045)
    assert np.all(np.abs(est["stride_length_m"][j] - steps["length_m"][k]) < 0.05)


def test_running_without_foot_flat_default_detector_needs_no_fallback(run_no_flat):
    from bootnav.postproc.detectors import detect_stance
    from bootnav.postproc.strides import segment_strides

    t, a, w = _arrays(run_no_flat)
    init = initial_alignment(t, a, w, CalibrationSettings(), G)
    stance = np.asarray(detect_stance(t, a, w - init.gyro_bias_b, DetectorSettings(), G).stance, bool)
    nav = run_filter(t, a, w, stance, init, G, FilterSettings())
    est = segment_strides(t, nav.pos_n, stance)
    steps = run_no_flat.steps
    running = steps["length_m"] > 2.0
    k = np.flatnonzero(running[:-1] & running[1:])[1:]
    j = np.abs(est["t_s"][None, :] - steps["t_end_s"][k][:, None]).argmin(axis=1)
    found = np.abs(est["t_s"][j] - steps["t_end_s"][k]) < 0.045  # within one cycle-minimum window
    # the share rule takes the rolling foot's slowest moment as stance: at most one stride end in ten missed,
    # and every found stride within 5 cm of the truth's 2.5 m (one ZUPT-aided 0.7 s swing of a MEMS INS)
    assert found.mean() >= 0.9
    assert np.all(np.abs(est["stride_length_m"][j][found] - steps["length_m"][k][found]) < 0.05)


def test_stride_quality_flags_each_kind():
    t = np.arange(0.0, 8.0, 0.01)
    stance = np.zeros(t.size, bool)
    for a in (0.0, 1.0, 2.0, 4.5, 5.5, 6.5):  # 1 s strides (0.7 s swings), one missed stance: a 2.2 s swing
        stance[(t >= a) & (t < a + 0.3)] = True
    pos = np.zeros((t.size, 3))
    fp = {1.0: (1.4, 0.0), 2.0: (2.8, 0.0), 4.5: (5.6, 0.0), 5.5: (15.0, 0.0), 6.5: (16.4, 0.7)}
    for a, (x, z) in fp.items():
        pos[t >= a, 0] = x
        pos[t >= a, 2] = z
    gyro = np.zeros((t.size, 3))
    q = S.stride_quality(t, pos, stance, gyro, np.zeros(3), period_s=1.0)
    assert list(q.flags) == [0, 0, S.MISSED, S.FAST, S.VERTICAL]
    assert q.bad_fraction == pytest.approx(3 / 5)


def test_level_timing_offset_finds_the_half_sample_lead_and_an_injected_delay():
    # exact (ideal) samples of a level loop: the "endpoint" strapdown step rotates f_n with the attitude at the
    # END of its interval, half a sample ahead; the level-stride criterion must see that Δt/2 lead, the default
    # step (the middle of the interval) none, and an injected delay τ0 on top of either, all to within the
    # criterion's resolution (0.3 ms)
    res = sim.simulate("rectangle", seed=1, profile="ideal", rate_hz=400.0)
    t, a, w = _arrays(res)
    init = initial_alignment(t, a, w, CalibrationSettings(), G)
    stance = detect_stance(t, a, w, DetectorSettings(), G).stance
    endpoint = S.level_timing_offset(t, a, w, stance, init, G, FilterSettings(strapdown="endpoint"))
    assert endpoint["applied"] and endpoint["tau_s"] == pytest.approx(0.5 / 400.0, abs=3e-4)
    clean = S.level_timing_offset(t, a, w, stance, init, G, FilterSettings())
    assert clean["applied"] and clean["tau_s"] == pytest.approx(0.0, abs=3e-4)
    tau0 = 1e-3
    shifted = S.level_timing_offset(t, S.rotate_specific_force(a, w, tau0), w, stance, init, G, FilterSettings())
    assert clean["tau_s"] - shifted["tau_s"] == pytest.approx(tau0, abs=3e-4)


def test_timing_probes_in_threads_equal_serial_runs_bit_for_bit(walk):
    # the two probes run in two threads (the kernel releases the GIL) on force terms shared between ±δ: the
    # result must be exactly that of two serial runs on rotate_specific_force(±δ)
    from bootnav.postproc.ins import fast

    assert fast.filter_chunk.targetoptions.get("nogil") and fast.close_segment.targetoptions.get("nogil")
    t, a, w = _arrays(walk)
    init = initial_alignment(t, a, w, CalibrationSettings(), G)
    stance = detect_stance(t, a, w, DetectorSettings(), G).stance
    fs = FilterSettings()
    got = S.level_timing_offset(t, a, w, stance, init, G, fs, delta_s=0.002)
    serial = {}
    for d, key in ((-0.002, "m_minus"), (0.002, "m_plus")):
        nav = run_filter(t, S.rotate_specific_force(a, w, d), w, stance, init, G,
                         replace(fs, smoother="none", level_height=False))
        serial[key], serial["n_level"] = S.level_stride_dz(t, np.asarray(nav.pos_n), stance)
        serial[key + "_e2"] = np.mean(np.sum(S.onset_innovations(t, nav.vel_n, stance, fs) ** 2, axis=1))
    assert got["m_minus"] == serial["m_minus"] and got["m_plus"] == serial["m_plus"]
    assert got["n_level"] == serial["n_level"]
    assert got["innovation_rms_mps"] == float(np.sqrt(np.mean([serial["m_minus_e2"], serial["m_plus_e2"]])))


def test_short_walks_keep_their_samples_and_missions_calibrate_the_timing():
    # the probes' line m(τ) of a walk: slope 3 mm/ms, zero at τ* = +4/3 ms (inside the ±3 ms bound). A walk of 30
    # level strides (a mocap trial, a 20-m corridor) is not calibrated by default: between recordings of one
    # sensor τ* scatters by 6-14 ms there (SelfTuneSettings); one of 500 (a mission) is
    st = S.SelfTuneSettings()

    def timing(n_level):
        probes = {"m_minus": -0.010, "m_plus": 0.002, "n_level": n_level}
        return S.timing_from_probes(probes, st.timing_probe_s, st.timing_max_abs_s, st.timing_min_level_strides)

    short, mission = timing(30), timing(500)
    assert not short["applied"] and short["tau_s"] == 0.0
    slope = (0.002 + 0.010) / (2 * st.timing_probe_s)
    assert mission["applied"] and mission["tau_s"] == pytest.approx(0.004 / slope, rel=1e-9)
