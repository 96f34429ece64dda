"""Two boots against simulated truth (the short form of benchmarks/bench_twoboots.py; seeds 0 and 1, 3 min).

What the maximum-separation bound [Skog2012] guarantees, checked on every seed:

* the two feet cannot drift apart: the fused feet's RELATIVE heading error (left − right) is smaller than the
  two single feet's, and at the checks the fused feet are never further apart than the bound;
* the walker (midpoint of the fused feet) ends closer to the truth than the worse foot alone, in position and
  in heading, on these seeds. The bound cannot tell which foot drifted, so the walker's error is about the
  mean of the two feet's: not below the better foot on every seed, and not even below the worse one always
  (benchmarks/bench_twoboots.py, seed 6 of 10 at 600 s: docs/tuning-log.md "Two boots").
"""

import numpy as np
import pytest

from bootnav.core.rotations import euler_zyx_from_quat
from bootnav.postproc.twoboots import TwoBootSettings, process_two_boots
from bootnav.simulator.twoboots import WalkerGeometry, sensor_position_n, simulate_two_boots, write_two_boots

GEO = WalkerGeometry()


def yaw_rad(q_nb):
    return np.unwrap(euler_zyx_from_quat(q_nb)[:, 2])


def horizontal_errors(est, true):
    """(final, RMS) horizontal distance between two paths taken from their own starts, m."""
    e = (est - est[0]) - (true - true[0])
    d = np.hypot(e[:, 0], e[:, 1])
    return float(d[-1]), float(np.sqrt(np.mean(d * d)))


@pytest.mark.parametrize("seed", [0, 1])
def test_the_bound_limits_relative_drift_and_the_walker_beats_the_worse_foot(seed, tmp_path):
    sims = simulate_two_boots("mixed-walk", seed=seed, duration_s=180.0, geometry=GEO)
    paths = write_two_boots(sims, tmp_path / "walk.h5")
    tb = TwoBootSettings(right_start_m=(GEO.step_length_m, -GEO.step_width_m), right_start_frame="left-sensor")
    res = process_two_boots(*paths, two_boot=tb)
    assert res.fused.n_active > 0
    origin = sensor_position_n(sims["left"])[0]
    err = {}
    for label in ("left", "right"):
        sim, single, fused = sims[label], res.single[label], getattr(res.fused, label)
        idx = np.arange(sim.n)[single.index]
        y_true = yaw_rad(sim.truth["q_nb"][idx])
        p_true = sensor_position_n(sim)[idx] - origin
        e_single = yaw_rad(single.q_nb) - y_true
        e_fused = yaw_rad(fused.q_nb) - y_true
        err[label] = {"t": fused.t_s, "yaw_single": e_single - e_single[0], "yaw_fused": e_fused - e_fused[0],
                      "pos_single": horizontal_errors(single.pos_n, p_true)[0], "p_true": p_true}
    t = err["left"]["t"]
    rel = {kind: np.interp(t, err["right"]["t"], err["right"][f"yaw_{kind}"]) - err["left"][f"yaw_{kind}"]
           for kind in ("single", "fused")}
    assert abs(rel["fused"][-1]) < abs(rel["single"][-1])
    assert np.sqrt(np.mean(rel["fused"] ** 2)) < np.sqrt(np.mean(rel["single"] ** 2))
    p_r = err["right"]["p_true"]
    walker_true = 0.5 * (err["left"]["p_true"] + np.column_stack(
        [np.interp(t, err["right"]["t"], p_r[:, j]) for j in range(3)]))
    walker_final = horizontal_errors(res.walker_pos_n, walker_true)[0]
    assert walker_final < max(err["left"]["pos_single"], err["right"]["pos_single"])
    walker_yaw = 0.5 * (err["left"]["yaw_fused"] + np.interp(t, err["right"]["t"], err["right"]["yaw_fused"]))
    assert abs(walker_yaw[-1]) < max(abs(err["left"]["yaw_single"][-1]), abs(err["right"]["yaw_single"][-1]))
