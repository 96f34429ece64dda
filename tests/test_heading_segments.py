"""The heading aid decided per segment (``building.directions.segment_flags``, ``segment_gate``,
``CausalDirections.gate_open``) and the filter's per-sample gate (``run_filter(heading_gate=…)``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.postproc.building.directions import (CausalDirections, gate_intervals, gate_of, segment_flags,
                                                  segment_gate, stride_headings)
from bootnav.postproc.ins import FilterSettings, run_filter
from bootnav.postproc.ins.prepare import gated_chunks
from tests.test_ins_synthetic import TruthInit, synthetic_walk

S = FilterSettings(heading_aid="auto")
DEG = math.pi / 180.0


def _headings(parts, rng, sigma_deg=1.5):
    """Stride headings of parts: ("leg", heading, n) straight strides scattered by sigma_deg; ("curve", start,
    n, turn per stride); ("free", n legs of 2-4 strides in random directions). Returns headings and a label
    per stride."""
    psi, lab = [], []
    for p in parts:
        if p[0] == "leg":
            psi += list(p[1] + sigma_deg * DEG * rng.standard_normal(p[2]))
            lab += [p[3] if len(p) > 3 else "grid"] * p[2]
        elif p[0] == "curve":
            psi += [p[1] + k * p[3] for k in range(p[2])]
            lab += ["curve"] * p[2]
        else:
            for _ in range(p[1]):
                h, n = rng.uniform(-math.pi, math.pi), int(rng.integers(2, 5))
                psi += list(h + sigma_deg * DEG * rng.standard_normal(n))
                lab += ["free"] * n
    return np.array(psi), np.array(lab)


def test_segments_aid_grid_legs_and_leave_45_deg_curves_and_free_walks_alone():
    rng = np.random.default_rng(4)
    axis = 0.3
    grid = [("leg", axis + m * math.pi / 2, int(rng.integers(8, 20))) for m in rng.integers(0, 4, 12)]
    parts = (grid[:6] + [("leg", axis + math.pi / 4, 10, "diag")] + grid[6:]
             + [("curve", axis, 8, 12 * DEG)] + [("free", 40)])
    psi, lab = _headings(parts, rng)
    aided, counts = segment_flags(psi, S)
    g = lab == "grid"
    assert aided[g].mean() > 0.9  # corridor legs: aided (a leg's first strides may start before its turn ends)
    assert not aided[lab == "diag"].any()  # the 45° wing
    assert not aided[lab == "curve"].any()  # a turn of 12° per stride is no straight leg
    assert aided[lab == "free"].mean() < 0.1  # a stretch walked in random directions: no grid around
    assert counts["aided"] == int(aided.sum()) and sum(counts[k] for k in
                                                       ("aided", "leg off the grid", "no grid around",
                                                        "not in a straight leg")) == len(psi)
    assert counts["leg off the grid"] >= 10 and counts["not in a straight leg"] >= 6


def test_segments_follow_a_slowly_drifting_unaided_heading():
    """The unaided path's grid turns by 0.5° per leg (gyro drift): local windows still find every corridor."""
    rng = np.random.default_rng(5)
    parts = [("leg", 0.5 * DEG * k + m * math.pi / 2, 12) for k, m in enumerate(rng.integers(0, 4, 60))]
    psi, _ = _headings(parts, rng)  # 30° of drift over the walk
    aided, _ = segment_flags(psi, S)
    assert aided.mean() > 0.85


def test_causal_gate_opens_on_grid_legs_and_closes_on_a_45_deg_leg():
    rng = np.random.default_rng(6)
    parts = [("leg", m * math.pi / 2, 12) for m in rng.integers(0, 4, 8)] + [("leg", math.pi / 4, 15, "diag")]
    psi, lab = _headings(parts, rng)
    fp = np.vstack((np.zeros(2), np.cumsum(1.3 * np.c_[np.cos(psi), np.sin(psi)], axis=0)))
    c = CausalDirections(S)
    c.push(fp[:1])
    gates = []
    for k in range(1, len(fp)):
        c.push(fp[k:k + 1])
        gates.append(c.gate_open)
    gates = np.array(gates)
    assert c.on
    assert gates[:96][lab[:96] == "grid"][24:].mean() > 0.7  # once legs are seen (3 strides into each)
    assert not gates[-12:].any()  # the 45° leg: closed
    assert sum(c.segments.values()) == len(psi)


def test_segment_gate_is_open_from_the_previous_stance_to_the_end_of_the_aided_stride():
    stance = np.zeros(30, bool)
    for a in (0, 10, 20):
        stance[a:a + 4] = True  # phases end at samples 4, 14, 24 (exclusive)
    gate = segment_gate(30, stance, np.array([1, 2]), np.array([False, True]))
    assert not gate[:14].any() and gate[14:24].all() and not gate[24:].any()


def test_gated_chunks_cut_where_the_gate_changes():
    gate = np.array([True] * 5 + [False] * 3 + [True] * 4)
    assert gated_chunks(np.array([0, 6, 12]), gate) == [(0, 5, True), (5, 6, False), (6, 8, False), (8, 12, True)]
    assert gated_chunks(np.array([0, 12]), None) == [(0, 12, True)]
    with pytest.raises(InputError):
        gated_chunks(np.array([0, 12]), gate[:5])


