"""METRICS.md metrics on hand-made paths whose answers are known exactly."""

import numpy as np
import pytest

from bootnav.postproc.evaluate import metrics as m


def _rot(xy, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.column_stack([c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]])


def test_alignment_removes_start_offset_and_heading_but_not_scale():
    t = np.linspace(0, 10, 1001)
    truth = np.column_stack([t, 0.5 * np.sin(t), 0.1 * t])  # any path
    est_xy = _rot(truth[:, :2], 1.1) + [5.0, -3.0]
    est = np.column_stack([est_xy, truth[:, 2] + 2.0])
    r = m.trajectory_metrics(t, est, t, truth)
    assert r["mean_h_err_m"] < 1e-9 and r["armse_2d"] < 1e-9 and r["mean_v_err_m"] < 1e-9
    # A 10 % scale error is never fitted away: final error = 10 % of the final distance.
    r2 = m.trajectory_metrics(t, truth * [1.1, 1.1, 1.0], t, truth)
    assert r2["final_h_err_m"] == pytest.approx(0.1 * np.hypot(*truth[-1, :2]), rel=1e-6)


def test_armse_is_pyshoe_definition():
    t = np.arange(4.0)
    truth = np.zeros((4, 3))
    truth[:, 0] = [0, 1, 2, 3]  # heading fixed by the sample at 1 m
    est = truth.copy()
    est[2:, 1] = 0.3  # lateral error of 0.3 m on two samples
    r = m.trajectory_metrics(t, est, t, truth)
    assert r["armse_2d"] == pytest.approx(2 * np.sqrt(0.09 / 2) / 4)
    assert r["mean_h_err_m"] == pytest.approx(0.15)


def test_closed_loop_closure_and_distance():
    # Square loop of 4 m sides, stance at the corners, ends 0.2 m east and 0.1 m up of the start.
    corners = np.array([[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0], [0.2, 0, 0.1]], float)
    pos = np.repeat(corners, 10, axis=0)
    stance = np.tile(np.r_[np.ones(8), np.zeros(2)], 5).astype(bool)
    r = m.closed_loop_metrics(pos, stance)
    assert r["closure_h_m"] == pytest.approx(0.2)
    assert r["closure_v_m"] == pytest.approx(0.1)
    distance = 12 + np.hypot(0.2, 4.0)
    assert r["distance_m"] == pytest.approx(distance)
    assert r["closure_pct"] == pytest.approx(100 * np.hypot(0.2, 0.1) / distance)


def test_footprints_final_error_percent_of_truth_polyline():
    fp_t = np.array([0.0, 1.0, 2.0])
    fp_xy = np.array([[0, 0], [1, 0], [2, 0]], float)
    t = np.linspace(0, 2, 201)
    est = np.column_stack([t * 1.05, np.zeros_like(t), np.zeros_like(t)])  # 5 % long
    r = m.footprint_metrics(t, est, fp_t, fp_xy)
    assert r["final_fp_err_m"] == pytest.approx(0.1)
    assert r["final_fp_err_pct"] == pytest.approx(5.0)


def test_event_matching_is_one_to_one_nearest_first():
    truth = [1.0, 2.0, 3.0]
    detected = [1.1, 1.15, 2.3, 5.0]  # 1.1 matches 1.0; 1.15 left over; 2.3 is outside ±0.25
    r = m.step_event_metrics(detected, truth)
    assert r["precision"] == pytest.approx(1 / 4) and r["recall"] == pytest.approx(1 / 3)
    assert r["count_err_pct"] == pytest.approx(100 / 3)
    # 1.05 takes 1.0 (nearest pair first); 0.9 is then 0.3 s from 1.2, outside the tolerance.
    assert m.match_events([0.9, 1.05], [1.0, 1.2]) == [(1, 0)]
    assert sorted(m.match_events([0.9, 1.05], [1.0, 1.1])) == [(0, 1), (1, 0)]


def test_nearest_pair_wins():
    # detected 1.05 is nearest to truth 1.0 (0.05) — it must be paired with it, leaving 0.9 for nothing
    pairs = m.match_events([0.9, 1.05], [1.0])
    assert pairs == [(1, 0)]


