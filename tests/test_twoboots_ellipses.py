"""Issue 24: every two-boot stride carries its horizontal 1-σ ellipse (the columns of ``steps.csv``), from the
conservative per-foot covariance (``run.foot_covariance``) plus the scale/cross-axis term (``ellipses``), in
``strides.csv`` and each foot's ``steps.csv``."""

import csv
import math

import numpy as np
import pytest

from bootnav.postproc.ellipses import scale_sigmas
from bootnav.postproc.pipeline import process
from bootnav.postproc.strides import ELLIPSE_COLUMNS, ellipse, phase_ends
from bootnav.postproc.twoboots import TwoBootSettings
from bootnav.postproc.twoboots.outputs import write_two_boot_outputs
from bootnav.postproc.twoboots.run import common_frame_covariance, fuse_results
from bootnav.simulator import custom
from bootnav.simulator.twoboots import WalkerGeometry, simulate_two_boots, write_two_boots

pytestmark = pytest.mark.timeout(120)

GEO = WalkerGeometry()
STRAIGHT = custom("straight", lambda pb: pb.stand(5).walk(20).stand(3))
KNOWN_START = dict(right_start_m=(GEO.step_length_m, -GEO.step_width_m), right_start_frame="left-sensor")


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """A simulated 20 m straight walk of both feet, each foot processed alone, then fused and written."""
    d = tmp_path_factory.mktemp("tbellipse")
    files = write_two_boots(simulate_two_boots(STRAIGHT, seed=5, geometry=GEO), d / "s.h5")
    single = {label: process(p) for label, p in zip(("left", "right"), files)}
    res = fuse_results(single, single["left"].settings, TwoBootSettings(**KNOWN_START))
    files = write_two_boot_outputs(res, d / "out")
    return {"single": single, "res": res, "files": files}


def _read(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_every_stride_file_has_finite_positive_definite_ellipses(walk):
    rows = _read(walk["files"]["strides"])
    assert rows and all(c in rows[0] for c in ELLIPSE_COLUMNS)
    for label in ("left", "right"):
        steps = _read(walk["files"][f"{label}_steps"])  # the fused foot's own steps.csv
        foot = [r for r in rows if r["foot"] == label]
        assert len(foot) >= 10
        assert len(steps) == len(foot)
        for table in (foot, steps):
            major, minor, theta = (np.array([float(r[c]) for r in table]) for c in ELLIPSE_COLUMNS)
            assert np.isfinite(major).all() and np.isfinite(minor).all() and np.isfinite(theta).all()
            assert (minor > 0).all() and (major >= minor).all()  # positive definite, semi-axes ordered
            assert ((theta > -math.pi / 2 - 1e-9) & (theta <= math.pi / 2 + 1e-9)).all()


def test_the_ellipse_grows_with_the_distance_walked(walk):
    """The scale term alone is σ_s·‖p_k − p_0‖ along the walk (``ellipses``), and the filter's covariance is
    positive semi-definite, so every stride's semi-major axis is at least that; and it grows: the last strides'
    ellipse is larger than the first strides'."""
    res = walk["res"]
    sigma_s, _ = scale_sigmas(res.settings, False)
    for label in ("left", "right"):
        g = res.gait[label]
        fp = np.column_stack((g["x_m"], g["y_m"]))
        major = np.asarray(g["ellipse_major_m"])
        along = sigma_s * np.hypot(*(fp - fp[0]).T)
        assert (major >= along * (1 - 1e-9)).all()
        q = max(len(major) // 4, 1)
        assert major[-q:].mean() > major[:q].mean()
        assert np.hypot(*(fp[-1] - fp[0])) > 15.0  # the walk is what the scenario says (20 m, less a stride)


def test_the_ellipse_is_the_conservative_per_foot_covariance(walk):
    """The left foot's frame is the common frame: on this walk its ellipses are its single-foot ``steps.csv`` ones
    (one definition; the constraint only shrinks the navigator's own P). The right foot's conservative part
    (``common_frame_covariance``), with γ = ∞ (no update), is not smaller than its own navigator's in the fusion
    (which starts with the alignment's yaw σ): the single-foot covariance turned into the common frame plus the
    rest of the alignment's yaw variance is the same variance to first order in the yaw error (for a single-foot
    run without the heading aid, as here); the neglected terms are of relative order σ_ψ², so the tolerance is a
    few σ_ψ² (4 σ_ψ² = 0.5 % at σ_ψ = 2°)."""
    single = walk["single"]
    res = walk["res"]
    for c in ELLIPSE_COLUMNS:
        np.testing.assert_allclose(res.gait["left"][c], single["left"].steps[c], atol=1e-9, rtol=0)
    st = single["left"].settings
    tb = TwoBootSettings(max_separation_m=1e9, **KNOWN_START)
    free = fuse_results(single, st, tb)
    assert free.fused.n_active == 0
    f = free.fused.right
    end = phase_ends(f.stance)
    cov = common_frame_covariance(f, single["right"], st, free.heading["yaw_rad"], tb.heading_alignment_sigma_rad)
    conservative, _, _ = ellipse(*cov.T)
    own, _, _ = ellipse(f.pos_sigma_n[end, 0] ** 2, f.pos_sigma_n[end, 1] ** 2, f.pos_cov_en[end])
    assert len(own) >= 10 and (conservative >= own * (1 - 4 * tb.heading_alignment_sigma_rad ** 2)).all()
