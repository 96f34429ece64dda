"""Two boots against simulated truth: what the maximum-separation bound [Skog2012] observes and what it cannot
(docs/twoboots.md).

The bound is a function of p_L − p_R only: it observes the DIFFERENCE of the two feet's errors, never their
common mode. Checked exactly with ideal sensors and a known yaw error put into both feet's initial attitude:

* the same error in both feet (common mode): the bound never bites, and the walker ends exactly as far off as
  the rotated feet alone (2 sin(δ/2) × the distance walked);
* opposite errors (differential mode, common mode zero): the bound removes them: the walker ends on the
  truth and each foot's heading error shrinks.

With the MPU6050 model (seeds 0 and 1, 3 min; the short form of benchmarks/bench_twoboots.py), the guarantees:
the fused feet's relative error at every check is at most γ + the true separation (the single feet's grows
without bound), their relative heading error is smaller than the single feet's, and the walker ends closer to
the truth than the worse foot on these seeds (not a guarantee: on 1 of 10 seeds × 600 s it ends behind both
feet in position, docs/twoboots.md).
"""

import math

import numpy as np
import pytest

from bootnav.core.rotations import euler_zyx_from_quat
from bootnav.postproc.pipeline import process
from bootnav.postproc.twoboots import TwoBootSettings, process_two_boots
from bootnav.postproc.ins.prepare import delay_zupt_onsets
from bootnav.postproc.twoboots.fusion import constraint_instants, fuse
from bootnav.postproc.twoboots.run import foot_input
from bootnav.simulator import custom
from bootnav.simulator.twoboots import (WalkerGeometry, max_separation_m, sensor_position_n, simulate_two_boots,
                                        write_two_boots)

# issue 27: a numerical fault (e.g. a sign error in the constraint) must fail within minutes, not hang for the
# suite's 10-minute default; the slowest test here takes about 20 s on a loaded 2-core machine
pytestmark = pytest.mark.timeout(120)

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
    # the relative error r = (p̂_L − p̂_R) − (p_L − p_R) at every check: after the update ‖p̂_L − p̂_R‖ ≤ γ, and
    # ‖p_L − p_R‖ ≤ the walker's true largest separation, so ‖r‖ ≤ γ + that (the smoother moves a resting
    # foot's position afterwards by its stance-phase σ, a few cm: 0.05 m slack)
    fs = res.settings.filter
    feet = {label: getattr(res.fused, label) for label in ("left", "right")}
    zupt = {label: delay_zupt_onsets(f.t_s, f.stance, fs.zupt_onset_delay_s, fs.zupt_onset_max_fraction)
            for label, f in feet.items()}
    instants = constraint_instants(feet["left"].t_s, zupt["left"], feet["right"].t_s, zupt["right"], res.two_boot)
    assert len(instants) > 100

    def at(label, pos):
        return np.column_stack([np.interp(instants, feet[label].t_s, pos[:, j]) for j in range(3)])

    # the fused frame is the truth's (start posture known), so r is the estimated minus the true separation
    r = np.linalg.norm((at("left", feet["left"].pos_n) - at("right", feet["right"].pos_n))
                       - (at("left", err["left"]["p_true"]) - at("right", p_r)), axis=1)
    bound = res.two_boot.max_separation_m + max_separation_m(sims) + 0.05
    assert r.max() <= bound


OUT = custom("out", lambda pb: pb.stand(5).walk(30).stand(5))  # 30 m straight, both feet
DELTA = math.radians(3.0)


@pytest.fixture(scope="module")
def ideal_walk(tmp_path_factory):
    """Both feet of a 30 m straight walk with ideal sensors, each processed alone (their paths are exact to
    about 1 cm)."""
    sims = simulate_two_boots(OUT, seed=1, profile="ideal", geometry=GEO)
    files = write_two_boots(sims, tmp_path_factory.mktemp("ideal") / "w.h5")
    return sims, {label: process(p) for label, p in zip(("left", "right"), files)}


