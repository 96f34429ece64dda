"""Streaming stance detection (``bootnav.postproc.detectors.stream.StreamStance``): the whole-array detector's
mask for any chunking where the detector's context is bounded, a clear refusal where it is not, and the
stream (stance -> navigator) gives ``run_filter``'s ZUPT mask and path."""

from __future__ import annotations

import numpy as np
import pytest

import bootnav
from bootnav.errors import InputError
from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.core.arrays import median_dt
from bootnav.postproc.detectors.stream import StreamStance, streamable_detectors
from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.prepare import delay_zupt_onsets
from bootnav.postproc.ins.stream import NavRows, StreamNavigator
from tests.conftest import REPO

G = 9.80665


@pytest.fixture(scope="module")
def records():
    """The bundled real x-io walk (400 Hz) and a simulated stair walk (bootnav.simulator, 200 Hz), each with
    30 samples flagged saturated (ax, gx)."""
    from bootnav.simulator.simulate import simulate

    sim = simulate("paper-stairs", seed=5)
    rec = bootnav.load(REPO / "recordings" / "xio_ngimu_short_walk.h5")
    out = {}
    for name, (t, acc, gyr) in {"xio-real": (rec.t_s, rec.acc_mps2, rec.gyro_radps),
                                "sim-stairs": (sim.t_s, sim.acc_mps2, sim.gyro_radps)}.items():
        sat = np.zeros(len(t), np.uint8)
        sat[len(t) // 2:len(t) // 2 + 30] = 0b001001
        out[name] = (np.asarray(t, float), np.asarray(acc, float), np.asarray(gyr, float), sat)
    return out


def _stream(ss, t, acc, gyr, sat, sizes):
    chunks, i = [], 0
    while i < t.shape[0]:
        c = sizes if isinstance(sizes, int) else next(sizes)
        chunks += ss.push(t[i:i + c], acc[i:i + c], gyr[i:i + c], sat[i:i + c])
        i += c
    chunks += ss.finish()
    assert chunks[0].start == 0 and all(a.start + len(a) == b.start for a, b in zip(chunks[:-1], chunks[1:]))
    return chunks


def _sizes(seed):
    rng = np.random.default_rng(seed)
    while True:
        yield int(rng.integers(1, 300))


CASES = [
    ("shoe", {}),
    ("shoe", dict(min_swing_s=0.1, min_stance_s=0.05, literal_paper_form=True, threshold=1e3)),
    ("ared", {}),
    ("mv", {}),
    ("mag", dict(min_stance_s=0.03, threshold=3e3)),
    ("shoe-literal", dict(threshold=1e3)),  # the paper's printed form with a fixed threshold
    ("adaptive", {}),  # with the whole record's noise floor given
    ("adaptive", dict(average_s=0.01)),  # the statistic of 10 ms moving means: one more half-mean of context
]


@pytest.mark.parametrize("data", ["xio-real", "sim-stairs"])
@pytest.mark.parametrize("method,extra", CASES, ids=[f"{m}-{i}" for i, (m, _) in enumerate(CASES)])
def test_stream_equals_whole_array(records, data, method, extra):
    """Chunks of 7, 1000, random 1-299 and the whole record (and single samples for SHOE on the shorter
    record) give exactly the whole-array mask (same sample period, no clipping search)."""
    t, acc, gyr, sat = records[data]
    ds = DetectorSettings(method, extra, detect_clipping=False)
    ref = detect_stance(t, acc, gyr, ds, G, saturated=sat)
    assert 0.3 < ref.stance.mean() < 0.9 and not ref.stance[len(t) // 2:len(t) // 2 + 30].any()
    chunkings = [7, 1000, _sizes(2), t.shape[0]]
    if data == "sim-stairs" and method == "shoe" and not extra:
        chunkings.append(1)
    for sizes in chunkings:
        ss = StreamStance(ds, 1.0 / median_dt(t), G, noise_floor_log10=ref.info.get("noise_floor_log10"))
        chunks = _stream(ss, t, acc, gyr, sat, sizes)
        stance = np.concatenate([c.stance for c in chunks])
        assert np.array_equal(stance, ref.stance)
        assert np.array_equal(np.concatenate([c.saturated for c in chunks]), sat)
        assert np.array_equal(np.concatenate([c.t_s for c in chunks]), t)


def test_decisions_come_one_radius_after_the_sample(records):
    """Latency and memory: a decision comes ``radius`` samples after its sample (the context the detector
    needs: 1.4 s for the adaptive detector's 1.5 s valley/peak span, 0.05 s for SHOE at 400 Hz), and the
    buffer never holds more than one radius + the look-back history (a radius and span_s) + one chunk."""
    t, acc, gyr, sat = records["xio-real"]
    rate = 1.0 / median_dt(t)
    for method, most_s in (("adaptive", 1.5), ("shoe", 0.06)):
        ss = StreamStance(DetectorSettings(method=method), rate, G)
        assert ss.lookahead_s <= most_s
        decided = 0
        for i in range(0, 4000, 50):
            decided += sum(len(c) for c in ss.push(t[i:i + 50], acc[i:i + 50], gyr[i:i + 50]))
            assert decided == max(0, i + 50 - ss.radius)
            assert len(ss._t) <= ss.radius + ss._history + 50  # + the look-back of the isolated-run rule


def test_running_noise_floor_is_close(records):
    """Without a given floor the adaptive detector's floor comes from the samples decided so far: the mask
    differs from the whole-array one on at most 1 % of the samples (it decides only long rests)."""
    t, acc, gyr, sat = records["xio-real"]
    ds = DetectorSettings(detect_clipping=False)
    ref = detect_stance(t, acc, gyr, ds, G, saturated=sat)
    chunks = _stream(StreamStance(ds, 1.0 / median_dt(t), G), t, acc, gyr, sat, 100)
    diff = np.count_nonzero(np.concatenate([c.stance for c in chunks]) != ref.stance)
    assert diff <= 0.01 * t.shape[0]
    ss = StreamStance(ds, 1.0 / median_dt(t), G)
    assert ss.noise_floor_log10 is None
    _stream(ss, t, acc, gyr, sat, t.shape[0])  # one chunk: the whole record's quantile, to the bin width
    assert abs(ss.noise_floor_log10 - ref.info["noise_floor_log10"]) < 2e-3


@pytest.mark.parametrize("method,extra,why", [
    ("xio", {}, "whole record"),
    ("paper_accmag", {}, "whole record"),
    ("shoe-literal", {}, "fixed threshold"),
    ("shoe", dict(hysteresis_ratio=3.0), "hysteresis"),
])
def test_whole_record_detectors_are_refused(method, extra, why):
    with pytest.raises(InputError, match=f"'{method}' cannot run on a stream: .*{why}.*choose one of"):
        StreamStance(DetectorSettings(method, extra), 200.0)
    assert set(streamable_detectors()) == {"adaptive", "ared", "mag", "mv", "shoe"}


@pytest.mark.parametrize("data", ["xio-real", "sim-stairs"])
def test_stance_stream_into_navigator_equals_run_filter(records, data):
    """Detector stream -> navigator stream: the navigator applies the ZUPT onset delay to the streamed mask
    exactly as run_filter does, and the path is run_filter's on the whole-array mask."""
    t, acc, gyr, sat = records[data]
    ds = DetectorSettings(detect_clipping=False)
    ref = detect_stance(t, acc, gyr, ds, G, saturated=sat)
    rate = 1.0 / median_dt(t)

    from bootnav.postproc.calibration import initial_alignment

    init = initial_alignment(t, acc, gyr, gravity=G)
    fs = FilterSettings()
    nav = StreamNavigator.from_initial_state(init, G, median_dt(t), fs)
    ss = StreamStance(ds, rate, G, noise_floor_log10=ref.info["noise_floor_log10"])
    parts = []
    for i in range(0, t.shape[0], 37):
        for c in ss.push(t[i:i + 37], acc[i:i + 37], gyr[i:i + 37], sat[i:i + 37]):
            parts.append(nav.push(c.t_s, c.acc_b, c.gyro_b, c.stance, c.saturated))
    parts += [nav.push(c.t_s, c.acc_b, c.gyro_b, c.stance, c.saturated) for c in ss.finish()] + [nav.finish()]
    rows = NavRows.concatenate(parts)
    zupt = delay_zupt_onsets(t, ref.stance, fs.zupt_onset_delay_s, fs.zupt_onset_max_fraction)
    assert np.array_equal(rows.zupt, zupt) and (ref.stance & ~zupt).sum() > 50  # the delay did cut onsets
    sol = run_filter(t, acc, gyr, ref.stance, init, G, fs, saturated=sat)
    assert np.abs(rows.pos_n - sol.pos_n).max() <= 1e-9
    assert np.abs(rows.q_nb - sol.q_nb).max() <= 1e-12
