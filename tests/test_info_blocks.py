"""``bootnav info`` reads a recording block by block, or the summary its writer stored: either way its
figures equal the whole-array computation.

The reference below computes every figure from the whole arrays of ``recording.load`` with the time-base
functions, as ``info`` did before it read in blocks. The recordings put gaps, saturation runs, non-finite
samples, a block whose own median step exceeds the recording's (so its gap candidates are incomplete) and
the first motion exactly at or across block boundaries. Every recording is checked twice: as written (the
writer's summary) and as a copy without the summary (scanned, as a recording whose writer died).
"""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest

import bootnav.logger.cli_info as info
import bootnav.logger.samplestats as samplestats
from bootnav.core.timebase import gap_mask, missing_samples, nominal_period, timing_summary
from bootnav.logger.recording import RecordingWriter, counts_channel, load, si_channel, write_recording

pytestmark = pytest.mark.timeout(60)

RATE_HZ = 100.0
T = 1.0 / RATE_HZ
BLOCK = 1000  # rows per block in these tests; the files span 12 blocks


def whole_array_figures(path) -> dict:
    """The figures ``summarize`` reports, from whole arrays (no seq numbers here: gaps from timestamps)."""
    rec = load(path, with_truth=False)
    dt = np.diff(rec.t_s)
    good = dt[np.isfinite(dt) & (dt > 0)]
    med = nominal_period(dt)
    idx = np.flatnonzero(gap_mask(dt, med))
    warnings = []
    for name, arr in (("acc", rec.acc_mps2), ("gyro", rec.gyro_radps)):
        bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
        if bad.size:
            warnings.append(f"{name}: {bad.size} non-finite samples (first at sample {int(bad[0])})")
        finite = arr[np.isfinite(arr)]
        if finite.size and np.all(finite == 0):
            warnings.append(f"{name}: all zero (sensor not delivering data?)")
    if not warnings and np.nanstd(rec.acc_mps2, axis=0).max() < info.STILL_ACC_STD_MPS2 \
            and np.nanmax(np.abs(rec.gyro_radps)) < info.STILL_GYRO_RADPS:
        warnings.append("no motion: the sensor stayed still for the whole recording")
    sat = rec.saturated
    return {
        "frames": rec.n,
        "duration_s": float(rec.t_s[-1] - rec.t_s[0]),
        "rate_hz": timing_summary(rec.t_s)["rate_measured_hz"],
        "jitter_s": timing_summary(rec.t_s)["jitter_s"],
        "dt_min_s": float(good.min()),
        "dt_max_s": float(good.max()),
        "gap_list": [{"t_s": float(rec.t_s[i + 1]), "sample_index": int(i + 1), "missing": int(m)}
                     for i, m in zip(idx, missing_samples(dt[idx], med))],
        "saturated_samples": {a: int(((sat >> i) & 1).sum()) for i, a in enumerate(info.AXES)},
        "saturated_any": int((sat != 0).sum()),
        "data_warnings": warnings,
    }


def has_summary(path) -> bool:
    with h5py.File(path, "r") as f:
        n = f["imu/t_s"].shape[0]
        return samplestats.read_summary(f["imu"], n) is not None


def without_summary(path):
    """A copy of the recording without the writer's summary: ``info`` has to scan it."""
    copy = path.with_name(path.stem + "_scanned.h5")
    shutil.copyfile(path, copy)
    with h5py.File(copy, "r+") as f:
        del f["imu"].attrs["summary"]
    return copy


def assert_same_figures(path, *, summary=True, **kw):
    """``summarize`` of the recording and of its copy without summary equal the whole-array figures
    (``summary``: whether the writer must have stored one)."""
    ref = whole_array_figures(path)
    assert has_summary(path) is summary
    got = info.summarize(path, **kw)
    # the jitter is a std: summed in another order, it may differ in the last bits of a float64
    assert got["jitter_s"] == pytest.approx(ref["jitter_s"], rel=1e-12, abs=0)
    assert {k: got[k] for k in ref if k != "jitter_s"} == {k: v for k, v in ref.items() if k != "jitter_s"}
    assert got["gaps"] == len(ref["gap_list"]) and got["gap_source"] == "timestamps"
    if summary:
        scanned = info.summarize(without_summary(path), **kw)
        assert scanned["jitter_s"] == pytest.approx(ref["jitter_s"], rel=1e-12, abs=0)
        same = [json.dumps({k: v for k, v in x.items() if k not in ("file", "jitter_s")}, sort_keys=True)
                for x in (scanned, got)]  # as text: NaN (an unknown nominal rate) equals NaN
        assert same[0] == same[1]
    return got


def jittered_times(n, rng, period=T):
    """Times of a 100 Hz clock quantised to µs with ±20 µs jitter."""
    return np.round((np.arange(n) * period + rng.uniform(-20e-6, 20e-6, n)) * 1e6) / 1e6


