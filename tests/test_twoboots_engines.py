"""The two-boot fusion on both filter engines: the filterpy reference navigator and the fast numba one take
the same constraint measurement and give the same fused feet, to floating-point accuracy."""

import dataclasses
import math

import numpy as np
import pytest

from bootnav.postproc.pipeline import process
from bootnav.postproc.twoboots import TwoBootSettings
from bootnav.postproc.twoboots.run import fuse_results
from bootnav.simulator import custom
from bootnav.simulator.twoboots import WalkerGeometry, simulate_two_boots, write_two_boots

# issue 27: a numerical fault (e.g. a sign error in the constraint) must fail within minutes, not hang for the
# suite's 10-minute default; the slowest test here takes about 20 s on a loaded 2-core machine
pytestmark = pytest.mark.timeout(120)

GEO = WalkerGeometry()
# a 32 m loop with turns on the spot, 46 s at 200 Hz per foot (the reference loop: ~3 s of CPU per fusion)
LOOP = custom("loop", lambda pb: pb.stand(5).walk(10).turn_in_place(math.pi / 2).walk(6).turn_in_place(math.pi / 2)
              .walk(10).turn_in_place(math.pi / 2).walk(6).stand(5))


@pytest.fixture(scope="module")
def single(tmp_path_factory):
    files = write_two_boots(simulate_two_boots(LOOP, seed=4, geometry=GEO), tmp_path_factory.mktemp("eng") / "w.h5")
    return {label: process(p) for label, p in zip(("left", "right"), files)}


def test_fast_and_reference_engines_fuse_alike(single):
    """Same single-foot inputs, clock, frame and instants: the only difference is the engine of the fused
    navigators. The reference runs the same arithmetic in another order (filterpy's update, numpy's
    smoother), so the two agree to accumulated rounding: 1e-6 m, far below the 1 cm σ of the constraint."""
    settings = single["left"].settings
    # a bound of 0.8 m (the simulated feet are never more than 0.72 m apart on this loop) bites often enough
    tb = TwoBootSettings(max_separation_m=0.8, right_start_m=(GEO.step_length_m, -GEO.step_width_m),
                         right_start_frame="left-sensor")
    out = {}
    for engine in ("fast", "reference"):
        s = dataclasses.replace(settings, filter=dataclasses.replace(settings.filter, engine=engine))
        out[engine] = fuse_results(single, s, tb)
        assert out[engine].summary["engine"] == engine
    fast, ref = out["fast"].fused, out["reference"].fused
    assert fast.n_active == ref.n_active >= 5 and fast.n_checks == ref.n_checks
    for label in ("left", "right"):
        a, b = getattr(fast, label), getattr(ref, label)
        assert b.info["engine"] == "reference" and b.info["external_updates"] == ref.n_active
        np.testing.assert_allclose(b.pos_n, a.pos_n, atol=1e-6, rtol=0)
        np.testing.assert_allclose(b.q_nb, a.q_nb, atol=1e-9, rtol=0)
        np.testing.assert_allclose(b.pos_sigma_n, a.pos_sigma_n, atol=1e-9, rtol=0)
    # the constraint moved the feet: the fused left foot (its frame is the common one) is not its single path
    assert np.abs(fast.left.pos_n - single["left"].pos_n).max() > 0.01
    np.testing.assert_allclose(out["reference"].walker_pos_n, out["fast"].walker_pos_n, atol=1e-6, rtol=0)


def test_two_boots_run_every_pass_on_the_reference_engine(tmp_path):
    """``process_two_boots`` with ``filter.engine = "reference"``: each foot's single run (the block passes) and
    the fusion say the reference engine ran, and each single foot's path is the fast engine's (1e-9 m)."""
    import bootnav

    files = write_two_boots(simulate_two_boots(LOOP, seed=4, geometry=GEO), tmp_path / "w.h5")
    ref = bootnav.process_two_boots(*files, filter={"engine": "reference"})
    assert ref.summary["engine"] == "reference"
    for label, path in zip(("left", "right"), files):
        single = ref.raw.single[label]
        assert single.summary["filter"]["engine"] == "reference"
        fast = process(path)
        assert fast.summary["filter"]["engine"] == "fast"
        assert np.abs(single.pos_n - fast.pos_n).max() < 1e-9
