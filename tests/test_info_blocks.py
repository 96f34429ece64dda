"""``bootnav info`` reads a recording block by block: its figures equal the whole-array computation.

The reference below computes every figure from the whole arrays of ``recording.load`` with the time-base
functions, as ``info`` did before it read in blocks. The recordings put gaps, saturation runs, non-finite
samples, a block whose own median step exceeds the recording's (so its gap candidates are incomplete) and
the first motion exactly at or across block boundaries.
"""

from __future__ import annotations

import numpy as np
import pytest

import bootnav.logger.cli_info as info
from bootnav.core.timebase import gap_mask, missing_samples, nominal_period, timing_summary
from bootnav.logger.recording import counts_channel, load, si_channel, write_recording

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


def assert_same_figures(path, **kw):
    ref = whole_array_figures(path)
    got = info.summarize(path, **kw)
    # the jitter is a std: summed in another order, it may differ in the last bits of a float64
    assert got["jitter_s"] == pytest.approx(ref.pop("jitter_s"), rel=1e-12, abs=0)
    assert {k: got[k] for k in ref} == ref
    assert got["gaps"] == len(ref["gap_list"]) and got["gap_source"] == "timestamps"
    return got


def jittered_times(n, rng, period=T):
    """Times of a 100 Hz clock quantised to µs with ±20 µs jitter."""
    return np.round((np.arange(n) * period + rng.uniform(-20e-6, 20e-6, n)) * 1e6) / 1e6


@pytest.fixture(scope="module")
def hazards(tmp_path_factory):
    """12 blocks of SI floats: gaps on and across block boundaries, one gap of 1.6 periods inside a block
    sampled at 1.2 periods (its bound 1.8 periods exceeds the recording's 1.5), saturation runs and a NaN
    row across boundaries."""
    rng = np.random.default_rng(18)
    n = 12 * BLOCK
    dt = np.diff(jittered_times(n + 1, rng))
    dt[5 * BLOCK:6 * BLOCK] = 1.2 * T  # a block at a lower rate
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
    monkeypatch.setattr(info, "MAX_DISTINCT_STEPS", 16)
    monkeypatch.setattr(info, "MAX_GAP_CANDIDATES", 0)
    assert_same_figures(hazards, block_rows=BLOCK)


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
