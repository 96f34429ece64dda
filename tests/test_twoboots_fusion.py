"""Two-boot fusion end to end on a simulated walker: equivalence without the bound, clock and frame alignment,
step width, and the CLI (multi-boot recording and two files)."""

import json
from dataclasses import replace
import math
import subprocess
import sys

import numpy as np
import pytest

from bootnav.core.runs import runs
from bootnav.postproc.pipeline import process
from bootnav.postproc.settings import ProcessSettings
from bootnav.postproc.twoboots import TwoBootSettings
from bootnav.postproc.twoboots.align import gait_clock_offset, heading_offset_rad
from bootnav.postproc.twoboots.fusion import fuse
from bootnav.postproc.twoboots.gaitmetrics import gait_table
from bootnav.postproc.twoboots.outputs import plot_paths
from bootnav.postproc.twoboots.run import foot_input, fuse_results
from bootnav.simulator import custom
from bootnav.simulator.twoboots import (WalkerGeometry, max_separation_m, simulate_two_boots, write_two_boots,
                                        write_two_boots_h5)

# issue 27: a numerical fault (e.g. a sign error in the constraint) must fail within minutes, not hang for the
# suite's 10-minute default; the slowest test here takes about 20 s on a loaded 2-core machine
pytestmark = pytest.mark.timeout(120)

GEO = WalkerGeometry()
LOOP = custom("loop", lambda pb: pb.stand(5).walk(10).turn_in_place(math.pi / 2).walk(6).turn_in_place(math.pi / 2)
              .walk(10).turn_in_place(math.pi / 2).walk(6).stand(5))
KNOWN_START = dict(right_start_m=(GEO.step_length_m, -GEO.step_width_m), right_start_frame="left-sensor")


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """A simulated 32 m loop (walking gait, turns on the spot), both feet: two files and one multi-boot file."""
    d = tmp_path_factory.mktemp("twoboots")
    sims = simulate_two_boots(LOOP, seed=4)
    assert max_separation_m(sims) < TwoBootSettings().max_separation_m  # the walker respects the bound
    files = write_two_boots(sims, d / "rect.h5")
    both = write_two_boots_h5(sims, d / "both.h5")
    single = {label: process(p) for label, p in zip(("left", "right"), files)}
    return {"dir": d, "sims": sims, "files": files, "both": both, "single": single}


def test_without_the_bound_each_fused_foot_is_its_single_foot_path(walk):
    # the fusion runs no heading aid (docs/twoboots.md): compared with single feet processed without it
    plain = ProcessSettings()
    plain.filter = replace(plain.filter, heading_aid="none")
    L, R = (process(p, plain) for p in walk["files"])
    out = fuse(foot_input("left", L), foot_input("right", R), L.settings.filter,
               TwoBootSettings(max_separation_m=1e9))
    assert out.n_active == 0 and out.n_checks > 10
    for single, fused in ((L, out.left), (R, out.right)):  # the filter's path (process adds the storeys stage)
        np.testing.assert_allclose(fused.pos_n, single.nav.pos_n, atol=1e-9, rtol=0)
        np.testing.assert_allclose(fused.q_nb, single.q_nb, atol=1e-9, rtol=0)


def test_gait_symmetry_recovers_a_clock_offset(walk):
    """The simulated feet alternate exactly half a stride apart: a right clock late by 0.2 s is found to within
    the stance detector's onset jitter (a few samples), and the residual stays small."""
    L, R = walk["single"]["left"], walk["single"]["right"]
    zero = gait_clock_offset(L.t_s, L.stance, R.t_s, R.stance)
    late = gait_clock_offset(L.t_s, L.stance, R.t_s + 0.2, R.stance)
    assert zero["n_strides"] >= 10
    assert abs(zero["offset_s"]) < 0.03  # 6 samples at 200 Hz
    assert late["offset_s"] == pytest.approx(zero["offset_s"] - 0.2, abs=1e-9)


def test_frame_alignment_recovers_a_turned_frame(walk):
    """The right foot's path turned by 35 deg about z is turned back, from the first straight 8 m of the loop
    (truth paths; the 2.5 s displacements of the two feet differ by the stagger of the feet, 0.72 m, at the
    ends of the compared stretch only: at most 0.72 m / 8 m = 5 deg at one end, far less on average)."""
    sims = walk["sims"]
    pl = np.asarray(sims["left"].truth["pos_n_m"])
    pr = np.asarray(sims["right"].truth["pos_n_m"])
    a = math.radians(35.0)
    rot = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    h = heading_offset_rad(sims["left"].t_s, pl, sims["right"].t_s, pr @ rot.T, 8.0)
    assert h["n_points"] > 20
    assert math.degrees(h["yaw_rad"]) == pytest.approx(-35.0, abs=0.5)


