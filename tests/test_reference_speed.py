"""Point-to-polyline distance of the reference metrics: exact (the brute-force result to the last bit) and
O((K + M) log M), so a dense reference (one vertex per sample of a 30 min walk) costs about a second, not a
minute (issue 13, point 4); timed as its own ``reference`` stage."""

from __future__ import annotations

import time

import numpy as np
import pytest

from bootnav.postproc.reference_path import distance_to_polyline
from tests.conftest import REPO


def brute_force(p_xy, poly):
    """Every point against every segment (the definition)."""
    a, b = poly[:-1, None, :2], poly[1:, None, :2]
    ab = b - a
    den = np.maximum((ab**2).sum(-1), 1e-300)
    ap = p_xy[None, :, :] - a
    u = np.clip((ap * ab).sum(-1) / den, 0.0, 1.0)
    return np.linalg.norm(ap - u[..., None] * ab, axis=-1).min(axis=0)


@pytest.mark.parametrize("shape", ["walk", "scatter", "circle", "waypoints"])
def test_identical_to_brute_force(shape):
    rng = np.random.default_rng(7)
    if shape == "walk":  # dense, with runs of repeated vertices (stance) and long jumps
        steps = rng.normal(size=(3000, 3)) * rng.choice([0.0, 0.01, 1.0], size=(3000, 1))
        poly, p = np.cumsum(steps, axis=0), rng.uniform(-30, 30, (400, 2))
    elif shape == "scatter":
        poly, p = rng.uniform(-20, 20, (800, 3)), rng.uniform(-25, 25, (400, 2))
    elif shape == "circle":  # points near the centre are almost equidistant from every vertex
        th = np.linspace(0, 2 * np.pi, 2000)
        poly, p = np.column_stack((5 * np.cos(th), 5 * np.sin(th), th)), rng.normal(scale=0.3, size=(300, 2))
    else:  # a few long segments: the densified samples decide
        poly, p = np.array([[0, 0, 0], [40, 0, 0], [40, 10, 3], [0, 10, 3.0]]), rng.uniform(-5, 45, (500, 2))
    assert np.array_equal(distance_to_polyline(p, poly), brute_force(p, poly))


def test_dense_reference_is_fast():
    """360 k vertices (30 min at 200 Hz) and 1400 footprints: brute force does 5·10⁸ point-segment
    distances (~60 s); the KD search must stay below 5 s even on a busy 2-core machine."""
    rng = np.random.default_rng(3)
    n = 360_000
    heading = np.cumsum(rng.normal(scale=0.002, size=n))
    poly = np.column_stack((np.cumsum(0.005 * np.cos(heading)), np.cumsum(0.005 * np.sin(heading)), np.zeros(n)))
    p = poly[:: n // 1400, :2] + rng.normal(scale=0.5, size=(len(poly[:: n // 1400]), 2))
    t0 = time.perf_counter()
    d = distance_to_polyline(p, poly)
    assert time.perf_counter() - t0 < 5.0
    sub = slice(0, 1400, 97)  # exact on a sample of the points (brute force on all would take a minute)
    assert np.array_equal(d[sub], brute_force(p[sub], poly))


def test_reference_has_its_own_stage_timing():
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    rec = REPO / "recordings" / "xio_ngimu_short_walk.h5"
    if not rec.exists():
        pytest.skip("recordings/ not present")
    ref = REPO / "recordings" / "xio_ngimu_short_walk.reference.json"
    timings = process(rec, ProcessSettings(reference=str(ref))).summary["timings_s"]
    stages = list(timings)  # the passes of ``passes.BlockPasses``, in order: the reference right after strides
    assert stages[:3] == ["load", "stance_floor", "timing"] and stages.index("reference") == stages.index("strides") + 1
    assert "reference" not in process(rec, ProcessSettings()).summary["timings_s"]
