"""``bootnav.process_two_boots``: the two-boot mode of the Python API (one multi-boot file, two files or two sets
of arrays give one result), its fields, and ``save``."""

import math

import numpy as np
import pytest

import bootnav
from bootnav.errors import InputError
from bootnav.simulator import custom
from bootnav.simulator.twoboots import WalkerGeometry, simulate_two_boots, write_two_boots, write_two_boots_h5

# issue 27: a numerical fault (e.g. a sign error in the constraint) must fail within minutes, not hang for the
# suite's 10-minute default; the slowest test here takes about 20 s on a loaded 2-core machine
pytestmark = pytest.mark.timeout(120)

GEO = WalkerGeometry()
BACK = custom("back", lambda pb: pb.stand(5).walk(12).turn_in_place(math.pi).walk(12).stand(5))
KNOWN_START = {"right_start_m": (GEO.step_length_m, -GEO.step_width_m), "right_start_frame": "left-sensor"}


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    d = tmp_path_factory.mktemp("api2")
    sims = simulate_two_boots(BACK, seed=2, geometry=GEO)
    return {"dir": d, "sims": sims, "files": [str(p) for p in write_two_boots(sims, d / "w.h5")],
            "both": str(write_two_boots_h5(sims, d / "both.h5"))}


@pytest.fixture(scope="module")
def both(walk):
    return bootnav.process_two_boots(walk["both"], two_boot=KNOWN_START)


def test_one_multi_boot_file_two_files_and_arrays_agree(walk, both):
    by_files = bootnav.process_two_boots(*walk["files"], two_boot=KNOWN_START)
    recs = [bootnav.load(f) for f in walk["files"]]
    by_arrays = bootnav.process_two_boots(*[(r.t_s, r.acc_mps2, r.gyro_radps) for r in recs], two_boot=KNOWN_START)
    for other in (by_files, by_arrays):
        assert np.array_equal(other.walker_pos_n_m, both.walker_pos_n_m)
        assert np.array_equal(other.strides["step_width_m"], both.strides["step_width_m"], equal_nan=True)


def test_fields_are_the_fused_feet_the_walker_and_the_gait(walk, both):
    L, R = both.left, both.right
    assert isinstance(L, bootnav.PathResult) and isinstance(both, bootnav.TwoBootPathResult)
    assert "TwoBootPathResult(" in repr(both)
    # the walker is the midpoint of the two fused feet at the left foot's times
    pr = np.column_stack([np.interp(both.walker_t_s, R.t_s, R.pos_n_m[:, j]) for j in range(3)])
    np.testing.assert_allclose(both.walker_pos_n_m, 0.5 * (L.pos_n_m + pr), atol=1e-12)
    # each foot alone is the single-foot API's result
    alone = bootnav.process(walk["files"][0])
    assert np.array_equal(both.left_alone.pos_n_m, alone.pos_n_m)
    # strides of both feet, in time order; per foot the fused foot's own stride table
    feet = both.strides["foot"]
    assert set(feet) == {"left", "right"} and np.all(np.diff(both.strides["t_s"]) >= 0)
    np.testing.assert_array_equal(both.stride_lengths_m("left"), L.steps["stride_length_m"])
    np.testing.assert_array_equal(both.stride_lengths_m("right"), R.steps["stride_length_m"])
    # against the simulated truth: every walking stride is 12 m / 9 long; 1 % of it is what a ZUPT filter with
    # the MPU6050 model keeps over 12 m (the scale error of a foot, README accuracy table)
    true_len = float(np.max(walk["sims"]["left"].steps["length_m"]))
    assert true_len == pytest.approx(12.0 / 9)
    for foot in ("left", "right"):
        s = both.stride_lengths_m(foot)
        walking = np.abs(s - true_len) < 0.1 * true_len
        assert walking.sum() == 18  # 9 strides out, 9 back (the turn's shuffles are shorter)
        np.testing.assert_allclose(s[walking], true_len, rtol=0.01)
    # the feet are never further apart than the bound, so neither is a step width
    w = both.strides["step_width_m"]
    assert np.isfinite(w).sum() >= 20
    assert np.all(np.abs(w[np.isfinite(w)]) < both.summary["constraint"]["bound_m"])


def test_save_writes_the_cli_files_and_refuses_to_overwrite(walk, both):
    out = walk["dir"] / "out"
    files = both.save(out)
    for name in ("walker.csv", "strides.csv", "two_boots.json", "two_boots.h5"):
        assert (out / name).is_file()
    assert (out / "left" / "trajectory.csv").is_file() and (out / "right" / "steps.csv").is_file()
    assert files["summary"] == str(out / "two_boots.json")
    with pytest.raises(InputError, match="exists"):
        both.save(out)
    both.save(out, force=True)


def test_bad_calls_are_one_line_errors(walk):
    with pytest.raises(InputError, match="right foot too"):
        bootnav.process_two_boots(walk["files"][0])
    with pytest.raises(InputError, match="boots="):
        bootnav.process_two_boots(*walk["files"], boots=("left", "right"))
    with pytest.raises(InputError, match="give two of the labels"):
        bootnav.process_two_boots(walk["both"], boots=("left", "nope"))
    with pytest.raises(InputError, match="unknown two-boot setting"):
        bootnav.process_two_boots(*walk["files"], two_boot={"gamma": 1.0})
    with pytest.raises(InputError, match="arrays is"):
        bootnav.process_two_boots((np.zeros(3), np.zeros((3, 3))), walk["files"][1])
