"""Learned stance detector: a tiny network on windowed, physical features, trained on motion-capture stance.

Why: a learned zero-velocity classifier (an LSTM on raw IMU windows) cut pyshoe's 3-D error by about a third on
mixed motion (walking, running, stairs, crawling) against the best fixed-threshold detector [Wagstaff2020]. This
module asks whether a much smaller model, shipped as a few hundred numbers and run in numpy, transfers to the
sensors and gaits of the other datasets; ``benchmarks/learned_stance.py`` trains it and answers the question
leave-one-dataset-out (docs/learned-stance.md, docs/tuning-log.md). It is a registered detector
(``--detector learned``), not the default.

Features (``stance_features``), per sample, all from centred windows defined in seconds, so that a model
trained at 200 Hz reads a 100 Hz or an 820 Hz recording the same way:

    e_ω(W)  = log10( mean_W |ω|² + ω_0² )                      rad²/s², W ∈ ``WINDOWS_S``
    e_a(W)  = log10( mean_W |f|² − 2 g |mean_W f| + g² + a_0² ) m²/s⁴ (SHOE's specific-force term [Skog2010])
    r       = (L − min_S L) / (max_S L − min_S L + 0.1)          L = log10 SHOE T over 0.05 s, S = 1.5 s
    d       = L − q_0.05(L)                                      decades above the recording's noise floor
    e_ω(0.05 s), e_a(0.05 s) at the offsets ``OFFSETS_S``         what comes before and after (the context an
                                                                 LSTM sees [Wagstaff2020])

ω_0 = 1e-3 rad/s and a_0 = 1e-2 m/s² (a good MEMS sensor's noise) keep the logs of noise-free data finite. ``r``
and ``d`` are the adaptive detector's two scale-free quantities (adaptive.py): the model may lean on them.

Model: standardised features → one hidden layer of tanh units (or none: logistic regression) → the
probability p that the foot is at rest; stance ⇔ p ≥ ``probability``, then the shared post-processing of
``base.StanceDetector.detect`` (minimum swing and stance, saturated samples never stance). The shipped weights
(``learned_stance.json``, beside this module) carry their provenance: training data, labels, date, script.
Labels: only ``pyshoe_vicon`` has per-sample zero-velocity truth (thresholded VICON foot speed); gaitmap's
mocap strides and koroglu's surveyed footprints give point labels (docs/learned-stance.md says which).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import ClassVar

import numpy as np

from bootnav.core.arrays import moving_mean, row_norm, window_samples
from .base import FRACTION, StanceDetector, register
from .shoe import shoe_statistic

#: the shipped model (``benchmarks/learned_stance.py train``)
SHIPPED_MODEL = Path(__file__).with_name("learned_stance.json")
#: feature layout version: a model file names the version its features had
FEATURE_VERSION = 1
WINDOWS_S = (0.05, 0.15, 0.4)
OFFSETS_S = (-0.2, -0.1, 0.1, 0.2)
BASE_WINDOW_S = 0.05
SPAN_S = 1.5
NOISE_QUANTILE = 0.05
GYRO_FLOOR_RADPS = 1e-3
ACC_FLOOR_MPS2 = 1e-2
# SHOE's σ's only shift L by a constant (adaptive.py); the OpenShoe values [Nilsson2012]
SIGMA_ACC_MPS2 = 0.01
SIGMA_GYRO_RADPS = math.radians(0.1)


def feature_names() -> list[str]:
    """Names of the columns of ``stance_features``, in order."""
    names = [f"log_gyro_energy_{w:g}s" for w in WINDOWS_S] + [f"log_acc_energy_{w:g}s" for w in WINDOWS_S]
    names += ["shoe_rel_position", "shoe_decades_above_floor"]
    names += [f"log_gyro_energy_{BASE_WINDOW_S:g}s_at_{o:+g}s" for o in OFFSETS_S]
    names += [f"log_acc_energy_{BASE_WINDOW_S:g}s_at_{o:+g}s" for o in OFFSETS_S]
    return names


def _shift(x: np.ndarray, k: int) -> np.ndarray:
    """x[i + k] at each i, the edge value repeated beyond the ends."""
    idx = np.clip(np.arange(x.shape[0]) + k, 0, x.shape[0] - 1)
    return x[idx]


def stance_features(acc_b, gyro_b, dt: float, gravity_mps2: float, bad=None) -> np.ndarray:
    """(N, F) features of every sample (module docstring), float64.

    Parameters
    ----------
    acc_b, gyro_b : ndarray, shape (N, 3)
        Specific force (m/s²) and angular rate (rad/s, bias removed), finite.
    dt : float
        Sample period, s.
    gravity_mps2 : float
        Gravity as this sensor reads it at rest, m/s².
    bad : ndarray of bool, shape (N,), optional
        Samples left out of the noise-floor quantile (saturated).
    """
    from scipy.ndimage import maximum_filter1d, minimum_filter1d

    acc_b = np.asarray(acc_b, dtype=np.float64)
    gyro_b = np.asarray(gyro_b, dtype=np.float64)
    g = float(gravity_mps2)
    w2 = np.square(row_norm(gyro_b))
    a2 = np.square(row_norm(acc_b))
    cols = []
    gyro_e, acc_e = {}, {}
    for w in WINDOWS_S:
        n = window_samples(w, dt, 3)
        gyro_e[w] = np.log10(moving_mean(w2, n) + GYRO_FLOOR_RADPS**2)
        acc_term = np.maximum(moving_mean(a2, n) - 2.0 * g * row_norm(moving_mean(acc_b, n)) + g * g, 0.0)
        acc_e[w] = np.log10(acc_term + ACC_FLOOR_MPS2**2)
    cols += [gyro_e[w] for w in WINDOWS_S] + [acc_e[w] for w in WINDOWS_S]
    n0 = window_samples(BASE_WINDOW_S, dt, 3)
    T = shoe_statistic(acc_b, gyro_b, n0, SIGMA_ACC_MPS2, SIGMA_GYRO_RADPS, g)
    L = np.log10(T + (ACC_FLOOR_MPS2 / SIGMA_ACC_MPS2) ** 2)
    span = window_samples(SPAN_S, dt, 3)
    lo = minimum_filter1d(L, span, mode="nearest")
    hi = maximum_filter1d(L, span, mode="nearest")
    cols.append((L - lo) / (hi - lo + 0.1))
    usable = L if bad is None or not (~np.asarray(bad, bool)).any() else L[~np.asarray(bad, bool)]
    cols.append(L - float(np.quantile(usable, NOISE_QUANTILE)))
    for o in OFFSETS_S:
        cols.append(_shift(gyro_e[BASE_WINDOW_S], int(round(o / dt))))
    for o in OFFSETS_S:
        cols.append(_shift(acc_e[BASE_WINDOW_S], int(round(o / dt))))
    return np.column_stack(cols)


@dataclass(frozen=True)
class StanceModel:
    """A trained model: feature standardisation, dense layers (tanh hidden, sigmoid output), provenance."""

    mean: np.ndarray
    scale: np.ndarray
    layers: tuple  # ((W (F_in, F_out), b (F_out,)), ...)
    provenance: dict

    def probability(self, features: np.ndarray) -> np.ndarray:
        """p(stance) (N,) of (N, F) features."""
        h = (features - self.mean) / self.scale
        for i, (w, b) in enumerate(self.layers):
            h = h @ w + b
            if i < len(self.layers) - 1:
                h = np.tanh(h)
        z = h[:, 0]
        return 0.5 * (1.0 + np.tanh(0.5 * z))  # the logistic function, without overflow

    def to_dict(self) -> dict:
        return {"format": "bootnav-stance-model", "feature_version": FEATURE_VERSION, "features": feature_names(),
                "mean": self.mean.tolist(), "scale": self.scale.tolist(),
                "layers": [{"W": w.tolist(), "b": b.tolist()} for w, b in self.layers],
                "provenance": self.provenance}

    @classmethod
    def from_dict(cls, doc: dict, where: str = "model") -> "StanceModel":
        if not isinstance(doc, dict) or doc.get("format") != "bootnav-stance-model":
            raise ValueError(f"{where}: not a bootnav stance model (no 'format': 'bootnav-stance-model')")
        if doc.get("feature_version") != FEATURE_VERSION or doc.get("features") != feature_names():
            raise ValueError(f"{where}: trained on feature version {doc.get('feature_version')}, this bootnav "
                             f"computes version {FEATURE_VERSION}; retrain it (benchmarks/learned_stance.py train)")
        mean = np.asarray(doc["mean"], float)
        scale = np.asarray(doc["scale"], float)
        layers = tuple((np.asarray(lay["W"], float), np.asarray(lay["b"], float)) for lay in doc["layers"])
        n_in = len(feature_names())
        shapes_ok = mean.shape == scale.shape == (n_in,) and np.all(scale > 0) and layers
        for w, b in layers:
            shapes_ok = shapes_ok and w.ndim == 2 and w.shape[0] == n_in and b.shape == (w.shape[1],)
            n_in = w.shape[1] if w.ndim == 2 else -1
        if not shapes_ok or n_in != 1 or not all(np.isfinite(w).all() and np.isfinite(b).all() for w, b in layers):
            raise ValueError(f"{where}: inconsistent layer shapes or non-finite weights")
        return cls(mean, scale, layers, dict(doc.get("provenance", {})))


@lru_cache(maxsize=8)
def load_model(path: str = "") -> StanceModel:
    """The model in the JSON file ``path`` ("" = the shipped one); ValueError naming the file otherwise."""
    p = Path(path) if path else SHIPPED_MODEL
    try:
        doc = json.loads(p.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"stance model {p}: cannot be read ({exc})") from None
    return StanceModel.from_dict(doc, str(p))


@register("learned")
@dataclass(kw_only=True)
class LearnedDetector(StanceDetector):
    """A tiny network on windowed physical features, trained on motion-capture stance (not the default) [Wagstaff2020]

    model: path of a model JSON written by ``benchmarks/learned_stance.py train``; "" = the shipped one
        (``learned_stance.json``, its provenance inside).
    probability: stance where the model's p(stance) is at least this; 0.5 is the labels' own decision.
    min_swing_s, min_stance_s: as the adaptive detector's (0.1 s, 0.05 s).
    """

    BOUNDS: ClassVar[dict] = {"probability": FRACTION}

    model: str = ""
    probability: float = 0.5
    min_swing_s: float = 0.1
    min_stance_s: float = 0.05

    def check(self) -> None:
        super().check()
        load_model(self.model)  # a missing or malformed file is refused with the settings, before any work

    def classify(self, acc_b, gyro_b, dt, bad):
        model = load_model(self.model)
        p = model.probability(stance_features(acc_b, gyro_b, dt, self.gravity_mps2, bad))
        n = window_samples(BASE_WINDOW_S, dt, 3)
        info = {"window_samples": n, "window_s": n * dt, "model": self.model or SHIPPED_MODEL.name,
                "model_trained_on": model.provenance.get("trained_on", []),
                "model_date": model.provenance.get("date", "")}
        # statistic 1 − p: stance below the threshold, as every detector's
        return p >= self.probability, 1.0 - p, 1.0 - self.probability, n, info