@pytest.fixture(scope="module")
def hazards(tmp_path_factory):
    """12 blocks of SI floats: gaps on and across block boundaries, one gap of 1.6 periods inside a block
    sampled at 1.3 periods (its candidates' bound, 1.25 x 1.3 = 1.625 periods, exceeds the recording's gap
    bound 1.5), saturation runs and a NaN row across boundaries."""
    rng = np.random.default_rng(18)
    n = 12 * BLOCK
    dt = np.diff(jittered_times(n + 1, rng))
    dt[5 * BLOCK:6 * BLOCK] = 1.3 * T  # a block at a lower rate
    dt[5 * BLOCK + 500] = 1.6 * T  # one lost sample, only a gap by the recording's median
    dt[BLOCK - 1] = 3 * T  # the step into the first row of block 1: two lost samples
    dt[2 * BLOCK - 2] = 5 * T  # the last step inside block 1
    dt[3 * BLOCK] = 2 * T  # the step out of the first row of block 3
    t = np.r_[0.0, np.cumsum(dt)][:n]
    acc = rng.normal(0.0, 1.0, (n, 3)) + [0.0, 0.0, 9.81]
    gyro = rng.normal(0.0, 0.5, (n, 3))
    acc[4 * BLOCK - 1, 1] = np.nan  # last row of block 3
    acc[4 * BLOCK, 2] = np.inf  # first row of block 4
    gyro[7 * BLOCK + 3, 0] = np.nan
    sat = np.zeros(n, np.uint8)
    sat[BLOCK - 3:BLOCK + 4] |= 1 << 3  # gx, across the boundary of blocks 0 and 1
    sat[8 * BLOCK - 1:8 * BLOCK + 1] |= (1 << 0) | (1 << 5)  # ax and gz, the last row of block 7 and first of 8
    path = tmp_path_factory.mktemp("blocks") / "hazards.h5"
    write_recording(path, t, acc, gyro, saturated=sat, acc_channel=si_channel("acc", 16 * 9.80665),
                    gyro_channel=si_channel("gyro", np.deg2rad(2000)))
    return path


@pytest.mark.parametrize("block_rows", [BLOCK, BLOCK - 3, 4096, info.BLOCK_ROWS])
def test_blocks_give_the_whole_array_figures(hazards, block_rows):
    s = assert_same_figures(hazards, block_rows=block_rows)
    # what the recording was built with, independently of the reference
    assert [(g["sample_index"], g["missing"]) for g in s["gap_list"]] == [
        (BLOCK, 2), (2 * BLOCK - 1, 4), (3 * BLOCK + 1, 1), (5 * BLOCK + 501, 1)]
    assert s["saturated_samples"] == {"ax": 2, "ay": 0, "az": 0, "gx": 7, "gy": 0, "gz": 2}
    assert s["saturated_any"] == 9
    assert s["data_warnings"] == [f"acc: 2 non-finite samples (first at sample {4 * BLOCK - 1})",
                                  f"gyro: 1 non-finite samples (first at sample {7 * BLOCK + 3})"]


def test_the_fallbacks_for_many_distinct_steps_and_many_gap_candidates(hazards, monkeypatch):
    """Steps kept as values instead of counted, and blocks read again instead of candidates kept."""
    scanned = without_summary(hazards)
    monkeypatch.setattr(samplestats, "MAX_DISTINCT_STEPS", 16)
    monkeypatch.setattr(samplestats, "MAX_GAP_CANDIDATES", 0)
    assert_same_figures(scanned, summary=False, block_rows=BLOCK)
    # a writer in the same situation stores no summary (it cannot read its blocks again)
    again = hazards.with_name("fallbacks.h5")
    rec = load(hazards, with_truth=False)
    write_recording(again, rec.t_s, rec.acc_mps2, rec.gyro_radps, saturated=rec.saturated)
    assert_same_figures(again, summary=False, block_rows=BLOCK)


@pytest.mark.parametrize("moves_from", [None, 11 * BLOCK, 11 * BLOCK - 1, 12 * BLOCK - 1])
@pytest.mark.parametrize("tilted", [False, True])
def test_no_motion_is_decided_on_every_block_of_int16_counts(tmp_path, moves_from, tilted):
    """A boot standing still (counts), or moving only from a row at or near the end of the last block; tilted:
    still within every block, but the acc z mean steps by 0.19 m/s² after half of the blocks (a std of
    0.096 m/s² over the recording, only from the spread between the blocks' means)."""
    rng = np.random.default_rng(7)
    n = 12 * BLOCK
    acc = np.tile(np.array([0, 0, 2048], np.int16), (n, 1)) + rng.integers(-1, 2, (n, 3)).astype(np.int16)
    acc[6 * BLOCK:, 2] += 40 if tilted else 0
    gyro = rng.integers(-2, 3, (n, 3)).astype(np.int16)  # 1e-3 rad/s a count: far below the bound
    if moves_from is not None:
        gyro[moves_from, 2] = 100  # 0.1 rad/s
    path = tmp_path / "still.h5"
    write_recording(path, jittered_times(n, rng), acc, gyro, acc_channel=counts_channel("acc", 9.80665 / 2048),
                    gyro_channel=counts_channel("gyro", 1e-3))
    s = assert_same_figures(path, block_rows=BLOCK)
    assert s["data_warnings"] == ([] if moves_from or tilted else
                                  ["no motion: the sensor stayed still for the whole recording"])


