"""The learned stance detector: its inference against a hand computation, the shipped model's provenance, the
refusal of a bad model file, and the same strides at 400 and 100 Hz of one real walk (windows in seconds).

Its accuracy is measured by ``benchmarks/learned_stance.py crossval`` (leave-one-dataset-out), not here."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bootnav.postproc.detectors import DetectorSettings, detect_stance
from bootnav.postproc.detectors.learned import (SHIPPED_MODEL, StanceModel, feature_names, load_model,
                                                stance_features)

# the only sources of stance labels in ../shared/datasets (benchmarks/learned_stance.py, docs/learned-stance.md)
LABELLED = {"pyshoe_vicon", "gaitmap_example", "koroglu_footprints", "koroglu_rectangles"}


def _sigmoid(z):
    return 1.0 / (1.0 + np.exp(-z))


def test_probability_is_the_networks_output_computed_by_hand():
    rng = np.random.default_rng(3)
    f = len(feature_names())
    x = rng.normal(2.0, 3.0, (50, f))
    mean, scale = rng.normal(0, 1, f), rng.uniform(0.5, 2.0, f)
    w1, b1, w2, b2 = rng.normal(0, 0.5, (f, 4)), rng.normal(0, 0.5, 4), rng.normal(0, 1, (4, 1)), rng.normal(0, 1, 1)
    net = StanceModel(mean, scale, ((w1, b1), (w2, b2)), {})
    z = (x - mean) / scale
    expect = [_sigmoid(np.tanh(z[i] @ w1 + b1) @ w2[:, 0] + b2[0]) for i in range(len(x))]
    np.testing.assert_allclose(net.probability(x), expect, rtol=1e-12)
    logistic = StanceModel(mean, scale, ((w1[:, :1], b1[:1]),), {})
    np.testing.assert_allclose(logistic.probability(x), _sigmoid(z @ w1[:, 0] + b1[0]), rtol=1e-12)
    far = StanceModel(np.zeros(f), np.ones(f), ((np.full((f, 1), 100.0), np.zeros(1)),), {})
    assert np.all(np.isfinite(far.probability(np.c_[np.full((2, f), 10.0)] * [[1], [-1]])))  # no overflow


def test_shipped_model_says_what_it_was_trained_on():
    doc = json.loads(SHIPPED_MODEL.read_text())
    model = StanceModel.from_dict(doc)
    prov = model.provenance
    assert set(prov["trained_on"]) <= LABELLED and "pyshoe_vicon" in prov["trained_on"]
    assert set(prov["labels"]) == set(prov["trained_on"]) and all(v["labels"] > 0 for v in prov["labels"].values())
    assert prov["script"].startswith("benchmarks/learned_stance.py") and prov["date"]
    assert doc["features"] == feature_names() and model.mean.shape == (len(feature_names()),)
    assert SHIPPED_MODEL.stat().st_size < 20_000  # a few hundred numbers, shipped in the package


def test_a_bad_model_file_is_refused_with_its_name(tmp_path):
    good = json.loads(SHIPPED_MODEL.read_text())
    cases = {
        "missing.json": None,
        "not_a_model.json": {"hello": 1},
        "old_features.json": {**good, "feature_version": 0},
        "wrong_shape.json": {**good, "mean": good["mean"][:-1]},
        "nan_weight.json": {**good, "layers": [{"W": [[float("nan")]] * len(good["mean"]), "b": [0.0]}]},
    }
    for name, doc in cases.items():
        path = tmp_path / name
        if doc is not None:
            path.write_text(json.dumps(doc))
        with pytest.raises(ValueError, match=name):
            DetectorSettings("learned", {"model": str(path)})
    path = tmp_path / "copy.json"
    path.write_text(json.dumps(good))
    assert DetectorSettings("learned", {"model": str(path)}).build().model == str(path)


def test_features_are_finite_on_noise_free_rest():
    """A sensor at perfect rest (simulated, noise-free): the logs meet their physical floors, not -inf."""
    n = 500
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    feats = stance_features(acc, np.zeros((n, 3)), 0.01, 9.81)
    assert feats.shape == (n, len(feature_names())) and np.isfinite(feats).all()
    assert np.allclose(feats[:, :3], np.log10(1e-3**2)) and np.allclose(feats[:, 3:6], np.log10(1e-2**2))


def test_same_strides_at_400_and_100_hz(xio_short_walk):
    """One real walk (NGIMU, 400 Hz, never trained on) and its block-mean decimation to 100 Hz: the foot
    makes the same strides, so every stance phase found at one rate starts within the 0.1 s minimum swing of
    one found at the other; the only extra phase allowed is a split of a rest (it starts inside a stance phase
    of the other rate, so it adds no zero-velocity update while the foot moves)."""
    t, acc, gyro = xio_short_walk
    k = 4
    n = (len(t) // k) * k
    t4, acc4, gyro4 = (x[:n].reshape(n // k, k, *x.shape[1:]).mean(axis=1) for x in (t, acc, gyro))
    s = DetectorSettings("learned")
    hi, lo = detect_stance(t, acc, gyro, s), detect_stance(t4, acc4, gyro4, s)
    assert hi.phases()[0].size >= 12  # a 23 m loop at no more than 2 m per stride
    for a, ta, b, tb in ((hi, t, lo, t4), (lo, t4, hi, t)):
        starts_b = tb[b.phases()[0]]
        stance_b_at = np.interp(ta, tb, b.stance.astype(float)) >= 0.5
        for i in a.phases()[0]:
            assert np.min(np.abs(starts_b - ta[i])) <= 0.1 or stance_b_at[i], \
                f"a stance phase at {ta[i]:.2f} s has no counterpart at the other rate"


@pytest.fixture(scope="module")
def xio_short_walk():
    import bootnav

    from tests.conftest import REPO

    rec = bootnav.load(REPO / "recordings" / "xio_ngimu_short_walk.h5")
    return (np.asarray(rec.t_s, float), np.asarray(rec.acc_mps2, float), np.asarray(rec.gyro_radps, float))


def test_load_model_default_is_the_shipped_file():
    assert load_model("") is load_model("")  # cached: one read per process
    assert load_model("").provenance == json.loads(SHIPPED_MODEL.read_text())["provenance"]
