"""The one pipeline (``pipeline.process_to``): a recording in many blocks (``settings.block_s``) gives the path,
storeys, stride flags and ellipses of the same recording in one block (the whole-record stages)."""

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.postproc.outputs import write_outputs
from bootnav.postproc.pipeline import process, process_to
from bootnav.postproc.settings import ProcessSettings
from bootnav.simulator.simulate import LongSimulation
from bootnav.simulator.writers import write_long_h5


def _settings(**selftune) -> ProcessSettings:
    s = ProcessSettings()
    s.output.plots = False
    for k, v in selftune.items():
        setattr(s.selftune, k, v)
    return s


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """2 min of the long simulation (stairs included: the storeys snap landings) in one block."""
    d = tmp_path_factory.mktemp("blocks")
    rec = write_long_h5(LongSimulation(120.0, seed=5, block_s=30.0), d / "walk.h5")
    whole = process(rec, _settings())
    write_outputs(whole, d / "whole")
    assert whole.summary["path"]["storeys"]["flights"] > 0  # the storeys have something to do
    return d, rec, whole


def results(folder):
    with h5py.File(folder / "results.h5", "r") as f:
        g = f["results/default"]
        return {**{k: g[k][()] for k in ("t_s", "pos_n_m", "vel_n_mps", "q_nb", "stance", "stance_statistic")},
                "created_utc": g.attrs["created_utc"]}