def test_step_width_of_the_true_paths_is_the_simulated_one(walk):
    """``gait_table`` on the exact sensor paths: 0.15 m (the simulated step width, right foot on the right:
    positive) on every straight stride; turns on the spot are not walking steps."""
    sims = walk["sims"]
    feet = {}
    for label, offset in (("left", np.zeros(3)), ("right", np.array([GEO.step_length_m, -GEO.step_width_m, 0.0]))):
        tr = sims[label].truth
        feet[label] = {"t_s": sims[label].t_s, "pos_n": np.asarray(tr["pos_n_m"]) + offset, "stance": tr["stance"] > 0}
    g = gait_table(feet["left"], feet["right"], min_stride_m=0.05)
    for label in ("left", "right"):
        w = g[label]["step_width_m"]
        straight = np.isfinite(w) & (np.abs(w - GEO.step_width_m) < 0.1)
        assert straight.sum() >= 0.6 * np.isfinite(w).sum()
        np.testing.assert_allclose(w[straight], GEO.step_width_m, atol=1e-3)


def test_fused_feet_meet_the_bound_at_the_checks(walk):
    res = fuse_results(walk["single"], walk["single"]["left"].settings, TwoBootSettings(**KNOWN_START))
    assert res.fused.n_checks > 30
    png = walk["dir"] / "paths.png"
    plot_paths(res, png)  # both feet alone and fused, and the walker, in one frame
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for a, b in ((res.fused.left, res.fused.right), (res.fused.right, res.fused.left)):
        starts, stops = runs(a.stance)
        t_mid = 0.5 * (a.t_s[starts] + a.t_s[stops - 1])  # the checks of the bound
        pa, pb = (np.column_stack([np.interp(t_mid, f.t_s, f.pos_n[:, j]) for j in range(3)]) for f in (a, b))
        # filtered positions meet it to constraint_sigma_m; the smoother then moves the swinging foot by
        # what the later ZUPTs of its stride tell, a few centimetres on a 32 m walk
        assert np.linalg.norm(pa - pb, axis=1).max() < TwoBootSettings().max_separation_m + 0.05


def _bootnav(*args):
    return subprocess.run([sys.executable, "-m", "bootnav", *map(str, args)], capture_output=True, text=True,
                          timeout=120)


def test_cli_multi_boot_recording_writes_both_feet_and_refuses_to_overwrite(walk):
    out = walk["dir"] / "out_both"
    r = _bootnav("process", walk["both"], "--out", out, "-q", "--no-plots")
    assert r.returncode == 0, r.stderr
    assert "walker:" in r.stdout and "left" in r.stdout and "right" in r.stdout
    summary = json.loads((out / "two_boots.json").read_text())
    assert summary["two_boot_settings"]["max_separation_m"] == 1.0 and summary["settings"]
    for f in ("walker.csv", "strides.csv", "two_boots.h5", "left/trajectory.csv", "right/steps.csv",
              "left/summary.json", "right/results.h5"):
        assert (out / f).is_file(), f
    header = (out / "strides.csv").read_text().splitlines()[0]
    assert header.endswith("step_width_m,floor,ellipse_major_m,ellipse_minor_m,ellipse_orientation_rad")
    assert header.startswith("foot,t_s")
    again = _bootnav("process", walk["both"], "--out", out, "-q", "--no-plots")
    assert again.returncode == 1 and "exists" in again.stderr and "Traceback" not in again.stderr


def test_cli_two_files_and_bad_requests(walk):
    left, right = walk["files"]
    out = walk["dir"] / "out_files"
    r = _bootnav("process", left, right, "--two-boots", "--out", out, "-q", "--no-plots", "--max-separation", "0.9")
    assert r.returncode == 0, r.stderr
    assert json.loads((out / "two_boots.json").read_text())["constraint"]["bound_m"] == 0.9
    one = _bootnav("process", left, "--two-boots", "--out", walk["dir"] / "o1", "-q")
    assert one.returncode == 1 and "--two-boots needs LEFT RIGHT" in one.stderr and len(one.stderr.splitlines()) == 1
    ric = _bootnav("process", left, right, "--two-boots", "--mode", "riccati", "--out", walk["dir"] / "o2", "-q")
    assert ric.returncode == 1 and "time-varying" in ric.stderr and "Traceback" not in ric.stderr
    bad = _bootnav("process", left, right, "--two-boots", "--max-separation", "-1", "--out", walk["dir"] / "o3", "-q")
    assert bad.returncode == 1 and "max_separation_m" in bad.stderr


def test_cli_simulate_two_boots(tmp_path):
    out = tmp_path / "straight.h5"
    r = _bootnav("simulate", "--scenario", "paper-straight", "--two-boots", "--seed", "2", "--out", out)
    assert r.returncode == 0, r.stderr
    assert "two boots" in r.stdout and "largest distance between the feet" in r.stdout
    from bootnav.logger.recording import boot_labels, load

    assert boot_labels(out) == ["left", "right"]
    left, right = load(out, boot="left"), load(out, boot="right")
    assert left.meta["mount"] == "left_boot" and right.meta["mount"] == "right_boot"
    assert "pos_n_m" in left.truth and "pos_n_m" in right.truth
    again = _bootnav("simulate", "--scenario", "paper-straight", "--two-boots", "--out", out)
    assert again.returncode == 1 and "--force" in again.stderr
