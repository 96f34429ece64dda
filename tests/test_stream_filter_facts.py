"""The filter facts of a run in blocks (``StreamNavigator.info``, summary.json's "filter") are the whole-array
``run_filter``'s: the stance samples the ZUPT onset delay skipped, the saturated samples given extra process noise,
the timestamp gaps (listed up to ``MAX_LISTED_GAPS``)."""

import numpy as np
import pytest

from bootnav.postproc.ins import filter as ins_filter
from bootnav.postproc.ins import stream
from bootnav.postproc.ins.settings import FilterSettings
from bootnav.postproc.pipeline import process, process_to
from bootnav.postproc.settings import ProcessSettings
from bootnav.simulator.simulate import LongSimulation
from bootnav.simulator.writers import write_long_h5

FACTS = ("zupt_onset_samples_skipped", "saturated_samples_inflated", "gaps")


def _settings(block_s=None) -> ProcessSettings:
    s = ProcessSettings()
    s.output.plots = False
    if block_s is not None:
        s.block_s = block_s
    return s


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """2 min of the long simulation: it has timestamp gaps and saturated bursts."""
    d = tmp_path_factory.mktemp("facts")
    return d, write_long_h5(LongSimulation(120.0, seed=5, block_s=30.0), d / "walk.h5")


def test_blocks_report_the_whole_array_filter_facts(walk):
    d, rec = walk
    whole = process(rec, _settings()).summary["filter"]  # run_filter over the whole arrays
    one, _ = process_to(rec, _settings(1000.0), d / "one")
    many, _ = process_to(rec, _settings(7.0), d / "many")
    assert many["navigation"]["blocks"] > 1
    # the walk exercises each of them
    assert whole["zupt_onset_samples_skipped"] > 0 and whole["saturated_samples_inflated"] > 0 and whole["gaps"]
    for key in FACTS:
        assert one["filter"][key] == many["filter"][key] == whole[key], key
    assert many["filter"]["n_gaps"] == len(whole["gaps"])


def _record(n=3000, dt=0.01, gaps=(500, 900, 1700, 2500)):
    t = np.arange(n) * dt
    for i in gaps:
        t[i:] += 3 * dt  # a step of 4 periods into sample i
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    acc[:, 0] += 0.5 * np.sin(2 * np.pi * t)  # swing-like forward acceleration
    gyr = np.zeros((n, 3))
    stance = (np.floor(t) % 2) == 0  # 1 s stance, 1 s swing
    sat = np.zeros(n, np.uint8)
    sat[1000:1010] = 0b001  # accelerometer x clipped
    sat[2200:2203] = 0b100000  # gyro z clipped
    return t, acc, gyr, stance, sat


@pytest.mark.parametrize("cap", [2, 1000])
def test_stream_facts_in_any_chunking_equal_run_filter(monkeypatch, cap):
    monkeypatch.setattr(stream, "MAX_LISTED_GAPS", cap)
    monkeypatch.setattr(ins_filter, "MAX_LISTED_GAPS", cap)
    t, acc, gyr, stance, sat = _record()
    init = type("I", (), {"q_nb": [1.0, 0, 0, 0], "gyro_bias_b": np.zeros(3)})()
    ref = ins_filter.run_filter(t, acc, gyr, stance, init, 9.81, FilterSettings(), saturated=sat).info
    assert ref["zupt_onset_samples_skipped"] > 0 and ref["saturated_samples_inflated"] == 13
    assert len(ref["gaps"]) == min(cap, 4)
    nav = stream.StreamNavigator.from_initial_state(init, 9.81, 0.01)
    for a in range(0, len(t), 137):  # chunks that cut stance phases, gaps and bursts
        b = a + 137
        nav.push(t[a:b], acc[a:b], gyr[a:b], stance[a:b], sat[a:b])
    nav.finish()
    for key in FACTS:
        assert nav.info[key] == ref[key], key
    assert nav.info["n_gaps"] == 4