@pytest.mark.parametrize("engine", ["fast", "reference"])
def test_filter_gate_closed_is_the_aid_off_and_open_lets_it_correct(engine):
    """A straight walk with a gyro bias: the aid corrects its heading; a closed gate everywhere gives the
    path without the aid, bit for bit; a gate open over the second half only corrects there."""
    w = synthetic_walk(n_strides=12, gyro_noise=0.005, gyro_bias=(0.0, 0.0, 0.01), seed=2)
    init = TruthInit(w.q_nb[0], np.zeros(3))
    common = (w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity)
    base = FilterSettings(engine=engine, n_states=9)
    off = run_filter(*common, base)
    aid = replace(base, heading_aid="dominant_directions", heading_aid_reference_rad=0.0)
    closed = run_filter(*common, aid, heading_gate=np.zeros(len(w.t_s), bool))
    assert closed.info["heading_aid_updates"] == 0
    np.testing.assert_array_equal(closed.pos_n, off.pos_n)
    full = run_filter(*common, aid)
    half_gate = np.arange(len(w.t_s)) >= len(w.t_s) // 2
    half = run_filter(*common, aid, heading_gate=half_gate)
    assert 0 < half.info["heading_aid_updates"] < full.info["heading_aid_updates"]
    np.testing.assert_array_equal(half.pos_n[: len(w.t_s) // 4], off.pos_n[: len(w.t_s) // 4])
    # the aid holds the walk's straight line: the cross-track drift at the end is smaller than without it
    assert abs(full.pos_n[-1, 1]) < abs(off.pos_n[-1, 1])


def test_stride_headings_and_segments_agree_on_lengths():
    fp = np.cumsum(np.ones((20, 2)), axis=0)
    psi, ends = stride_headings(fp, S.hde_min_stride_m)
    aided, _ = segment_flags(psi, S)
    assert len(psi) == len(ends) == len(aided) == 19


def test_gate_intervals_give_segment_gate_over_any_range():
    """``gate_intervals`` (a long recording's gate, one row per run of aided strides) and ``gate_of`` over any
    sample range give ``segment_gate``'s mask."""
    rng = np.random.default_rng(3)
    stance = np.repeat(rng.random(60) < 0.5, rng.integers(1, 9, 60))
    stance[-3:] = True  # a phase open at the end stops at n
    from bootnav.core.runs import runs

    _, stops = runs(stance)
    ends = np.arange(1, len(stops))
    aided = rng.random(len(ends)) < 0.5
    whole = segment_gate(len(stance), stance, ends, aided)
    iv = gate_intervals(stops, ends, aided)
    assert np.all(iv[1:, 0] > iv[:-1, 1])  # disjoint, merged
    cuts = np.unique(np.concatenate(([0, len(stance)], rng.integers(0, len(stance), 7))))
    np.testing.assert_array_equal(np.concatenate([gate_of(iv, a, b) for a, b in zip(cuts[:-1], cuts[1:])]), whole)


@pytest.mark.parametrize("chunk", [1, 37, 100_000])
def test_stream_navigator_takes_the_gate_per_sample_as_run_filter(chunk):
    """Samples pushed with their own gate flag are filtered with it, however long they wait in the onset-delay
    queue: the path of ``run_filter(heading_gate=…)`` for every chunking (the block passes of a long recording).
    Stance phases of 0.3 s (a run) end before their onset is decided (0.45 s look-ahead): a gate set between
    pushes (``set_heading_gate``) at the phase's end would reach its onset, still queued (one aid update too
    many, 0.3 mm off, on this walk)."""
    from bootnav.postproc.ins.stream import NavRows, StreamNavigator

    w = synthetic_walk(n_strides=16, stance_s=0.3, gyro_noise=0.005, gyro_bias=(0.0, 0.0, 0.01), seed=5)
    init = TruthInit(w.q_nb[0], np.zeros(3))
    aid = FilterSettings(heading_aid="dominant_directions", heading_aid_reference_rad=0.0)
    from bootnav.core.runs import runs

    _, stops = runs(w.stance)
    ends = np.arange(1, len(stops))
    aided = (ends // 3) % 2 == 1  # three strides aided, three not, ...
    gate = segment_gate(len(w.t_s), w.stance, ends, aided)
    whole = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, aid, heading_gate=gate)
    full = run_filter(w.t_s, w.acc_b, w.gyro_b, w.stance, init, w.gravity, aid)
    assert 0 < whole.info["heading_aid_updates"] < full.info["heading_aid_updates"]  # the gate acts
    nav = StreamNavigator.from_initial_state(init, w.gravity, float(np.median(np.diff(w.t_s))), aid)
    rows = [nav.push(w.t_s[a:a + chunk], w.acc_b[a:a + chunk], w.gyro_b[a:a + chunk], w.stance[a:a + chunk],
                     heading_gate=gate[a:a + chunk]) for a in range(0, len(w.t_s), chunk)]
    r = NavRows.concatenate(rows + [nav.finish()])
    assert nav.info["heading_aid_updates"] == whole.info["heading_aid_updates"]
    assert np.abs(r.pos_n - whole.pos_n).max() <= 1e-9