def test_an_all_zero_channel_found_in_blocks(tmp_path):
    rng = np.random.default_rng(3)
    n = 3 * BLOCK + 5
    acc = rng.integers(-500, 500, (n, 3)).astype(np.int16)
    path = tmp_path / "zero_gyro.h5"
    write_recording(path, jittered_times(n, rng), acc, np.zeros((n, 3), np.int16),
                    acc_channel=counts_channel("acc", 1e-3), gyro_channel=counts_channel("gyro", 1e-3))
    s = assert_same_figures(path, block_rows=BLOCK)
    assert s["data_warnings"] == ["gyro: all zero (sensor not delivering data?)"]


def test_known_steps_and_a_gap_give_exact_figures(tmp_path):
    """A 200 Hz clock in exact 5 ms steps (µs ticks / 1e6, as a µs device clock gives) with 7 samples lost
    after sample 50 000 and a 1 ms late sample: rate, extremes and the gap are known without any reference."""
    ticks = np.arange(80_000, dtype=np.int64) * 5000
    ticks[50_000:] += 7 * 5000
    ticks[60_000] += 1000
    path = tmp_path / "known.h5"
    rng = np.random.default_rng(2)
    write_recording(path, ticks / 1e6, rng.normal(0, 1, (ticks.size, 3)) + [0, 0, 9.81],
                    rng.normal(0, 1, (ticks.size, 3)))
    for p in (path, without_summary(path)):
        s = info.summarize(p, block_rows=4096)
        # the steps are differences of float64 times below 401 s: within 2 ulp(401 s) = 1.2e-13 s of the ticks
        assert s["rate_hz"] == pytest.approx(200.0, rel=1.2e-13 / 0.005)
        assert s["dt_min_s"] == pytest.approx(0.004, abs=1.2e-13)
        assert s["dt_max_s"] == pytest.approx(0.040, abs=1.2e-13)
        assert s["gap_list"] == [{"t_s": ticks[50_000] / 1e6, "sample_index": 50_000, "missing": 7}]
        assert s["dropped"] == 7 and s["frames"] == 80_000 and s["duration_s"] == ticks[-1] / 1e6


def test_a_live_writer_s_small_appends_give_the_summary_of_the_scan(tmp_path, monkeypatch):
    """A recorder appends a few hundred rows at a time; folded every FOLD_ROWS rows (here 2500, so folds
    straddle the gaps and the block at a lower rate), its summary equals the scan, or it stores none when a
    fold's candidates may miss a gap."""
    monkeypatch.setattr(samplestats, "FOLD_ROWS", 2500)
    rng = np.random.default_rng(11)
    n = 12 * BLOCK
    for slow, expect_summary in ((1.0, True), (1.3, False)):
        dt = np.diff(jittered_times(n + 1, rng))
        dt[5 * BLOCK:8 * BLOCK] *= slow  # 3000 rows: a whole fold at the lower rate
        dt[6 * BLOCK + 500] = 1.6 * T  # a gap only by the recording's median
        dt[3 * BLOCK] = 4 * T
        t = np.r_[0.0, np.cumsum(dt)][:n]
        acc = rng.integers(-3000, 3000, (n, 3)).astype(np.int16)
        gyro = rng.integers(-3000, 3000, (n, 3)).astype(np.int16)
        path = tmp_path / f"live_{slow}.h5"
        w = RecordingWriter(path, counts_channel("acc", 1e-3), counts_channel("gyro", 1e-3))
        for a in range(0, n, 333):
            w.append(t[a:a + 333], acc[a:a + 333], gyro[a:a + 333])
            w.flush()
        w.close()
        assert_same_figures(path, summary=expect_summary)


def test_the_summary_is_used_only_for_the_rows_it_counts(tmp_path):
    """Rows changed or added after the writer closed (or a summary that does not parse): the file is scanned.
    A scale factor corrected after the writer closed (a late header) applies to the summary's figures."""
    rng = np.random.default_rng(4)
    n = 3 * BLOCK
    acc = np.tile(np.array([0, 0, 2048], np.int16), (n, 1))
    gyro = rng.integers(-2, 3, (n, 3)).astype(np.int16)
    path = tmp_path / "still.h5"
    write_recording(path, jittered_times(n, rng), acc, gyro, acc_channel=counts_channel("acc", 9.80665 / 2048),
                    gyro_channel=counts_channel("gyro", 1e-3))
    assert_same_figures(path)  # still: the no-motion warning, from the summary and from the scan
    with h5py.File(path, "r+") as f:  # 1e-3 -> 0.05 rad/s a count: the same counts now move
        f["imu/gyro"].attrs["scale_to_si"] = 0.05
    assert info.summarize(path)["data_warnings"] == []
    assert_same_figures(path)
    with h5py.File(path, "r+") as f:
        f["imu/t_s"][-1] += 1.0  # the last step is now a gap
    assert not has_summary(path)
    assert info.summarize(path)["gaps"] == 1
    assert_same_figures(path, summary=False)
    with h5py.File(path, "r+") as f:
        f["imu"].attrs["summary"] = "{not json"
    assert_same_figures(path, summary=False)
