"""`process` in chunks (``pipeline.process_chunked``, ``--chunk-s``) gives the whole-array run's path."""

import subprocess
import sys

import h5py
import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.postproc.outputs import write_outputs
from bootnav.postproc.pipeline import process, process_chunked
from bootnav.postproc.settings import ProcessSettings
from bootnav.simulator.simulate import LongSimulation
from bootnav.simulator.writers import write_long_h5


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    d = tmp_path_factory.mktemp("chunked")
    rec = write_long_h5(LongSimulation(120.0, seed=5, block_s=30.0), d / "walk.h5")
    settings = ProcessSettings()
    settings.output.plots = False
    settings.floor_storeys = False  # a look-back stage the chunked run does not have (it warns)
    whole = process(rec, settings)
    write_outputs(whole, d / "whole")
    return d, rec, whole


def results(folder):
    with h5py.File(folder / "results.h5", "r") as f:
        return {k: f[f"results/default/{k}"][()] for k in ("t_s", "pos_n_m", "vel_n_mps", "q_nb", "stance")}


@pytest.mark.parametrize("chunk_s", [2.9, 13.0, 1000.0])
def test_every_chunk_size_gives_the_whole_array_path(walk, chunk_s):
    d, rec, whole = walk
    out = d / f"c{chunk_s:g}"
    summary, files = process_chunked(rec, ProcessSettings(), out, chunk_s)
    r = results(out)
    assert len(r["t_s"]) == len(whole.t_s)
    np.testing.assert_array_equal(r["t_s"], whole.t_s)
    np.testing.assert_array_equal(r["stance"].astype(bool), whole.stance)
    assert np.abs(r["pos_n_m"] - whole.pos_n).max() <= 1e-9
    assert np.abs(r["q_nb"] - whole.q_nb).max() <= 1e-9
    assert summary["navigation"]["timing_offset"]["tau_s"] == whole.navigation.timing["tau_s"]
    assert summary["path"]["distance_m"] == pytest.approx(whole.summary["path"]["distance_m"], abs=1e-9)
    # the files too: trajectory.csv byte for byte, steps.csv to the printed precision
    assert (out / "trajectory.csv").read_bytes() == (d / "whole" / "trajectory.csv").read_bytes()
    head = (out / "steps.csv").read_text().splitlines()[0].split(",")
    assert head == ["t_s", "x_m", "y_m", "z_m", "stride_length_m", "dz_m", "yaw_enu_rad", "heading_deg_cw_from_north",
                    "floor"]
    whole_head = (d / "whole" / "steps.csv").read_text().splitlines()[0].split(",")
    mine = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)
    theirs = np.loadtxt(d / "whole" / "steps.csv", delimiter=",", skiprows=1)[:, [whole_head.index(c) for c in head]]
    np.testing.assert_allclose(mine, theirs, atol=1.5e-4)  # last printed digit, footprint sums in another order


def test_cli_refuses_what_chunks_cannot_do(walk, tmp_path):
    d, rec, _ = walk
    run = lambda *a: subprocess.run([sys.executable, "-m", "bootnav", "process", *map(str, a)],  # noqa: E731
                                    capture_output=True, text=True, timeout=120)
    p = run(rec, "--out", tmp_path / "o", "--chunk-s", "10", "--crop", "0", "50")
    assert p.returncode == 1 and "--crop is not available with --chunk-s" in p.stderr and "Traceback" not in p.stderr
    with pytest.raises(InputError, match="--chunk-s must be a positive number of seconds"):
        process_chunked(rec, ProcessSettings(), tmp_path / "o", 0.0)
    csv = tmp_path / "imu.csv"
    csv.write_text("t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps\n0,0,0,9.8,0,0,0\n")
    p = run(csv, "--out", tmp_path / "o2", "--chunk-s", "10")
    assert p.returncode == 1 and "`bootnav import` it first" in p.stderr


def test_a_recording_too_big_for_the_memory_limit_is_processed_in_chunks(walk, tmp_path):
    """The whole-array run's memory estimate (cli_process.WHOLE_RUN_*) against --memory-limit picks the mode."""
    d, rec, whole = walk
    run = lambda *a: subprocess.run([sys.executable, "-m", "bootnav", "process", str(rec), *map(str, a)],  # noqa: E731
                                    capture_output=True, text=True, timeout=180)
    p = run("--out", tmp_path / "small", "--memory-limit", "1")  # 1 MB: far below the base alone
    assert p.returncode == 0, p.stderr
    assert "processed in chunks of 600 s" in p.stderr and "Traceback" not in p.stderr
    assert len(list((tmp_path / "small").glob("*.png"))) == 7  # the chunked run draws the charts too
    assert np.abs(results(tmp_path / "small")["pos_n_m"] - whole.pos_n).max() <= 1e-9
    p = run("--out", tmp_path / "big", "--memory-limit", "1e6", "--no-plots")  # 1 TB: the whole-array run
    assert p.returncode == 0, p.stderr
    assert "processed in chunks" not in p.stderr
    p = run("--out", tmp_path / "bad", "--memory-limit", "-1")
    assert p.returncode == 1 and "--memory-limit must be a positive number of MB" in p.stderr
