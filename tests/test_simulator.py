"""Simulator truth and synthesis: strapdown closure, exact stance, stairs geometry, files, CLI."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bootnav.core.rotations import dcm_from_euler_zyx, quat_multiply
from bootnav.logger.crc import crc16_ccitt_false
from bootnav.logger.mpu6050 import INT16_MAX, INT16_MIN, STANDARD_GRAVITY
from bootnav.logger.recording import load
from bootnav.simulator import PROFILES, custom, simulate, write_h5, write_sd_txt
from bootnav.simulator.imu_model import quantize
from bootnav.simulator.scenarios import PAPER_STAIRS, SCENARIOS, THREE_FLOORS
from tests.conftest import REPO, reopen_in_fresh_process, sha

G = STANDARD_GRAVITY


# --------------------------------------------------------------------------- independent strapdown (RK4)
@numba.njit(cache=True)
def _qmul(a, b):
    return np.array([a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
                     a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
                     a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
                     a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]])


@numba.njit(cache=True)
def _deriv(q, w, f, g):
    """q' = q (x) [0, w] / 2,  v' = q (x) f (x) q* + g_n,  g_n = [0, 0, -g]."""
    dq = 0.5 * _qmul(q, np.array([0.0, w[0], w[1], w[2]]))
    qc = np.array([q[0], -q[1], -q[2], -q[3]])
    dv = _qmul(_qmul(q, np.array([0.0, f[0], f[1], f[2]])), qc)[1:]
    dv[2] -= g
    return dq, dv


@numba.njit(cache=True)
def strapdown_rk4(acc, gyro, h, q0, v0, p0, g):
    """Classical RK4 over steps of 2 samples: the odd sample is the exact mid-point input."""
    m = (acc.shape[0] - 1) // 2
    Q, V, P = np.empty((m + 1, 4)), np.empty((m + 1, 3)), np.empty((m + 1, 3))
    q, v, p = q0.copy(), v0.copy(), p0.copy()
    Q[0], V[0], P[0] = q, v, p
    for k in range(m):
        i = 2 * k
        dq1, dv1 = _deriv(q, gyro[i], acc[i], g)
        dq2, dv2 = _deriv(q + 0.5 * h * dq1, gyro[i + 1], acc[i + 1], g)
        v2 = v + 0.5 * h * dv1
        dq3, dv3 = _deriv(q + 0.5 * h * dq2, gyro[i + 1], acc[i + 1], g)
        v3 = v + 0.5 * h * dv2
        dq4, dv4 = _deriv(q + h * dq3, gyro[i + 2], acc[i + 2], g)
        v4 = v + h * dv3
        p = p + h / 6 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + h / 6 * (dv1 + 2 * dv2 + 2 * dv3 + dv4)
        q = q + h / 6 * (dq1 + 2 * dq2 + 2 * dq3 + dq4)
        q = q / np.sqrt(np.sum(q * q))
        Q[k + 1], V[k + 1], P[k + 1] = q, v, p
    return Q, V, P


LOOP_100M = custom("loop-100m", lambda pb: pb.stand(2.0).walk_to(30, 0).walk_to(30, 20).walk_to(0, 20)
                   .walk_to(0, 0).stand(2.0), "30 m x 20 m walking loop, 100 m")


def test_noise_free_strapdown_reproduces_truth_over_100m(tmp_path):
    # 4 kHz: RK4 (4th order) error on these C3 trajectories is ~0.2 mm over 100 m; the test reads the
    # recording back from the HDF5 file, so the stored samples are what is integrated.
    res = simulate(LOOP_100M, profile="ideal", rate_hz=4000.0, mount="right_boot_tilted")
    path = write_h5(res, tmp_path / "loop.h5")
    rec = load(path)
    tr = rec.truth
    assert float(np.sum(tr["step_length_m"])) == pytest.approx(100.0, abs=1e-9)
    h = 2.0 / 4000.0
    assert np.allclose(np.diff(rec.t_s), 1 / 4000.0, atol=1e-12)
    args = (tr["q_nb"][0], tr["vel_n_mps"][0], tr["pos_n_m"][0], G)
    Q, V, P = strapdown_rk4(rec.acc_mps2, rec.gyro_radps, h, *args)
    ref = slice(None, 2 * (len(P) - 1) + 1, 2)
    pos_err = np.linalg.norm(P - tr["pos_n_m"][ref], axis=1)
    dq = quat_multiply(Q * np.array([1, -1, -1, -1]), tr["q_nb"][ref])
    att_err = 2 * np.linalg.norm(dq[:, 1:], axis=1)
    print(f"\nstrapdown over 100 m at 4 kHz: max position error {pos_err.max() * 1e3:.3f} mm, "
          f"attitude {att_err.max():.2e} rad")
    assert pos_err.max() < 1e-3, f"max position error {pos_err.max() * 1e3:.3f} mm over 100 m"
    assert att_err.max() < 1e-6
    assert np.abs(V - tr["vel_n_mps"][ref]).max() < 1e-4
    # the check can fail: a gyro bias of 1e-4 rad/s (21 deg/h) breaks the 1 mm closure by far
    _, _, Pb = strapdown_rk4(rec.acc_mps2, rec.gyro_radps + 1e-4, h, *args)
    assert np.linalg.norm(Pb[-1] - tr["pos_n_m"][ref][-1]) > 1e-2


def test_truth_is_self_consistent_by_finite_differences():
    res = simulate("running", profile="ideal", rate_hz=2000.0, duration_s=12.0, mount="right_boot_side")
    tr, t = res.truth, res.truth["t_s"]
    v_fd = np.gradient(tr["pos_n_m"], t, axis=0)
    assert np.abs(v_fd - tr["vel_n_mps"])[2:-2].max() < 2e-3  # O(h^2 * jerk)
    q = tr["q_nb"]
    w_fd = 2 * quat_multiply(q * np.array([1, -1, -1, -1]), np.gradient(q, t, axis=0))[:, 1:]
    assert np.abs(w_fd - tr["omega_b_radps"])[2:-2].max() < 5e-3
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)


def test_stance_is_exactly_still_and_reads_gravity():
    res = simulate("paper-stairs", profile="ideal", rate_hz=200.0)
    tr = res.truth
    st = tr["stance"] == 1
    assert 0.3 < st.mean() < 0.9
    assert np.all(tr["vel_n_mps"][st] == 0.0)
    assert np.all(tr["omega_b_radps"][st] == 0.0)
    # at rest the specific force is +g along the nav up axis: R_nb f_b = [0, 0, g]
    q = tr["q_nb"][st]
    f = np.concatenate([np.zeros((q.shape[0], 1)), tr["f_b_mps2"][st]], axis=1)
    f_n = quat_multiply(quat_multiply(q, f), q * np.array([1, -1, -1, -1]))[:, 1:]
    assert np.allclose(f_n, [0.0, 0.0, G], atol=1e-12)
    # every stride starts and ends in stance
    for t0, t1 in zip(res.steps["t_start_s"], res.steps["t_end_s"]):
        i0 = np.searchsorted(tr["t_s"], t0) - 1
        i1 = np.searchsorted(tr["t_s"], t1, side="right")
        assert st[i0] and st[min(i1, len(st) - 1)]
        assert not st[(i0 + i1) // 2]


def test_stairs_truth_total_climb_equals_risers_times_count():
    g = THREE_FLOORS
    res = simulate("three-floors", profile="ideal", rate_hz=100.0)
    tr = res.truth
    n_risers = g["floors"] * 2 * g["risers_per_flight"]
    riser = g["floor_height_m"] / (2 * g["risers_per_flight"])
    climb = tr["foot_pos_n_m"][-1, 2] - tr["foot_pos_n_m"][0, 2]
    assert climb == pytest.approx(n_risers * riser, abs=1e-9)
    assert tr["pos_n_m"][-1, 2] == pytest.approx(n_risers * riser, abs=1e-9)
    assert np.sum(res.steps["dz_m"]) == pytest.approx(9.0, abs=1e-9)
    # the foot stands on a tread: stance heights are whole multiples of the riser
    z = tr["foot_pos_n_m"][tr["stance"] == 1, 2]
    assert np.allclose(z / riser, np.round(z / riser), atol=1e-9)
    ps = simulate("paper-stairs", profile="ideal", rate_hz=100.0)
    assert ps.truth["pos_n_m"][-1, 2] == pytest.approx(PAPER_STAIRS["n_risers"] * PAPER_STAIRS["riser_m"], abs=1e-9)
    assert np.sum(ps.steps["length_m"]) == pytest.approx(11.0, abs=1e-9)
    # the swing clears the step edges: the foot origin never dips below the floor it leaves or lands on
    assert tr["foot_pos_n_m"][:, 2].min() >= -1e-9


def test_rectangle_closes_and_straight_walk_is_9m():
    rect = simulate("rectangle", profile="ideal", rate_hz=100.0)
    assert np.allclose(rect.truth["foot_pos_n_m"][-1], 0.0, atol=1e-9)
    assert np.sum(rect.steps["length_m"]) == pytest.approx(32.0, abs=1e-9)
    st = simulate("paper-straight", profile="ideal", rate_hz=100.0)
    assert np.allclose(st.truth["foot_pos_n_m"][-1], [9.0, 0.0, 0.0], atol=1e-9)
    still = st.truth["t_s"] < 10.0
    assert np.all(st.truth["stance"][still] == 1)  # 10 s still at the start


def test_quantisation_and_saturation_are_exact():
    lsb = PROFILES["mpu6050-2g-250dps"].accel_lsb_mps2
    assert lsb == pytest.approx(G / 16384.0)
    x = np.array([32766.4, 32766.6, 32767.0, 1e9, -32767.4, -32767.6, -32768.0, -1e9, 0.49, 0.51]) * lsb
    counts, sat = quantize(x, lsb)
    assert counts.tolist() == [32766, 32767, 32767, 32767, -32767, -32768, -32768, -32768, 0, 1]
    assert sat.tolist() == [False, True, True, True, False, True, True, True, False, False]
    # end to end: a noise-free quantising +-2 g / +-250 deg/s sensor on a walk saturates exactly where
    # the true signal is beyond full scale, and every other sample is within half an LSB of the truth
    prof = replace(PROFILES["mpu6050-noise-only"], name="quantise-only", accel_range_g=2, gyro_range_dps=250,
                   dlpf_cfg=None, accel_noise_ug_rthz=0.0, gyro_noise_dps_rthz=0.0, accel_bias_rw_mps2_rts=0.0,
                   gyro_bias_rw_dps_rts=0.0)
    res = simulate("paper-straight", profile=prof, rate_hz=200.0)
    for name, raw, true, step, bit0 in (("acc", res.acc, res.truth["f_b_mps2"], prof.accel_lsb_mps2, 0),
                                        ("gyro", res.gyro, res.truth["omega_b_radps"], prof.gyro_lsb_radps, 3)):
        exp = np.clip(np.rint(true / step), INT16_MIN, INT16_MAX)
        assert np.array_equal(raw, exp), name
        beyond = (true / step >= INT16_MAX - 0.5) | (true / step < INT16_MIN + 0.5)  # rounds to the limit
        flags = np.stack([(res.saturated >> (bit0 + a)) & 1 for a in range(3)], axis=1) == 1
        assert np.array_equal(flags, beyond), name
        assert flags.any(), f"{name}: a walk must exceed the smallest range"
        si = raw * step
        ok = ~flags
        assert np.abs(si[ok] - true[ok]).max() <= step / 2 + 1e-12
        # quantisation steps: every SI difference is a whole number of LSB
        d = np.diff(si[:, 2]) / step
        assert np.allclose(d, np.round(d), atol=1e-9)
        steps = np.round(np.diff(si, axis=0) / step).astype(np.int64)
        assert np.gcd.reduce(np.abs(steps[steps != 0])) == 1  # the grid is 1 LSB, not a multiple
    n_events = int(np.sum(res.events["kind"] == b"saturation"))
    assert n_events > 0 and np.sum(res.events["count"][res.events["kind"] == b"saturation"]) == sum(
        res.saturation_counts().values())


def test_saturation_counts_grow_as_the_range_shrinks():
    counts = {}
    for name in ("mpu6050-16g-2000dps", "mpu6050-2g-250dps"):
        counts[name] = sum(simulate("running", seed=1, profile=name, duration_s=15.0).saturation_counts().values())
    assert counts["mpu6050-2g-250dps"] > 100 * max(1, counts["mpu6050-16g-2000dps"])


def test_h5_recording_reopens_in_fresh_process(tmp_path):
    res = simulate("three-floors", seed=7)
    path = write_h5(res, tmp_path / "three.h5")
    summary = reopen_in_fresh_process(path)
    assert summary["n"] == res.n
    assert summary["acc_raw"] == sha(res.acc) and summary["gyro_raw"] == sha(res.gyro)
    assert summary["meta"]["mount"] == "right_boot"
    rec = load(path)
    assert rec.raw["acc"].dtype == np.int16
    assert rec.raw["acc_attrs"]["scale_to_si"] == pytest.approx(PROFILES["mpu6050-16g-2000dps"].accel_lsb_mps2)
    for key in ("t_s", "pos_n_m", "vel_n_mps", "q_nb", "stance", "step_t_s", "step_length_m", "step_dz_m",
                "step_heading_rad"):
        assert key in rec.truth and len(rec.truth[key]) > 0, key
    assert len(rec.truth["t_s"]) == rec.n
    assert np.allclose(rec.truth["pos_n_m"][0], 0.0)
    assert rec.truth["attrs"]["scenario"] == "three-floors" and rec.truth["attrs"]["seed"] == 7
    assert "accel_noise_ug_rthz" in rec.truth["attrs"]["sensor_profile"]
    gaps = rec.events_of("gap")
    assert int(np.sum(gaps["count"])) == rec.truth["attrs"]["n_dropped"]
    # bootnav emulate streams exactly these counts at the nominal rate
    from bootnav.logger.emulator import load_source

    src = load_source(path)
    assert np.array_equal(src.acc, res.acc) and np.array_equal(src.gyro, res.gyro) and src.rate_hz == 200.0
    assert (src.accel_fs, src.gyro_fs) == (3, 3)


def test_sd_text_parses_with_correct_crc(tmp_path):
    res = simulate("paper-straight", seed=2)
    path = write_sd_txt(res, tmp_path / "walk.txt")
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# bootnav-sd v1 accel_fs=3 gyro_fs=3 dlpf=3 smplrt_div=4 ")
    data = lines[1:]
    assert len(data) == res.n
    rows = []
    for ln in data:
        body, star, crc = ln.partition("*")
        assert star and len(crc) == 4 and crc == crc.upper()
        assert int(crc, 16) == crc16_ccitt_false(body.encode("ascii"))
        rows.append([int(v) for v in body.split(",")])
    rows = np.array(rows)
    assert np.array_equal(rows[:, 0], res.t_device) and np.array_equal(rows[:, 1], res.seq)
    assert np.array_equal(rows[:, 2:5], res.acc) and np.array_equal(rows[:, 5:8], res.gyro)
    # the project's own SD-card importer reads it back bit-exact, without a single CRC error
    from bootnav.logger.importers.core import read_any

    imp = read_any(path)
    assert imp.count("crc_error") == 0 and imp.count("skipped_line") == 0
    assert np.array_equal(imp.acc, res.acc) and np.array_equal(imp.gyro, res.gyro)
    with pytest.raises(Exception, match="int16 counts"):
        write_sd_txt(simulate("paper-straight", profile="ideal"), tmp_path / "ideal.txt")


def test_same_seed_same_recording_other_seed_differs():
    a = simulate("paper-stairs", seed=5)
    b = simulate("paper-stairs", seed=5)
    c = simulate("paper-stairs", seed=6)
    assert np.array_equal(a.acc, b.acc) and np.array_equal(a.t_s, b.t_s)
    assert not np.array_equal(a.acc, c.acc)
    assert np.array_equal(a.truth["pos_n_m"], c.truth["pos_n_m"])  # fixed geometry, only the sensor differs


def test_long_scenario_generates_fast():
    import time

    t0 = time.perf_counter()
    res = simulate("long", duration_s=600.0)
    dt = time.perf_counter() - t0
    print(f"\nlong 600 s at 200 Hz: {res.n} samples in {dt:.2f} s ({res.n / dt / 1e3:.0f} k samples/s)")
    assert res.truth["t_s"][-1] >= 590.0
    assert dt < 30.0  # ~2 s on one core; generous for a shared CI machine


def test_cli_lists_scenarios_and_writes_files(tmp_path):
    run = lambda *a: subprocess.run([sys.executable, "-m", "bootnav", "simulate", *a], cwd=REPO,  # noqa: E731
                                    capture_output=True, text=True, timeout=120)
    out = run("--list")
    assert out.returncode == 0
    listed = [ln.split()[0] for ln in out.stdout.splitlines() if ln.startswith("  ")]
    for name in SCENARIOS:
        assert name in listed
    p = run("--scenario", "paper-stairs", "--seed", "3", "--sensor-profile", "mpu6050-8g-1000dps", "--rate", "100",
            "--out", str(tmp_path / "s.h5"))
    assert p.returncode == 0, p.stderr
    rec = load(tmp_path / "s.h5")
    assert rec.meta["accel_range_g"] == 8 and rec.meta["smplrt_div"] == 9
    assert rec.rate_hz == pytest.approx(100.0, rel=5e-3)
    bad = run("--scenario", "nowhere", "--out", str(tmp_path / "x.h5"))
    # an option's bad value is a usage error: exit 2, as argparse gives for its own (issue 26)
    assert bad.returncode == 2 and "unknown scenario 'nowhere'" in bad.stderr
    bad = run("--scenario", "paper-straight", "--duration", "100", "--out", str(tmp_path / "x.h5"))
    assert bad.returncode == 2 and "fixed path" in bad.stderr
    assert not (tmp_path / "x.h5").exists()


def _sole_heights(res, points=np.linspace(-0.07, 0.15, 12)):
    """(s along +x, z) of sole points between the heel and toe pivots, for every truth sample."""
    val = res.trajectory.evaluate(res.truth["t_s"])[0]
    R = dcm_from_euler_zyx(val[:, 5], val[:, 4], val[:, 3])
    return [val[:, :3] + R @ np.array([sp, 0.0, 0.0]) for sp in points]


@pytest.mark.parametrize("up", [True, False])
def test_swing_clears_the_stair_edges(up):
    # flight along +x; on step k the foot origin is at s = k * tread and the tread spans
    # [k tread - 0.10, k tread + 0.18] (the 22 cm foot plus 3 cm to the next riser)
    riser, tread, n = 0.17, 0.28, 10
    res = simulate(custom("flight", lambda pb: pb.stand(1.0).stairs(n, riser, tread, up=up).stand(1.0)),
                   profile="ideal", rate_hz=1000.0)
    worst = np.inf
    for p in _sole_heights(res):
        s = p[:, 0]
        if up:
            surface = np.clip(np.floor((s + 0.10) / tread), 0, n) * riser
        else:
            surface = -np.clip(np.floor((s - 0.18) / tread) + 1, 0, n) * riser
        worst = min(worst, float(np.min(p[:, 2] - surface)))
    assert worst > -1e-3, f"sole {'climbing' if up else 'descending'} cuts a step by {-worst * 1e3:.1f} mm"


def test_level_gaits_never_go_below_the_floor_and_lift_the_foot():
    from bootnav.simulator.gait import RUN, SHUFFLE, WALK

    for gait in (WALK, RUN, SHUFFLE):
        res = simulate(custom("level", lambda pb: pb.stand(1.0).walk(8.0, gait).stand(1.0)), profile="ideal",
                       rate_hz=1000.0)
        z_min = min(float(p[:, 2].min()) for p in _sole_heights(res))
        assert z_min > -1e-4, gait.name
        assert res.truth["foot_pos_n_m"][:, 2].max() >= gait.clearance_m - 1e-9


@settings(max_examples=25, deadline=None)
@given(strides=st.lists(st.tuples(st.floats(0.0, 2.0), st.floats(-0.4, 0.4), st.floats(-2.0, 2.0),
                                  st.sampled_from(["walk", "run", "shuffle", "stairs_up", "stairs_down"])),
                        min_size=1, max_size=5))
def test_any_stride_sequence_has_c1_signals_and_lands_on_its_pose(strides):
    """Random strides: the foot ends exactly on the commanded pose, stance is exactly still, and the
    specific force and angular rate have no jumps at the knots (C3 trajectory)."""
    from bootnav.simulator.gait import GAITS

    def build(pb):
        pb.stand(0.5)
        for length, dz, turn, gait in strides:
            pb.stride(length, dz, turn, GAITS[gait])
        return pb.stand(0.5)

    res = simulate(custom("random", build), profile="ideal", rate_hz=200.0, mount="right_boot_tilted")
    traj = res.trajectory
    end = traj.evaluate(np.array([traj.t_knots[-1]]))[0][0]
    exp_xy = np.zeros(2)
    yaw = 0.0
    for length, dz, turn, _ in strides:
        chi = yaw + turn / 2
        exp_xy += length * np.array([np.cos(chi), np.sin(chi)])
        yaw += turn
    assert np.allclose(end[:2], exp_xy, atol=1e-9)
    assert end[2] == pytest.approx(sum(s[1] for s in strides), abs=1e-9)
    assert end[3] == pytest.approx(yaw, abs=1e-12)
    st_ = res.truth["stance"] == 1
    assert np.all(res.truth["vel_n_mps"][st_] == 0) and np.all(res.truth["omega_b_radps"][st_] == 0)
    from bootnav.simulator.imu_synth import synthesize

    tk = traj.t_knots[1:-1]
    e = 1e-7
    f = {k: synthesize(traj, tk + k * e) for k in (-2, -1, 1, 2)}
    for name in ("f_b", "omega_b"):
        left = (getattr(f[-1], name) - getattr(f[-2], name)) / e
        right = (getattr(f[2], name) - getattr(f[1], name)) / e
        jump = np.abs(getattr(f[1], name) - getattr(f[-1], name)).max()
        # value jump over 2e and slope jump over 3e are bounded by the next derivative (jerk < 1e5,
        # snap < 1e7 per s even at running impacts) times those spans; a kink (a C2 trajectory's jerk jump
        # at a knot, typically 1e2-1e4 m/s^3) fails the slope test
        assert jump < 1e5 * 2 * e, name
        assert np.abs(right - left).max() < 20.0, name


def test_mixed_scenario_covers_every_activity_and_stays_on_the_floors():
    from bootnav.simulator.gait import GAIT_CODES

    kinds = set()
    for seed in (0, 1):
        res = simulate("mixed-30min", seed=seed, profile="ideal", rate_hz=50.0, duration_s=600.0)
        kinds |= set(res.steps["kind"].tolist())
        z_stance = res.truth["foot_pos_n_m"][res.truth["stance"] == 1, 2]
        assert z_stance.min() > -1e-9  # never below the ground floor
        assert 590.0 <= res.truth["t_s"][-1] <= 700.0
    assert kinds >= {GAIT_CODES[g] for g in ("walk", "run", "shuffle", "stairs_up", "stairs_down", "turn")}
