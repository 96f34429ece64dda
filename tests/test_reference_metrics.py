"""Reference metrics (paper Table 1, definitions in postproc/reference_path.py) and strides/floors on hand-made
paths whose answers are computed by hand in each test."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.postproc.reference_path import Reference, align_to_reference, compute_metrics, load_reference
from bootnav.postproc.strides import FloorSettings, count_floors, path_summary, segment_strides


def walk(footprints_xyz, stance_n=20, swing_n=20, dt=0.01, lift=0.0):
    """Samples of a foot resting ``stance_n`` samples on each footprint and swinging in a straight line
    (plus an optional vertical arc ``lift``) to the next. Returns t_s, pos_n, stance."""
    fp = np.asarray(footprints_xyz, float)
    pos, stance = [], []
    for k, p in enumerate(fp):
        pos.append(np.repeat(p[None], stance_n, axis=0))
        stance += [True] * stance_n
        if k + 1 < len(fp):
            u = (np.arange(1, swing_n + 1) / (swing_n + 1))[:, None]
            seg = p + u * (fp[k + 1] - p)
            seg[:, 2] += lift * np.sin(np.pi * u[:, 0])
            pos.append(seg)
            stance += [False] * swing_n
    pos = np.vstack(pos)
    return np.arange(len(pos)) * dt, pos, np.array(stance)


def rotate_translate(pos, yaw, offset):
    c, s = math.cos(yaw), math.sin(yaw)
    out = pos.copy()
    out[:, 0] = c * pos[:, 0] - s * pos[:, 1]
    out[:, 1] = s * pos[:, 0] + c * pos[:, 1]
    return out + offset


def test_straight_reference_distance_deviation_height_by_hand(tmp_path):
    # footprints 1 m apart along x, one footprint 0.5 m to the side, end 0.09 m higher
    fp = np.array([[x, 0.0, 0.0] for x in range(10)])
    fp[5, 1] = 0.5
    fp[-1, 2] = 0.09
    t, pos, stance = walk(fp, lift=0.1)
    # the estimate lives in an arbitrary frame: rotated 30 deg and shifted (removed by the alignment)
    pos = rotate_translate(pos, math.radians(30), np.array([5.0, -3.0, 1.0]))
    ref_file = tmp_path / "straight.json"
    ref_file.write_text(json.dumps({"straight_m": 9}))
    m = compute_metrics(load_reference(ref_file), t, pos, stance)
    l_est = 7 + 2 * math.hypot(1, 0.5)
    assert m["distance_est_m"] == pytest.approx(l_est, abs=1e-9)
    assert m["distance_ref_m"] == pytest.approx(9.0)
    assert m["distance_error_m"] == pytest.approx(l_est - 9, abs=1e-9)
    assert m["distance_error_pct"] == pytest.approx(100 * (l_est - 9) / 9, abs=1e-7)
    assert m["deviation_error_m"] == pytest.approx(0.5, abs=1e-9)
    assert m["deviation_error_pct"] == pytest.approx(100 * 0.5 / 9, abs=1e-7)
    assert m["height_error_m"] == pytest.approx(0.09, abs=1e-9)
    assert m["height_error_pct"] == pytest.approx(1.0, abs=1e-7)  # the paper's straight-row figure
    assert m["alignment_yaw_rad"] == pytest.approx(-math.radians(30), abs=1e-9)
    assert m["final_error_m"] == pytest.approx(0.0, abs=1e-9)


def test_timed_trajectory_reference_identical_path_scores_zero(tmp_path):
    fp = [[0, 0, 0], [1, 0, 0], [2, 0.5, 0], [2, 1.5, 0.3], [1, 2, 0.3]]
    t, pos, stance = walk(fp)
    ref = tmp_path / "truth.csv"
    np.savetxt(ref, np.column_stack((t, pos)), delimiter=",", header="t_s,x_m,y_m,z_m", comments="")
    est = rotate_translate(pos, 1.0, np.array([2.0, 2.0, 0.0]))
    m = compute_metrics(load_reference(ref), t, est, stance)
    for key in ("distance_error_m", "deviation_error_m", "height_error_m", "mean_h_err_m", "armse_2d",
                "mean_v_err_m", "final_h_err_m"):
        assert m[key] == pytest.approx(0.0, abs=1e-9), key


def test_timed_reference_offset_gives_known_armse(tmp_path):
    # the estimate runs 0.2 m to the left of the truth after the first 0.8 m: mean h error known by hand
    t = np.arange(0, 10, 0.01)
    truth = np.column_stack((t, np.zeros_like(t), np.zeros_like(t)))
    est = truth.copy()
    est[:, 1] = np.where(t > 2, 0.2, 0.0)  # alignment sample is at x = 0.8 (t = 0.8), before the offset
    stance = (np.arange(len(t)) // 50) % 2 == 0
    ref = tmp_path / "truth.csv"
    np.savetxt(ref, np.column_stack((t, truth)), delimiter=",", header="t_s,x_m,y_m,z_m", comments="")
    m = compute_metrics(load_reference(ref), t, est, stance)
    frac = np.mean(t > 2)
    assert m["mean_h_err_m"] == pytest.approx(0.2 * frac, abs=1e-9)
    assert m["armse_2d"] == pytest.approx(0.2 / math.sqrt(2) * frac, abs=1e-9)
    assert m["final_h_err_m"] == pytest.approx(0.2, abs=1e-9)


def test_closed_loop_closure_by_hand():
    fp = [[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0], [0.3, 0.4, 0.12]]
    t, pos, stance = walk(fp)
    m = compute_metrics(Reference("closed_loop"), t, pos, stance)
    l_est = 12 + math.hypot(0.3, 3.6)
    assert m["distance_est_m"] == pytest.approx(l_est)
    assert m["closure_h_m"] == pytest.approx(0.5)
    assert m["closure_v_m"] == pytest.approx(0.12)
    assert m["closure_3d_m"] == pytest.approx(math.sqrt(0.25 + 0.12**2))
    assert m["closure_pct"] == pytest.approx(100 * math.sqrt(0.25 + 0.12**2) / l_est)
    assert "distance_error_pct" not in m  # a loop flag has no reference length
    inline = load_reference('{"closed_loop": true, "approx_length_m": 25}')
    assert inline.kind == "closed_loop" and inline.approx_length_m == 25


def test_waypoint_csv_stairs_height_error(tmp_path):
    ref = tmp_path / "stairs.csv"
    ref.write_text("x_m,y_m,z_m\n0,0,0\n3,0,0\n3,4,2.5\n")
    fp = [[0, 0, 0], [1.5, 0, 0], [3, 0, 0], [3, 2, 1.2], [3, 4, 2.4]]
    t, pos, stance = walk(fp)
    m = compute_metrics(load_reference(ref), t, pos, stance)
    assert m["distance_ref_m"] == pytest.approx(7.0)
    assert m["distance_error_m"] == pytest.approx(0.0, abs=1e-9)
    assert m["height_error_m"] == pytest.approx(0.1, abs=1e-9)
    assert m["height_error_pct"] == pytest.approx(100 * 0.1 / 7)
    assert m["height_error_pct_of_climb"] == pytest.approx(4.0)


def test_alignment_uses_first_sample_beyond_0p8_m():
    ref = Reference("waypoints", np.array([[0, 0, 0], [0, 10, 0.0]]))  # reference goes north
    t = np.arange(5.0)
    est = np.array([[0, 0, 0], [0.5, 0, 0], [0.9, 0.1, 0], [5, 5, 0], [9, 0, 0]], float)
    aligned, _, yaw = align_to_reference(ref, t, est)
    assert yaw == pytest.approx(math.pi / 2 - math.atan2(0.1, 0.9))
    assert aligned[2, 0] == pytest.approx(0.0, abs=1e-12) and aligned[2, 1] > 0


@pytest.mark.parametrize(
    "text, message",
    [
        ("a,b\n1,2\n3,4\n", "header"),
        ("x_m,y_m\n1,2\n", "at least 2 rows"),
        ("t_s,x_m,y_m\n0,0,0\n1,1,0\n0.5,2,0\n", "line 4"),
        ("x_m,y_m\n0,0\nnan,1\n", "line 3"),
        ('{"straight_m": -1}', "straight_m"),
        ('{"foo": 1}', "closed_loop"),
        ('{"waypoints": [[0, 0]]}', "waypoints"),
        ('{"closed_loop": tru}', "invalid JSON"),
    ],
)
def test_bad_reference_files_say_what_and_where(tmp_path, text, message):
    p = tmp_path / "ref.txt"
    p.write_text(text)
    with pytest.raises(InputError, match=message):
        load_reference(p)


# ----------------------------------------------------------------------------- strides and floors
def stairs_footprints(riser=0.17, tread=0.28, steps_per_stride=2, floors_up=3, floors_down=1, risers_per_floor=18):
    """Footprints of a stair climb: each stride climbs steps_per_stride risers; a 2-stride flat landing
    after every floor; then descend. Returns footprints (K, 3) and the per-stride dz."""
    fp = [np.zeros(3)]
    heading = 0.0

    def go(dx, dz):
        p = fp[-1] + np.array([dx * math.cos(heading), dx * math.sin(heading), dz])
        fp.append(p)

    strides_per_floor = risers_per_floor // steps_per_stride
    for _ in range(floors_up):
        for _ in range(strides_per_floor):
            go(tread * steps_per_stride, riser * steps_per_stride)
        heading += math.pi  # turn on the landing (switch-back stairs)
        go(0.6, 0.0)
        go(0.6, 0.0)
    for _ in range(floors_down):
        for _ in range(strides_per_floor):
            go(tread * steps_per_stride, -riser * steps_per_stride)
        heading += math.pi
        go(0.6, 0.0)
    return np.array(fp)


def test_strides_on_known_stair_geometry():
    fp = stairs_footprints()
    t, pos, stance = walk(fp, lift=0.15)
    steps = segment_strides(t, pos, stance)
    assert len(steps["t_s"]) == len(fp) - 1
    climbing = steps["dz_m"] > 0.01
    assert np.allclose(steps["dz_m"][climbing], 2 * 0.17)
    assert np.allclose(steps["stride_length_m"][climbing], 2 * 0.28)
    assert np.allclose(steps["z_m"], fp[1:, 2])
    assert np.allclose(steps["yaw_enu_rad"][0], 0.0)
    summary = path_summary(t, pos, stance, FloorSettings(floor_height_m=3.06))
    assert summary["floors_climbed"] == 3
    assert summary["floors_descended"] == 1
    assert summary["final_floor"] == 2
    assert summary["height_max_m"] == pytest.approx(3 * 18 * 0.17)
    assert summary["distance_m"] == pytest.approx(np.hypot(*np.diff(fp[:, :2], axis=0).T).sum())


def test_floor_hysteresis_ignores_jitter_at_a_boundary():
    h = 3.0
    z = np.array([0, 1.4, 1.6, 1.45, 1.7, 1.5, 1.9, 1.3, 0.2])  # hovers around the half-storey line (1.5 m)
    assert count_floors(z, FloorSettings(h, 0.5))["floors_climbed"] == 0
    assert count_floors(z, FloorSettings(h, 0.0))["floors_climbed"] == 2  # without hysteresis: 1.6 and 1.7 count
    z = np.array([0, 2.1, 4.0, 6.1, 3.0, 0.1])
    got = count_floors(z, FloorSettings(h, 0.5))
    assert (got["floors_climbed"], got["floors_descended"], got["final_floor"]) == (2, 2, 0)
    with pytest.raises(ValueError):
        FloorSettings(3.0, 1.6)


def test_stair_gated_floors_ignore_slow_vertical_drift():
    """1000 flat strides drifting -5 mm each (-5 m: what an hour of z-bias does), with two 3 m flights of
    0.34 m stair strides in between. From the height: the drift counts as floors descended; from the stair
    strides only: exactly 2 up, 0 down."""
    dz = np.full(1000, -0.005)
    flights = np.full(9, 3.06 / 9)  # 18 risers of 0.17 m, two per stride
    z = np.cumsum(np.concatenate((dz[:300], flights, dz[300:700], flights, dz[700:])))
    z = np.concatenate(([0.0], z))
    plain = count_floors(z, FloorSettings(3.0, 0.5, stair_min_dz_m=None, storeys=False))
    gated = count_floors(z, FloorSettings(3.0, 0.5, stair_min_dz_m=0.1, storeys=False))  # the gate: storeys off
    assert (gated["floors_climbed"], gated["floors_descended"], gated["final_floor"]) == (2, 0, 2)
    assert plain["final_floor"] != 2  # the drift (-5 m) shows in the plain count
    with pytest.raises(ValueError):
        FloorSettings(3.0, 0.5, stair_min_dz_m=-0.1)


def test_footprint_csv_with_stride_column(tmp_path):
    """The datasets' truth_footprints.csv (stride,x_m,y_m,t_s): footprints at stance times; an estimate
    whose every footprint is 0.1 m north of the truth (after the first) scores that error."""
    fp = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [4, 0, 0]], float)
    t, pos, stance = walk(fp)
    phases_mid = [(k * 40 + 10) * 0.01 for k in range(len(fp))]  # mid-stance times of walk()
    ref = tmp_path / "truth_footprints.csv"
    ref.write_text("stride,x_m,y_m,t_s\n" + "".join(f"{k},{x:.3f},{y:.3f},{tk:.3f}\n"
                                                   for k, ((x, y, _), tk) in enumerate(zip(fp, phases_mid))))
    est = pos.copy()
    est[:, 1] += np.where(pos[:, 0] > 0.5, 0.1, 0.0) * (pos[:, 0] >= 1.0)  # sideways once the first stride lands
    m = compute_metrics(load_reference(ref), t, est, stance)
    assert m["reference_kind"] == "trajectory"
    # alignment sample (first >= 0.8 m) is mid-swing at x = 0.8, still on the line: no rotation
    assert m["alignment_yaw_rad"] == pytest.approx(0.0, abs=1e-12)
    assert m["mean_h_err_m"] == pytest.approx(0.1 * 4 / 5, abs=1e-9)
    assert m["final_h_err_m"] == pytest.approx(0.1, abs=1e-9)


def test_stride_length_reference_picks_the_recordings_foot(tmp_path):
    """truth_strides.csv (foot,t_start_s,t_end_s,stride_length_m) listing both feet: a left-boot
    recording is scored on the L rows only; hand-made answer: each estimated stride is 1.0 m."""
    fp = [[k * 1.0, 0, 0] for k in range(6)]
    t, pos, stance = walk(fp)  # stance phase k spans samples 40k .. 40k+19
    mid = [(40 * k + 10) * 0.01 for k in range(6)]
    rows = [f"L,{mid[k]:.3f},{mid[k + 1]:.3f},1.1" for k in range(5)]  # reference says 1.1 m
    rows += [f"R,{mid[k] + 0.2:.3f},{mid[k + 1] + 0.2:.3f},9.9" for k in range(4)]  # the other foot
    ref = tmp_path / "truth_strides.csv"
    ref.write_text("foot,t_start_s,t_end_s,stride_length_m\n" + "\n".join(rows) + "\n")
    m = compute_metrics(load_reference(ref), t, pos, stance, mount="left_boot")
    assert m["stride_foot"] == "L" and m["strides_ref"] == 5
    assert m["stride_mae_m"] == pytest.approx(0.1, abs=1e-9)
    assert m["stride_bias_m"] == pytest.approx(-0.1, abs=1e-9)
    assert m["distance_ref_m"] == pytest.approx(5.5)
    assert m["distance_error_pct"] == pytest.approx(100 * 0.5 / 5.5)
    assert compute_metrics(load_reference(ref), t, pos, stance, mount="right_boot")["stride_foot"] == "R"