def fused_errors(ideal_walk, yaw_left, yaw_right, gate_sigma=0.0):
    """Fuse the feet with these initial yaw errors (both with the same 2° σ: a symmetric fusion); final
    horizontal error (2,) and yaw error (rad) of each fused foot and of the walker, and the update count."""
    sims, single = ideal_walk
    start = np.array([GEO.step_length_m, -GEO.step_width_m, 0.0])
    sigma = math.radians(2.0)
    out = fuse(foot_input("left", single["left"], 0.0, yaw_left, None, sigma),
               foot_input("right", single["right"], 0.0, yaw_right, start, sigma),
               single["left"].settings.filter, TwoBootSettings(constraint_gate_sigma=gate_sigma))
    origin = sensor_position_n(sims["left"])[0]
    errs = {}
    for label, f in (("left", out.left), ("right", out.right)):
        idx = np.arange(sims[label].n)[single[label].index]
        p_true = sensor_position_n(sims[label])[idx] - origin
        e = (f.pos_n[-1] - f.pos_n[0]) - (p_true[-1] - p_true[0])
        yaw_err = yaw_rad(f.q_nb) - yaw_rad(sims[label].truth["q_nb"][idx])
        errs[label] = (e[:2], float(yaw_err[-1]))
    walker = (0.5 * (errs["left"][0] + errs["right"][0]), 0.5 * (errs["left"][1] + errs["right"][1]))
    return errs, walker, out.n_active


def test_the_common_mode_is_unobservable(ideal_walk):
    """Both feet turned by δ: every separation is what it was, up to δ × the 0.7 m start offset, so the bound
    never bites and the walker ends where the turned feet end: 2 sin(δ/2) × 30 m = 1.57 m off (ideal sensors:
    the paths alone are exact to 0.02 m)."""
    errs, walker, n_active = fused_errors(ideal_walk, DELTA, DELTA)
    assert n_active == 0
    assert np.linalg.norm(walker[0]) == pytest.approx(2 * math.sin(DELTA / 2) * 30.0, abs=0.02)
    assert walker[1] == pytest.approx(DELTA, abs=math.radians(0.1))


def test_the_difference_mode_is_removed(ideal_walk):
    """Left turned by +δ, right by −δ: the common mode is zero. Alone, the feet would end 2 × 1.57 m apart
    sideways; the bound bites, and a symmetric fusion (equal yaw σ) removes the difference without creating a
    common error: the walker ends within a tenth of the single feet's error of the truth, in position and
    heading, and each fused foot's heading error is under half of δ."""
    errs, walker, n_active = fused_errors(ideal_walk, DELTA, -DELTA)
    assert n_active > 10
    assert np.linalg.norm(walker[0]) < 0.1 * 2 * math.sin(DELTA / 2) * 30.0
    assert abs(walker[1]) < 0.1 * DELTA
    for label in ("left", "right"):
        assert abs(errs[label][1]) < 0.5 * DELTA
    # the feet's relative error at the end (both resting): at most γ + their true distance (0.72 m)
    sims, _ = ideal_walk
    assert np.linalg.norm(errs["left"][0] - errs["right"][0]) <= TwoBootSettings().max_separation_m + \
        max_separation_m(sims)


def test_a_large_difference_leaks_into_the_common_mode_unless_gated(ideal_walk):
    """±20°: the feet are metres apart before the bound bites, far outside their covariances, and the hard
    projection through the linearised covariances turns part of the excess into a COMMON heading error (the
    mechanism behind the stair-flight outliers of docs/twoboots.md). With the 3-σ consistency gate the walker
    keeps the common mode (zero) better, at the price of feet left apart."""
    delta = math.radians(20.0)
    hard = fused_errors(ideal_walk, delta, -delta)
    gated = fused_errors(ideal_walk, delta, -delta, gate_sigma=3.0)
    assert abs(hard[1][1]) > math.radians(1.0)
    assert abs(gated[1][1]) < 0.5 * abs(hard[1][1])
    assert abs(gated[0]["left"][1] - gated[0]["right"][1]) > abs(hard[0]["left"][1] - hard[0]["right"][1])


def test_the_gate_makes_the_excess_consistent():
    """R of a gated violation puts the excess exactly at g standard deviations of the separation."""
    from bootnav.postproc.twoboots.constraint import separation_variance_m2

    s, sigma = 0.02, 0.01
    assert separation_variance_m2(0.2, s, sigma, 0.0) == sigma ** 2  # no gate
    assert separation_variance_m2(0.3 * math.sqrt(s + sigma ** 2), s, sigma, 3.0) == sigma ** 2  # consistent
    e = 0.8
    r = separation_variance_m2(e, s, sigma, 3.0)
    assert e / math.sqrt(s + r) == pytest.approx(3.0, rel=1e-12)