def test_stride_lengths_out_and_back_step_lengths_stance():
    t = np.linspace(0, 10, 1001)
    pos = np.column_stack([t, np.zeros_like(t), np.zeros_like(t)])
    r = m.stride_length_metrics(t, pos, [1, 3], [2.5, 4], [1.4, 1.0])
    assert r["stride_mae_m"] == pytest.approx(0.05) and r["stride_bias_m"] == pytest.approx(0.05)
    # Out and back along x: 5 m out, 5 m back; footfalls every metre; the window starts and ends mid-stance.
    steps_t = np.arange(0, 11.0)
    x = np.minimum(steps_t, 5) - np.maximum(steps_t - 5, 0)
    t_fine = np.linspace(0, 10, 1001)
    pos_fine = np.column_stack([np.interp(t_fine, steps_t, x), np.zeros(1001), np.zeros(1001)])
    r = m.out_and_back_metrics(t_fine, pos_fine, steps_t, np.column_stack([x, 0 * x]), 0.0, 10.0, 10.0)
    assert r["distance_err_pct"] == pytest.approx(0.0)
    r = m.out_and_back_metrics(t_fine, pos_fine, steps_t, np.column_stack([x, 0 * x]), 0.5, 9.5, 9.0)
    assert r["distance_est_m"] == pytest.approx(9.0)
    r = m.step_distance_metrics([1.0, 2.0, 3.0, 9.0], [0.7, 0.7, 0.6, 5.0], 0.9, 3.1, 2.0)
    assert r["distance_est_m"] == pytest.approx(2.0) and r["distance_err_pct"] == pytest.approx(0.0)
    r = m.step_length_metrics([1.0, 2.0], [0.7, 0.8], [1.1, 2.4, 9.0], [0.6, 0.8, 1.0])
    assert r["n_matched"] == 1 and r["step_len_mae_m"] == pytest.approx(0.1)
    r = m.stance_metrics(t, t < 5, t, t < 4)
    assert r["stance_recall"] == pytest.approx(1.0)
    assert r["stance_precision"] == pytest.approx(400 / 500)


def test_out_and_back_straight_legs_leave_out_the_u_turn():
    # 10 m out along y = 0 (footfalls every metre, t = 0..10), a half circle of radius 0.5 m (t = 10..12, its
    # arc π·0.5 m is walked but not part of the 20 m course), 10 m back along y = 1 (t = 12..22)
    out_t = np.arange(0.0, 11.0)
    turn_t = np.linspace(10.0, 12.0, 9)[1:-1]
    ang = np.pi * (turn_t - 10.0) / 2.0 - np.pi / 2
    back_t = np.arange(12.0, 23.0)
    stance_t = np.concatenate([out_t, turn_t, back_t])
    xy = np.vstack([np.column_stack([out_t, 0 * out_t]),
                    np.column_stack([10.0 + 0.5 * np.cos(ang), 0.5 + 0.5 * np.sin(ang)]),
                    np.column_stack([10.0 - (back_t - 12.0), 1.0 + 0 * back_t])])
    t_fine = np.linspace(0.0, 22.0, 2201)
    pos = np.column_stack([np.interp(t_fine, stance_t, xy[:, 0]), np.interp(t_fine, stance_t, xy[:, 1]),
                           np.zeros_like(t_fine)])
    r = m.out_and_back_metrics(t_fine, pos, stance_t, xy, 0.0, 22.0, 20.0, uturn=(10.0, 12.0))
    arc = float(np.sum(np.hypot(*np.diff(xy[10:19], axis=0).T)))  # the polyline through the turn's footfalls
    assert r["distance_est_m"] == pytest.approx(20.0 + arc)
    assert r["distance_err_pct"] > 5.0  # the turn's arc counted as error
    assert r["distance_straight_est_m"] == pytest.approx(20.0) and r["distance_straight_err_pct"] == pytest.approx(0.0)
    # no U-turn times, or times outside the window: no straight-leg figure
    assert "distance_straight_err_pct" not in m.out_and_back_metrics(t_fine, pos, stance_t, xy, 0.0, 22.0, 20.0)
    assert "distance_straight_err_pct" not in m.out_and_back_metrics(t_fine, pos, stance_t, xy, 0.0, 22.0, 20.0,
                                                                      uturn=(21.0, 23.0))
