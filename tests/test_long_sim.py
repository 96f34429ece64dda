"""Long simulated recordings generated block by block (``LongSimulation``, ``write_long_h5``)."""

import numpy as np
import pytest

from bootnav.logger.recording import load
from bootnav.simulator.simulate import LongSimulation
from bootnav.simulator.writers import write_long_h5


@pytest.fixture(scope="module")
def two_block_sizes(tmp_path_factory):
    d = tmp_path_factory.mktemp("longsim")
    sims = {b: LongSimulation(150.0, seed=3, block_s=b) for b in (30.0, 100.0)}
    paths = {b: write_long_h5(sim, d / f"b{b:g}.h5") for b, sim in sims.items()}
    return sims, paths


def test_the_walk_does_not_depend_on_the_block_size(two_block_sizes):
    sims, paths = two_block_sizes
    a, b = sims[30.0].steps, sims[100.0].steps
    assert len(a["t_end_s"]) > 50  # 150 s of walking laps
    for key in ("t_end_s", "length_m", "dz_m", "heading_rad"):
        np.testing.assert_array_equal(a[key], b[key])
    ra, rb = load(paths[30.0], with_truth=False), load(paths[100.0], with_truth=False)
    assert abs(ra.n - rb.n) <= 20  # same length; only the drop bursts (drawn per block) differ
    assert ra.t_s[-1] >= 150.0 - 1.0


def test_blocks_join_without_a_seam(two_block_sizes):
    """Time runs on across block boundaries and the recording navigates: the distance walked matches the truth
    (a jump of attitude or position at a seam would add metres)."""
    from bootnav.postproc.pipeline import process

    sims, paths = two_block_sizes
    rec = load(paths[30.0], with_truth=False)
    dt = np.diff(rec.t_s)
    assert dt.min() > 0 and dt.max() < 0.05  # no backwards time, no gap beyond a short drop burst
    truth_m = float(np.sum(sims[30.0].steps["length_m"]))
    r = process(paths[30.0])
    assert r.summary["path"]["distance_m"] == pytest.approx(truth_m, rel=0.03)