def n_blocks(t_s, block_s):
    rows = round(block_s / np.median(np.diff(t_s)))
    return -(-len(t_s) // rows)


def steps_table(folder):
    head = (folder / "steps.csv").read_text().splitlines()[0].split(",")
    return head, np.loadtxt(folder / "steps.csv", delimiter=",", skiprows=1)


@pytest.mark.parametrize("block_s", [2.9, 13.0, 1000.0])
def test_every_block_length_gives_the_one_block_path(walk, block_s):
    d, rec, whole = walk
    out = d / f"b{block_s:g}"
    settings = _settings()
    settings.block_s = block_s
    summary, files = process_to(rec, settings, out)
    r = results(out)
    np.testing.assert_array_equal(r["t_s"], whole.t_s)
    np.testing.assert_array_equal(r["stance"].astype(bool), whole.stance)
    assert np.abs(r["pos_n_m"] - whole.pos_n).max() <= 1e-9  # storeys applied in both (their offsets to rounding)
    assert np.abs(r["q_nb"] - whole.q_nb).max() <= 1e-9
    # the statistic's moving sums are differences of running sums over another stretch of samples: rounding of
    # the order of eps x the running sum
    stat = whole.stance_result.statistic
    np.testing.assert_allclose(r["stance_statistic"], stat, rtol=0, atol=4 * np.finfo(float).eps * np.abs(stat).sum())
    assert (out / "trajectory.csv").read_bytes() == (d / "whole" / "trajectory.csv").read_bytes()
    assert summary["navigation"]["timing_offset"]["tau_s"] == whole.navigation.timing["tau_s"]
    assert summary["path"]["distance_m"] == pytest.approx(whole.summary["path"]["distance_m"], abs=1e-9)
    storeys, theirs = summary["path"]["storeys"], whole.summary["path"]["storeys"]
    assert {k: storeys[k] for k in ("flights", "flights_agreeing", "landings_on_known_level", "risers")} == \
        {k: theirs[k] for k in ("flights", "flights_agreeing", "landings_on_known_level", "risers")}
    assert storeys["riser_estimate_m"] == pytest.approx(theirs["riser_estimate_m"], abs=1e-9)
    # steps.csv: the same columns (flags, floor, ellipses) and values to the printed precision
    head, mine = steps_table(out)
    whole_head, ref = steps_table(d / "whole")
    assert head == whole_head and {"quality_flags", "floor", "ellipse_major_m"} <= set(head)
    np.testing.assert_allclose(mine, ref, atol=1.5e-4)  # last printed digit, footprint sums in another order
    assert summary["uncertainty"]["final_ellipse_major_m"] == pytest.approx(
        whole.summary["uncertainty"]["final_ellipse_major_m"], rel=1e-9)
    assert summary["navigation"].get("blocks", 1) == n_blocks(whole.t_s, block_s)
    # the filter's 1-σ of each error state at the last sample: the same filter, sample for sample
    np.testing.assert_allclose(summary["filter"]["final_state_sigma"], whole.summary["filter"]["final_state_sigma"],
                               rtol=1e-9)
    # the whole-record decisions: gait period, confidence, the timing probes' innovation (the same arithmetic)
    for key in ("gait_period_s", "confidence"):
        assert summary["navigation"][key] == pytest.approx(whole.summary["navigation"][key], rel=1e-9), key
    assert summary["navigation"]["configured_failed"] is whole.summary["navigation"]["configured_failed"] is None
    assert summary["navigation"]["timing_offset"]["innovation_rms_mps"] == pytest.approx(
        whole.navigation.timing["innovation_rms_mps"], rel=1e-9)
    # the whole-record checks and figures of the summary: the gap and saturation warnings (the walk has both), the
    # saturated bursts, the mount check (‖ω‖'s 99th percentile, exact from passes), the conventions
    assert any("gaps longer" in w for w in summary["warnings"]) and summary["saturation_intervals"]
    assert summary["warnings"] == whole.summary["warnings"]
    assert summary["saturation_intervals"] == whole.summary["saturation_intervals"]
    assert summary["mount"] == pytest.approx(whole.summary["mount"], rel=1e-12)
    assert summary["conventions"] == whole.summary["conventions"]
    # the adaptive detector's representative threshold 10^median γ: γ = max/min filters and a convex combination of
    # L = log10 T (and constants), so |Δγ| <= max |ΔL| over the samples, from the statistic's rounding above
    dL = np.abs(np.log10(np.maximum(r["stance_statistic"], 1e-300)) - np.log10(np.maximum(stat, 1e-300))).max()
    assert summary["stance"]["threshold"] == pytest.approx(whole.summary["stance"]["threshold"],
                                                           rel=10.0 ** dL - 1.0 + 1e-15)


@pytest.mark.parametrize("block_s", [13.0, 50.0])
def test_the_timing_probes_stop_early_and_change_nothing(walk, tmp_path, block_s, monkeypatch):
    """With few level strides to count, the block passes' probes stop early (``passes._ForwardProbes``): the
    same figures, to the last bit, as probes run to the end of the record, and the one-block run's."""
    from bootnav.postproc import passes

    d, rec, _ = walk
    whole = process(rec, _settings(timing_max_level_strides=8))
    settings = _settings(timing_max_level_strides=8)
    settings.block_s = block_s
    stopped, finish = [], passes._ForwardProbes.finish

    def spy(self, starts, n):
        stopped.append(self.cut is not None)
        return finish(self, starts, n)

    monkeypatch.setattr(passes._ForwardProbes, "finish", spy)
    early, _ = process_to(rec, settings, tmp_path / "early")
    assert stopped == [True]
    monkeypatch.setattr(passes._ForwardProbes, "_look", lambda self, starts: None)  # never stop
    late, _ = process_to(rec, settings, tmp_path / "late")
    mine, theirs = early["navigation"]["timing_offset"], whole.navigation.timing
    assert mine["probe_s"] < 0.5 * whole.summary["input"]["duration_s"]  # the probes saw the first part only
    assert mine == late["navigation"]["timing_offset"]
    assert (tmp_path / "early" / "trajectory.csv").read_bytes() == (tmp_path / "late" / "trajectory.csv").read_bytes()
    assert {k: mine[k] for k in ("n_level", "probe_s", "tau_s", "applied")} == \
        {k: theirs[k] for k in ("n_level", "probe_s", "tau_s", "applied")}
    for k in ("m_minus", "m_plus", "innovation_rms_mps"):  # footprints summed in another order: rounding
        assert mine[k] == pytest.approx(theirs[k], rel=1e-9), k


def test_many_blocks_flag_the_strides_one_block_flags(walk, tmp_path):
    """Limits tight enough that strides are flagged (FAST: longer than 1 m; ROLLING: a stance phase's median
    turning rate above the median of them all, so half the phases: it compares medians over phases cut by the
    blocks); no fallback, so both runs keep the configured detector."""
    d, rec, whole = walk
    rate = float(np.median(whole.navigation.quality.stance_rate_radps))
    tight = dict(max_stride_m=1.0, max_stance_rate_radps=rate, max_bad_fraction=1.0)
    whole = process(rec, _settings(**tight))
    write_outputs(whole, tmp_path / "whole")
    settings = _settings(**tight)
    settings.block_s = 7.0
    summary, _ = process_to(rec, settings, tmp_path / "blocks")
    flags = whole.summary["navigation"]["stride_flags"]
    assert flags["fast"] > 0 and flags["rolling"] > 0 and flags["fast"] < len(whole.steps["t_s"])
    assert summary["navigation"]["stride_flags"] == flags
    assert summary["navigation"]["implausible_stride_fraction"] == \
        whole.summary["navigation"]["implausible_stride_fraction"]
    head, mine = steps_table(tmp_path / "blocks")
    _, ref = steps_table(tmp_path / "whole")
    k = head.index("quality_flags")
    np.testing.assert_array_equal(mine[:, k], ref[:, k])


def _cli(*args, timeout=180):
    return subprocess.run([sys.executable, "-m", "bootnav", "process", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def test_old_command_lines_still_run(walk, tmp_path):
    """--chunk-s is the block length's old name; --memory-limit is ignored with a warning."""
    d, rec, whole = walk
    p = _cli(rec, "--out", tmp_path / "o", "--chunk-s", "10", "--memory-limit", "1", "--no-plots")
    assert p.returncode == 0, p.stderr
    assert "--memory-limit is deprecated" in p.stderr and "Traceback" not in p.stderr
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary["settings"]["block_s"] == 10.0 and summary["navigation"]["blocks"] == n_blocks(whole.t_s, 10.0)
    assert np.abs(results(tmp_path / "o")["pos_n_m"] - whole.pos_n).max() <= 1e-9


def test_a_detector_that_needs_the_whole_record_runs_in_the_passes_with_a_warning(walk, tmp_path):
    """A detector that cannot stream (``xio``) gets its whole-record stance in chunks: blocks of 10 s give the
    one-block path, with a warning that memory grows with the recording."""
    d, rec, whole = walk
    for out, block in (("c", "10"), ("one", "1000")):
        p = _cli(rec, "--out", tmp_path / out, "--block-s", block, "--detector", "xio", "--no-plots", "--no-hdf5")
        assert p.returncode == 0, p.stderr
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    assert any("the stance detector 'xio' cannot run block by block" in w and "memory grows" in w
               for w in summary["warnings"])
    assert summary["navigation"]["blocks"] > 1 and "confidence" in summary  # the whole-record stages ran
    assert (tmp_path / "c" / "trajectory.csv").read_bytes() == (tmp_path / "one" / "trajectory.csv").read_bytes()
    p = _cli(rec, "--out", tmp_path / "b", "--block-s", "-1")
    assert p.returncode == 1 and "block_s" in p.stderr and "Traceback" not in p.stderr


def _one_and_many(rec, tmp_path, block_s=4.0, **kw):
    """The same run in one block and in blocks of ``block_s`` (``process_to``): (one, many) summaries and folders."""
    runs = []
    for label, b in (("one", 1000.0), ("many", block_s)):
        s = _settings()
        s.block_s = b
        for k, v in kw.items():
            setattr(s, k, v)
        runs.append((*process_to(rec, s, tmp_path / label), tmp_path / label))
    (one, _, d1), (many, _, d2) = runs
    assert one["navigation"].get("blocks", 1) == 1 and many["navigation"]["blocks"] > 1
    assert not any("processed as one" in w for w in many["warnings"])
    return one, d1, many, d2


def _assert_same_outputs(one, d1, many, d2):
    r1, r2 = results(d1), results(d2)
    np.testing.assert_array_equal(r2["t_s"], r1["t_s"])
    np.testing.assert_array_equal(r2["stance"], r1["stance"])
    assert np.abs(r2["pos_n_m"] - r1["pos_n_m"]).max() <= 1e-9  # as the one-block path above
    assert (d2 / "trajectory.csv").read_bytes() == (d1 / "trajectory.csv").read_bytes()
    for key in ("samples_total", "samples_processed", "t_start_s", "t_end_s", "crop_s", "format"):
        assert many["input"][key] == one["input"][key], key
    with h5py.File(d1 / "results.h5", "r") as f1, h5py.File(d2 / "results.h5", "r") as f2:
        assert f2["results/default"].attrs["sample_index_start"] == f1["results/default"].attrs["sample_index_start"]
        assert f2["imu/t_s"].shape == f1["imu/t_s"].shape  # the recording beside the results (linked or imported)


def test_a_crop_in_blocks_is_the_crop_in_one_block(walk, tmp_path):
    """The crop is a window of rows (``source.crop_window``): the same samples, the recording's clock kept."""
    d, rec, whole = walk
    one, d1, many, d2 = _one_and_many(rec, tmp_path, crop_s=(10.0, 100.0))
    _assert_same_outputs(one, d1, many, d2)
    t = results(d2)["t_s"]
    inside = whole.t_s[(whole.t_s >= 10.0) & (whole.t_s <= 100.0)]
    np.testing.assert_array_equal(t, inside)
    assert many["input"]["crop_s"] == [10.0, 100.0]
    with h5py.File(d2 / "results.h5", "r") as f:
        assert f["results/default"].attrs["sample_index_start"] == int(np.searchsorted(whole.t_s, 10.0))


def test_reference_metrics_in_blocks_are_the_one_block_metrics(walk, tmp_path):
    """A timed reference (every metric of ``compute_metrics``: distance, deviation, height, the timed errors),
    here the simulated walk's own stride footprints shifted, compared with the path of the final pass."""
    d, rec, whole = walk
    fp = whole.steps
    ref = tmp_path / "ref.csv"
    ref.write_text("t_s,x_m,y_m,z_m\n" + "".join(f"{t:.3f},{x + 0.3:.4f},{y - 0.2:.4f},{z:.4f}\n" for t, x, y, z in
                                                zip(fp["t_s"], fp["x_m"], fp["y_m"], fp["z_m"])))
    one, d1, many, d2 = _one_and_many(rec, tmp_path, reference=str(ref))
    _assert_same_outputs(one, d1, many, d2)
    assert {"deviation_error_m", "mean_h_err_m", "height_error_m"} <= set(one["metrics"])
    assert set(many["metrics"]) == set(one["metrics"])
    for key, value in one["metrics"].items():
        if isinstance(value, float):  # metres of a path equal to 1e-9 m: equal to 1e-9 m
            assert many["metrics"][key] == pytest.approx(value, abs=1e-8), key
        else:
            assert many["metrics"][key] == value, key
    assert many["closed_loop"] == one["closed_loop"]


def test_an_imported_file_in_blocks_is_the_one_block_run(walk, tmp_path):
    """A non-HDF5 input (the canonical imu.csv) is read once and passed through ``source.MemoryReader``;
    results.h5 holds the imported recording, as the one-block run writes it."""
    d, rec, whole = walk
    csv = tmp_path / "imu.csv"
    r = whole.recording
    np.savetxt(csv, np.column_stack((r.t_s, r.acc_mps2, r.gyro_radps)), fmt="%.17g", delimiter=",",
               header="t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps", comments="")
    one, d1, many, d2 = _one_and_many(csv, tmp_path, crop_s=(5.0, 110.0))
    _assert_same_outputs(one, d1, many, d2)
    assert many["input"]["format"] == "imported"


def test_into_recording_in_blocks(walk, tmp_path):
    import shutil

    d, rec, whole = walk
    copy = tmp_path / "copy.h5"
    shutil.copy2(rec, copy)
    s = _settings()
    s.block_s = 9.0
    summary, files = process_to(copy, s, tmp_path / "o", into_recording=True)
    assert summary["navigation"]["blocks"] > 1 and files["hdf5"] == f"{copy}:/results/default"
    with h5py.File(copy, "r") as f:
        assert np.abs(f["results/default/pos_n_m"][()] - whole.pos_n).max() <= 1e-9
        assert "imu" in f and f["imu/t_s"].shape[0] == len(whole.t_s)


def _assert_fallback_as_one_block(rec, settings, out, block_s=4.0):
    """The same run in one block (``process``, ``navigate``'s fallback on whole arrays) and in blocks of
    ``block_s`` (the fallback's candidates scored in passes): the choice, every candidate's figures, the path."""
    whole = process(rec, settings)
    write_outputs(whole, out / "whole")
    settings.block_s = block_s
    summary, _ = process_to(rec, settings, out / "blocks")
    mine, theirs = summary["navigation"], whole.summary["navigation"]
    assert mine["blocks"] > 1 and not any("processed as one" in w for w in summary["warnings"])
    for key in ("stance_choice", "fallback_used", "configured_failed"):
        assert mine[key] == theirs[key], key
    assert [c["name"] for c in mine["candidates"]] == [c["name"] for c in theirs["candidates"]]
    for c, d in zip(mine["candidates"], theirs["candidates"]):  # forward runs: the path to rounding
        assert set(c) == set(d)
        for key in set(c) - {"name"}:
            assert c[key] == pytest.approx(d[key], rel=1e-9), (c["name"], key)
    assert mine["confidence"] == pytest.approx(theirs["confidence"], rel=1e-9)
    assert summary["warnings"] == whole.summary["warnings"]
    r = results(out / "blocks")
    np.testing.assert_array_equal(r["stance"].astype(bool), whole.stance)
    assert np.abs(r["pos_n_m"] - whole.pos_n).max() <= 1e-9
    assert (out / "blocks" / "trajectory.csv").read_bytes() == (out / "whole" / "trajectory.csv").read_bytes()
    return summary


def test_a_failed_stance_mask_falls_back_in_blocks_as_in_one_block(walk, tmp_path):
    """More stance phases required than the walk has: the configured detector fails (``checks.stance_findings``)
    and ``navigate``'s fallback chooses another stance detection; in blocks the candidates are scored by passes
    and the same one is chosen, the same path written. Without the fallback both refuse."""
    d, rec, whole = walk
    settings = _settings()
    settings.checks.min_stance_phases = 10_000
    summary = _assert_fallback_as_one_block(rec, settings, tmp_path)
    assert summary["navigation"]["configured_failed"].startswith("stance detector 'adaptive' found")
    assert summary["navigation"]["fallback_used"] and len(summary["navigation"]["candidates"]) >= 4
    settings.selftune.fallback = False  # as the one-block run: the failure refused
    with pytest.raises(InputError, match="stance phase"):
        process_to(rec, settings, tmp_path / "o2")


def test_implausible_strides_fall_back_in_blocks_as_in_one_block(walk, tmp_path):
    """Strides flagged (longer than 1 m: FAST) beyond ``max_bad_fraction``: the configured path fails on its
    strides after its final pass; the fallback's passes run again, as ``navigate`` runs the filter again."""
    d, rec, whole = walk
    settings = _settings(max_stride_m=1.0, max_bad_fraction=0.05)
    summary = _assert_fallback_as_one_block(rec, settings, tmp_path, block_s=7.0)
    assert "strides are implausible" in summary["navigation"]["configured_failed"]


def _auto_settings(block_s=None) -> ProcessSettings:
    s = _settings()
    s.filter.heading_aid = "auto"
    if block_s is not None:
        s.block_s = block_s
    return s


def _assert_auto_as_one_block(whole, summary, out):
    """The heading decision, its per-segment counts and the path of the block passes are the one-block run's."""
    mine, theirs = summary["filter"]["heading_decision"], whole.summary["filter"]["heading_decision"]
    assert summary["navigation"]["blocks"] > 1 and not any("processed as one" in w for w in summary["warnings"])
    assert (mine["on"], mine["reason"], mine["segments"], mine["n_strides"], mine["n_straight"]) == \
        (theirs["on"], theirs["reason"], theirs["segments"], theirs["n_strides"], theirs["n_straight"])
    for key in ("reference_rad", "share", "cross"):  # footprints summed in another order: rounding
        assert mine[key] == pytest.approx(theirs[key], abs=1e-9, nan_ok=True), key
    assert summary["filter"]["heading_aid_updates"] == whole.nav.info["heading_aid_updates"]
    r = results(out)
    np.testing.assert_array_equal(r["stance"].astype(bool), whole.stance)
    assert np.abs(r["pos_n_m"] - whole.pos_n).max() <= 1e-9
    assert np.abs(r["q_nb"] - whole.q_nb).max() <= 1e-9


@pytest.mark.parametrize("variant", ["per segment", "storeys off", "every stride"])
def test_heading_auto_on_in_blocks_is_the_one_block_run(walk, tmp_path, variant):
    """The shift's rectilinear loop: auto decides on, per segment (the turns' strides not aided); the unaided
    pass decides, the storeys and the written path are the aided filter's with the gate, as in one block.
    Without the storeys the aided path is only the final pass's; with ``heading_aid_segments`` off no gate."""
    d, rec, _ = walk

    def settings(block_s=None):
        s = _auto_settings(block_s)
        s.floor_storeys = variant != "storeys off"
        s.filter.heading_aid_segments = variant != "every stride"
        return s

    whole = process(rec, settings())
    dec = whole.summary["filter"]["heading_decision"]
    assert dec["on"] and whole.nav.info["heading_aid_updates"] > 0
    if variant == "per segment":
        assert 0 < dec["segments"]["aided"] < dec["n_strides"]  # the gate is open and closed
    summary, _ = process_to(rec, settings(13.0), tmp_path / "o")
    _assert_auto_as_one_block(whole, summary, tmp_path / "o")
    if variant != "storeys off":
        storeys, theirs = summary["path"]["storeys"], whole.summary["path"]["storeys"]
        assert storeys["flights"] == theirs["flights"] > 0
        assert storeys["riser_estimate_m"] == pytest.approx(theirs["riser_estimate_m"], abs=1e-9)


def _out_and_back(pb, rng):
    """A corridor walked out and back: one axis only (no cross strides), so auto decides off."""
    pb.walk_to(25.0, 0.0).walk_to(0.0, 0.0)
    pb.stand(float(rng.uniform(2.0, 5.0)))


def test_heading_auto_off_in_blocks_is_the_one_block_run(tmp_path):
    rec = write_long_h5(LongSimulation(60.0, seed=2, block_s=30.0, segment=_out_and_back), tmp_path / "oab.h5")
    whole = process(rec, _auto_settings())
    assert not whole.summary["filter"]["heading_decision"]["on"] and whole.nav.info["heading_aid_updates"] == 0
    summary, _ = process_to(rec, _auto_settings(7.0), tmp_path / "o")
    _assert_auto_as_one_block(whole, summary, tmp_path / "o")


@pytest.mark.parametrize("kind", ["jitter", "quantised", "gaps and repeats"])
def test_the_nominal_period_of_the_passes_is_the_whole_records(kind):
    """Δt₀ of the block passes (``passes._nominal_period``, passes over the times) is ``timebase.sample_period``
    of the whole time axis to the last bit, however few steps a pass may hold (``cap``) or read (``rows``)."""
    from bootnav.core.timebase import sample_period
    from bootnav.postproc.passes import _nominal_period
    from bootnav.postproc.source import MemoryReader
    from bootnav.logger.recording import Recording, make_events

    rng = np.random.default_rng(7)
    n = 50_001
    dt = {"jitter": 0.005 + rng.normal(0, 2e-6, n), "quantised": np.round(rng.choice([0.004, 0.005, 0.006], n), 3),
          "gaps and repeats": rng.choice([0.005, 0.0049, 0.0051, 0.0, -0.001, 0.02], n)}[kind]
    t = np.cumsum(dt)
    rec = MemoryReader(Recording(path=None, t_s=t, acc_mps2=np.zeros((n, 3)), gyro_radps=np.zeros((n, 3)),
                                 saturated=None, events=make_events([]), meta={}, attrs={}))
    for rows, cap in ((1 << 20, 1 << 20), (999, 64), (5, 3)):
        assert _nominal_period(rec, rows, cap) == sample_period(t)


def test_the_cycle_minimum_candidate_from_blocks_is_the_whole_records(walk):
    """The "cycle minimum" fallback candidate (the configured mask plus the cycle-minimum windows of the cycles it
    misses) from StanceChunks spilled to a temporary file equals ``selftune``'s on the whole arrays; here a mask
    that misses every other stance phase, so the windows are added."""
    from bootnav.core.runs import runs
    from bootnav.postproc import selftune
    from bootnav.postproc.calibration import stance_reference
    from bootnav.postproc.detectors.stream import StanceChunk
    from bootnav.postproc.passes import _cycle_minimum

    d, rec, whole = walk
    settings = _settings()
    starts, stops = runs(whole.stance)
    holed = whole.stance.copy()
    for a, b in zip(starts[1::2], stops[1::2]):
        holed[a:b] = False
    bias_det, g_det = stance_reference(whole.init, whole.gravity_mps2)
    period = whole.navigation.period_s
    sat = whole.saturated.astype(np.uint8)
    ref = selftune.cycle_minimum_candidate(whole.t_s, whole.acc_b, whole.gyro_b - bias_det, g_det, period,
                                           settings.detector, settings.selftune, sat.astype(bool), holed)
    assert ref is not None and (ref & ~holed).any()
    cuts = [0, 1, 777, 5000, 5001, 12345, len(whole.t_s)]
    chunks = (StanceChunk(a, whole.t_s[a:b], whole.acc_b[a:b], whole.gyro_b[a:b], holed[a:b], sat[a:b])
              for a, b in zip(cuts[:-1], cuts[1:]))
    mine = _cycle_minimum(chunks, len(whole.t_s), bias_det, g_det, period, settings)
    np.testing.assert_array_equal(mine, ref)


@pytest.mark.parametrize("storeys", [True, False])
def test_revisits_in_blocks_are_the_one_block_revisits(walk, tmp_path, storeys):
    """The pose graph over the strides (``building.revisits``) in passes: the final filter's footprints and
    their variances from a pass, the corrections interpolated in time on the rows of the passes after it (the
    storeys' and the final one), as ``apply_revisits`` corrects the whole path."""
    d, rec, _ = walk

    def settings(block_s=None):
        s = _settings()
        s.filter.revisits = "entry+stairs"
        s.floor_storeys = storeys
        if block_s is not None:
            s.block_s = block_s
        return s

    whole = process(rec, settings())
    write_outputs(whole, tmp_path / "whole")
    report = whole.nav.info["revisits"]
    assert report["edges"] and report["max_correction_m"] > 0.01  # the walk has revisits to correct
    summary, _ = process_to(rec, settings(6.0), tmp_path / "blocks")
    assert summary["navigation"]["blocks"] > 1 and not any("processed as one" in w for w in summary["warnings"])
    mine = summary["filter"]["revisits"]
    assert mine["edges"] == report["edges"]
    assert mine["max_correction_m"] == pytest.approx(report["max_correction_m"], abs=1e-9)
    r = results(tmp_path / "blocks")
    np.testing.assert_array_equal(r["stance"].astype(bool), whole.stance)
    assert np.abs(r["pos_n_m"] - whole.pos_n).max() <= 1e-9
    assert summary["navigation"]["stride_flags"] == whole.summary["navigation"]["stride_flags"]
    assert (tmp_path / "blocks" / "trajectory.csv").read_bytes() == (tmp_path / "whole" / "trajectory.csv").read_bytes()


@pytest.mark.parametrize("heading_aid", ["auto", "none"])
def test_passes_over_one_block_replay_the_heading_pass_and_give_the_whole_path(walk, monkeypatch, heading_aid):
    """Passes over a single block (what a one-block run takes once ``process`` is the passes): the rows are decoded
    once, and the final pass replays the rows of the pass before it that ran the same filter (the storeys', or the
    unaided one when the heading decision is off: ``navigate`` runs it once) instead of running the filter +
    smoother again; the path is the whole-array run's."""
    from bootnav.logger.recording import RecordingReader
    from bootnav.postproc import passes, pipeline
    from bootnav.postproc.ins.stream import StreamNavigator
    from bootnav.postproc.source import crop_window

    d, rec, _ = walk
    settings = _settings()
    settings.filter.heading_aid = heading_aid
    whole = process(rec, settings)
    made = []
    real = StreamNavigator.from_initial_state.__func__
    monkeypatch.setattr(StreamNavigator, "from_initial_state",
                        classmethod(lambda cls, *a, **k: made.append(a[-1].smoother) or real(cls, *a, **k)))
    out = d / f"one-{heading_aid}"
    reader = RecordingReader(rec)
    try:
        run = pipeline._Input(crop_window(reader, None, str(rec)), str(rec), rec, True, None, False, None)
        summary, _ = passes.BlockPasses(run, settings, out, [], pipeline._StageClock(None), None, None).run()
    finally:
        reader.close()
    assert summary["navigation"]["blocks"] == 1
    aided = heading_aid == "auto" and summary["filter"]["heading_decision"]["on"]
    # the smoothed filters made: the one the storeys are found on (the unaided one when no aid), and the aided one
    # when the decision is on; the final pass makes none, it replays the last one's rows
    assert made.count("rts") == 1 + aided
    r = results(out)
    np.testing.assert_array_equal(r["t_s"], whole.t_s)
    np.testing.assert_array_equal(r["stance"].astype(bool), whole.stance)
    assert np.abs(r["pos_n_m"] - whole.pos_n).max() <= 1e-9
    assert np.abs(r["q_nb"] - whole.q_nb).max() <= 1e-9
    assert summary["path"]["distance_m"] == pytest.approx(whole.summary["path"]["distance_m"], abs=1e-9)


def test_a_run_in_blocks_writes_the_geojson_of_the_one_block_run(walk):
    """``--geo-anchor``: path.geojson (footprints, start, end in WGS-84) is written by a run in blocks too (it was
    silently left out), the same footprints as the one-block run's."""
    d, rec, _ = walk
    gj = {}
    for block_s in (13.0, 1000.0):
        settings = _settings()
        settings.output.geo_anchor = (57.7, 11.9, 10.0)
        settings.block_s = block_s
        _, files = process_to(rec, settings, d / f"geo{block_s:g}")
        gj[block_s] = json.loads((d / f"geo{block_s:g}" / "path.geojson").read_text())
        assert files["geojson"] == str(d / f"geo{block_s:g}" / "path.geojson")
    many, one = gj[13.0], gj[1000.0]
    assert many["properties"] == one["properties"] and many["properties"]["footprints"] > 10
    for a, b in zip(many["features"], one["features"], strict=True):
        assert a["geometry"]["type"] == b["geometry"]["type"]
        # coordinates rounded to 1e-8 deg (≈ 1 mm): footprints equal to rounding
        np.testing.assert_allclose(a["geometry"]["coordinates"], b["geometry"]["coordinates"], rtol=0, atol=2e-8)
    assert many["features"][0]["properties"]["distance_m"] == pytest.approx(
        one["features"][0]["properties"]["distance_m"], rel=1e-9)
